#include "fdv/pipeline/event_windower.h"

#include <algorithm>

namespace fdv {

std::string EventWindowerOptions::validate() const {
  if (window_ns <= 0) return "window_ms must be positive";
  if (window_ns > kMaxWindowNs)
    return "window_ms must be at most " + std::to_string(kMaxWindowNs / kNsPerMs) +
           " (a window's buffers grow with its length)";
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
  empty_run_ = buffer_.empty() ? empty_run_ + 1 : 0;
  if (buffer_.size() > options_.max_events_per_window) {
    // Keep every k-th event, k = ceil(n / cap): uniform in time, polarity and place.
    const std::size_t k = (buffer_.size() + options_.max_events_per_window - 1) / options_.max_events_per_window;
    decimated_.clear();
    for (std::size_t i = 0; i < buffer_.size(); i += k) decimated_.push_back(buffer_[i]);
    w.decimated = buffer_.size() - decimated_.size();
    w.events = decimated_;
    w.storage = &decimated_;
  } else {
    w.events = buffer_;
    w.storage = &buffer_;
  }
  on_window(w);
  buffer_.clear();
  t_start_ += options_.window_ns;
}

void EventWindower::advance_to(TimeNs t, const Callback& on_window) {
  if (!started_) return;
  while (t >= t_start_ + options_.window_ns) {
    if (buffer_.empty() && empty_run_ >= options_.max_empty_windows) {
      // The rest of the gap: every complete window before t's, in one step (alignment kept;
      // unsigned difference: no overflow whatever the times).
      const auto step = static_cast<std::uint64_t>(options_.window_ns);
      const auto n = (static_cast<std::uint64_t>(t) - static_cast<std::uint64_t>(t_start_)) / step;
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
  if (started_ && !buffer_.empty()) emit(on_window);
}

}  // namespace fdv
