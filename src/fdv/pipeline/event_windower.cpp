#include "fdv/pipeline/event_windower.h"

#include <algorithm>

namespace fdv {

std::string EventWindowerOptions::validate() const {
  if (window_ns <= 0) return "window_ms must be positive";
  if (window_ns > kMaxWindowNs)
    return "window_ms must be at most " + std::to_string(kMaxWindowNs / kNsPerMs) +
           " (a window's buffers grow with its length)";
  if (step_ns < 0 || step_ns > window_ns) return "step_ms must be in [0, window_ms] (0 = window_ms)";
  if (window_ns % step() != 0) return "window_ms must be a multiple of step_ms";
  if (overlap() > kMaxWindowOverlap)
    return "step_ms must be at least window_ms / " + std::to_string(kMaxWindowOverlap) + " (each window is computed anew)";
  if (max_events_per_window == 0) return "max_events_per_window must be positive";
  return {};
}

EventWindower::EventWindower(const EventWindowerOptions& options) : options_(options) {
  buffer_.reserve(1 << 16);
}

void EventWindower::emit(const Callback& on_window) {
  EventWindow w;
  w.t_start = t_start_;
  w.t_end = t_start_ + options_.window_ns;
  w.index = next_index_++;
  w.skipped_before = skipped_pending_;
  skipped_pending_ = 0;
  const std::span<const Event> open(buffer_.begin() + static_cast<std::ptrdiff_t>(head_), buffer_.end());
  empty_run_ = open.empty() ? empty_run_ + 1 : 0;
  const bool overlapping = options_.step() < options_.window_ns;
  if (open.size() > options_.max_events_per_window) {
    // Keep every k-th event, k = ceil(n / cap): uniform in time, polarity and place.
    const std::size_t k = (open.size() + options_.max_events_per_window - 1) / options_.max_events_per_window;
    window_.clear();
    for (std::size_t i = 0; i < open.size(); i += k) window_.push_back(open[i]);
    w.decimated = open.size() - window_.size();
    w.events = window_;
    w.storage = &window_;
  } else if (overlapping) {  // the later windows need these events too: hand out a copy
    window_.assign(open.begin(), open.end());
    w.events = window_;
    w.storage = &window_;
  } else {
    w.events = open;
    w.storage = &buffer_;
  }
  on_window(w);
  t_start_ += options_.step();
  if (!overlapping) {
    buffer_.clear(), head_ = 0;
    return;
  }
  // Events before the next window's start leave; the buffer is compacted once half of it is gone.
  while (head_ < buffer_.size() && buffer_[head_].t < t_start_) ++head_;
  if (head_ > buffer_.size() / 2) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(head_));
    head_ = 0;
  }
}

void EventWindower::advance_to(TimeNs t, const Callback& on_window) {
  if (!started_) return;
  while (t >= t_start_ + options_.window_ns) {
    if (head_ == buffer_.size() && empty_run_ >= options_.max_empty_windows) {
      // The rest of the gap: every window that ends at or before t, in one step (alignment kept;
      // unsigned difference: no overflow whatever the times).
      const auto step = static_cast<std::uint64_t>(options_.step());
      const auto n = (static_cast<std::uint64_t>(t) - static_cast<std::uint64_t>(t_start_) -
                      static_cast<std::uint64_t>(options_.window_ns)) / step + 1;
      t_start_ = static_cast<TimeNs>(static_cast<std::uint64_t>(t_start_) + n * step);
      next_index_ += n;
      skipped_pending_ += n;
      skipped_total_ += n;
      break;
    }
    emit(on_window);
  }
}

void EventWindower::push(std::span<const Event> events, const Callback& on_window) {
  if (events.empty()) return;
  if (!started_) {
    started_ = true;
    t_start_ = events.front().t;
  }
  // Event by event, the first one at or past the window's end closes it (those before it join the
  // window whatever their time): the run before that event is appended as one block.
  while (!events.empty()) {
    const TimeNs end = t_start_ + options_.window_ns;
    const auto past = std::find_if(events.begin(), events.end(), [end](const Event& e) { return e.t >= end; });
    buffer_.insert(buffer_.end(), events.begin(), past);
    if (past == events.end()) break;
    advance_to(past->t, on_window);
    events = events.subspan(static_cast<std::size_t>(past - events.begin()));
  }
}

void EventWindower::flush(const Callback& on_window) {
  if (started_ && head_ < buffer_.size()) emit(on_window);
}

}  // namespace fdv
