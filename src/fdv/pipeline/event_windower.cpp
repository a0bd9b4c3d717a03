#include "fdv/pipeline/event_windower.h"

namespace fdv {

std::string EventWindowerOptions::validate() const {
  if (window_ns <= 0) return "window_ns must be positive";
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
  if (buffer_.size() > options_.max_events_per_window) {
    // Keep every k-th event, k = ceil(n / cap): uniform in time, polarity and place.
    const std::size_t k = (buffer_.size() + options_.max_events_per_window - 1) / options_.max_events_per_window;
    decimated_.clear();
    for (std::size_t i = 0; i < buffer_.size(); i += k) decimated_.push_back(buffer_[i]);
    w.decimated = buffer_.size() - decimated_.size();
    w.events = decimated_;
  } else {
    w.events = buffer_;
  }
  on_window(w);
  buffer_.clear();
  t_start_ += options_.window_ns;
}

void EventWindower::advance_to(TimeNs t, const Callback& on_window) {
  if (!started_) return;
  while (t >= t_start_ + options_.window_ns) emit(on_window);
}

void EventWindower::push(std::span<const Event> events, const Callback& on_window) {
  for (const Event& e : events) {
    if (!started_) {
      started_ = true;
      t_start_ = e.t;
    }
    if (e.t >= t_start_ + options_.window_ns) advance_to(e.t, on_window);
    buffer_.push_back(e);
  }
}

void EventWindower::flush(const Callback& on_window) {
  if (started_ && !buffer_.empty()) emit(on_window);
}

}  // namespace fdv
