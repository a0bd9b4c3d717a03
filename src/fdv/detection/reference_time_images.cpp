#include "fdv/detection/reference_time_images.h"

#include <algorithm>
#include <limits>

namespace fdv {

void reference_time_images(const CompensatedEventsView& view, TimeImages& out) {
  const int w = view.width, h = view.height;
  out.count = cv::Mat::zeros(h, w, CV_32S);
  out.sum_time_s = cv::Mat::zeros(h, w, CV_32F);
  out.mean_time_s = cv::Mat::zeros(h, w, CV_32F);
  out.normalized = cv::Mat::zeros(h, w, CV_32F);
  const std::size_t npx = static_cast<std::size_t>(w) * h;
  auto* I = out.count.ptr<std::int32_t>();
  auto* S = out.sum_time_s.ptr<float>();
  auto* T = out.mean_time_s.ptr<float>();
  auto* N = out.normalized.ptr<float>();

  // Eqs. 1-2: count and Σ(t − t0) per pixel, in event order.
  out.events = 0;
  for (std::size_t k = 0; k < std::min(view.pixel.size(), view.t_s.size()); ++k) {
    const std::int32_t p = view.pixel[k];
    if (p < 0 || static_cast<std::size_t>(p) >= npx) continue;
    ++I[p];
    S[p] += view.t_s[k];
    ++out.events;
  }
  // Eq. 3: mean time; its min and max over pixels with events.
  float t_min = std::numeric_limits<float>::infinity(), t_max = -t_min;
  double sum_t = 0;
  int pixels = 0;
  for (std::size_t i = 0; i < npx; ++i) {
    if (I[i] == 0) continue;
    T[i] = S[i] / static_cast<float>(I[i]);
    t_min = std::min(t_min, T[i]);
    t_max = std::max(t_max, T[i]);
    sum_t += T[i];
    ++pixels;
  }
  if (pixels == 0) t_min = t_max = 0;
  // Eq. 4: normalised mean time.
  const double range = static_cast<double>(t_max) - static_cast<double>(t_min);
  const double inv = pixels > 0 && range > 0 ? 1.0 / range : 0.0;
  const float scale = static_cast<float>(inv);
  for (std::size_t i = 0; i < npx; ++i)
    if (I[i] > 0) N[i] = (T[i] - t_min) * scale;
  out.pixels_with_events = pixels;
  out.t_min_s = t_min;
  out.t_max_s = t_max;
  out.mean_normalized = pixels > 0 ? (sum_t / pixels - t_min) * inv : 0.0;
}

}  // namespace fdv
