#include "fdv/detection/hot_pixels.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "fdv/core/error.h"

namespace fdv {

std::string HotPixelOptions::validate() const {
  std::ostringstream why;
  if (!std::isfinite(memory_windows) || !std::isfinite(min_firing) || !std::isfinite(max_neighbour_firing))
    why << "hot_pixels: non-finite parameter";
  else if (!(memory_windows > 1 && memory_windows <= 1000))
    why << "hot_pixels_memory_windows must be in (1, 1000], got " << memory_windows;
  else if (!(min_firing > 0 && min_firing < 1)) why << "hot_pixels_min_firing must be in (0, 1), got " << min_firing;
  else if (!(max_neighbour_firing >= 0 && max_neighbour_firing < 1))
    why << "hot_pixels_max_neighbour_firing must be in [0, 1), got " << max_neighbour_firing;
  return why.str();
}

HotPixelFilter::HotPixelFilter(const HotPixelOptions& options, int width, int height)
    : options_(options), width_(width), height_(height) {
  if (const std::string why = options.validate(); !why.empty()) throw ConfigError("detector: " + why);
  if (width <= 0 || height <= 0) throw ConfigError("hot pixel filter: the sensor size must be positive");
  alpha_ = static_cast<float>(1.0 - 1.0 / options.memory_windows);
  // αⁿ until it no longer matters (below 1e-6 of a firing fraction): a longer silence is 0.
  for (float p = 1; p > 1e-6f; p *= alpha_) alpha_pow_.push_back(p);
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  state_.resize(n);
  hot_.assign(n, 0);
  steady_.reserve(n);
}

namespace {
constexpr float kFiringScale = 65535.0f;
}

float HotPixelFilter::decayed(const PixelState& s) const {
  const std::size_t age = static_cast<std::uint16_t>(static_cast<std::uint16_t>(now_) - s.last);
  return age < alpha_pow_.size() ? static_cast<float>(s.firing) / kFiringScale * alpha_pow_[age] : 0.0f;
}

void HotPixelFilter::forget_old() {
  for (PixelState& s : state_)
    if (static_cast<std::uint16_t>(static_cast<std::uint16_t>(now_) - s.last) >= kForgetAge) s.firing = 0;
}

bool HotPixelFilter::evaluate(std::int32_t pixel) const {
  if (decayed(state_[static_cast<std::size_t>(pixel)]) < options_.min_firing) return false;
  const int x = pixel % width_, y = pixel / width_;
  double sum = 0;
  int neighbours = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int nx = x + dx, ny = y + dy;
      if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= width_ || ny >= height_) continue;
      sum += decayed(state_[static_cast<std::size_t>(ny) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(nx)]);
      ++neighbours;
    }
  return neighbours > 0 && sum <= options_.max_neighbour_firing * neighbours;
}

std::size_t HotPixelFilter::filter(std::vector<Event>& events, std::uint64_t window_index) {
  if (now_ < 0) first_window_ = window_index;
  const std::int32_t k = static_cast<std::int32_t>(window_index - first_window_);
  if (k < now_) throw std::logic_error("hot pixel filter: window indices must increase");
  // Every kForgetAge windows (and after a jump of as many), states that old are zeroed.
  if (now_ < 0 || k / kForgetAge != now_ / kForgetAge) {
    now_ = k;
    forget_old();
  }
  now_ = k;

  // Count this window: f ← f·α^(k − last) + (1 − α) on each pixel's first event.
  steady_.clear();
  const float gain = 1.0f - alpha_;
  const auto this_window = static_cast<std::uint16_t>(k);
  const auto min_firing = static_cast<float>(options_.min_firing);
  for (const Event& e : events) {
    if (e.x >= width_ || e.y >= height_) continue;
    const std::int32_t p = static_cast<std::int32_t>(e.y) * width_ + e.x;
    PixelState& s = state_[static_cast<std::size_t>(p)];
    if (s.last == this_window && s.firing != 0) continue;
    const float f = std::min(1.0f, decayed(s) + gain);
    s.firing = static_cast<std::uint16_t>(std::lround(f * kFiringScale));
    s.last = this_window;
    if (f >= min_firing) steady_.push_back(p);
  }

  // The verdicts: the pixels that fired steadily this window, and those hot before (they may have
  // stopped, or their neighbours started). Everything else keeps f below min_firing.
  next_hot_.clear();
  for (const std::int32_t p : hot_list_) hot_[static_cast<std::size_t>(p)] = 0;
  for (const std::int32_t p : hot_list_)
    if (evaluate(p)) next_hot_.push_back(p);
  for (const std::int32_t p : steady_)
    if (evaluate(p)) next_hot_.push_back(p);
  hot_list_.clear();
  for (const std::int32_t p : next_hot_) {
    std::uint8_t& h = hot_[static_cast<std::size_t>(p)];
    if (!h) hot_list_.push_back(p);  // a pixel both hot before and fired now is listed once
    h = 1;
  }
  if (hot_list_.empty()) return 0;

  const std::size_t before = events.size();
  std::erase_if(events, [this](const Event& e) {
    return e.x < width_ && e.y < height_ && hot_[static_cast<std::size_t>(e.y) * static_cast<std::size_t>(width_) + e.x];
  });
  return before - events.size();
}

bool HotPixelFilter::is_hot(int x, int y) const {
  return x >= 0 && y >= 0 && x < width_ && y < height_ &&
         hot_[static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x)] != 0;
}

double HotPixelFilter::firing(int x, int y) const {
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return 0;
  return decayed(state_[static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x)]);
}

int HotPixelFilter::windows_to_learn() const {
  int n = 1;
  for (double f = 1.0 - alpha_; f < options_.min_firing; f = f * alpha_ + (1.0 - alpha_)) ++n;
  return n;
}

}  // namespace fdv
