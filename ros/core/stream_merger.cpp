#include "stream_merger.h"

#include <fmt/format.h>

#include <algorithm>
#include <span>

namespace fdv::ros_core {

StreamMerger::StreamMerger(const NodeConfig& config, Warn warn)
    : max_hold_(from_seconds(config.max_hold_s)),
      missing_after_(from_seconds(config.missing_after_s)),
      max_hold_s_(config.max_hold_s),
      missing_after_s_(config.missing_after_s),
      warn_(std::move(warn)) {
  for (Stream s : kStreams)
    awaited_[index(s)] = subscribed(config, s) && (s != Stream::kDepth || config.wait_for_depth);
}

void StreamMerger::clear() {
  events_.clear(), imu_.clear(), depth_.clear(), odometry_.clear();
  events_released_ = 0;
  for (Progress& p : progress_) p.newest = kBeforeAll, p.seen = false, p.missing = false;
  first_t_ = kNever, newest_t_ = kBeforeAll, released_until_ = kBeforeAll;
}

void StreamMerger::note_time(Stream stream, TimeNs first, TimeNs last) {
  Progress& p = progress_[index(stream)];
  p.seen = true;
  p.newest = std::max(p.newest, last);
  first_t_ = std::min(first_t_, first);
  newest_t_ = std::max(newest_t_, last);
  if (first < released_until_) {
    ++p.late;
    warn_(std::string("late ") + to_string(stream),
          fmt::format(
              "{} arrived {:.1f} ms behind the streams already processed: used late ({} so far; a "
              "stream lagging over {} s of stream time is not waited for)",
              to_string(stream), to_seconds(released_until_ - first) * 1e3, p.late, max_hold_s_));
  }
}

void StreamMerger::hold(Stream stream, SensorChunk& chunk) {
  switch (stream) {
    case Stream::kEvents:
      if (chunk.events.empty()) return;
      note_time(stream, chunk.events.front().t, chunk.events.back().t);
      events_.push_back(std::move(chunk.events));
      chunk.events.clear();
      break;
    case Stream::kImu:
      for (const ImuSample& s : chunk.imu) note_time(stream, s.t, s.t), imu_.push_back(s);
      break;
    case Stream::kDepth:
      for (DepthFrame& f : chunk.depth) note_time(stream, f.t, f.t), depth_.push_back(std::move(f));
      break;
    case Stream::kOdometry:
      for (const OdometrySample& s : chunk.odometry)
        note_time(stream, s.t, s.t), odometry_.push_back(s);
      break;
  }
}

std::array<TimeNs, kStreams.size()> StreamMerger::awaited_until() {
  std::array<TimeNs, kStreams.size()> until;
  until.fill(kNever);
  if (first_t_ == kNever) return until;  // nothing received: nothing held, no stream time yet
  for (Stream s : kStreams) {
    if (!awaited_[index(s)]) continue;
    Progress& p = progress_[index(s)];
    const TimeNs newest = p.seen ? p.newest : first_t_;
    if (!p.seen && !p.missing && newest_t_ - first_t_ > missing_after_) {
      p.missing = true;
      warn_(std::string("missing ") + to_string(s),
            fmt::format(
                "no {} message in the first {} s of stream time: not awaited while it is silent",
                to_string(s), missing_after_s_));
    }
    if (newest_t_ - newest > max_hold_) continue;  // silent: not awaited
    until[index(s)] = newest;
  }
  return until;
}

TimeNs StreamMerger::held_time(Stream s) const {
  switch (s) {
    case Stream::kEvents:
      return events_.empty() ? kNever : events_.front()[events_released_].t;
    case Stream::kImu:
      return imu_.empty() ? kNever : imu_.front().t;
    case Stream::kDepth:
      return depth_.empty() ? kNever : depth_.front().t;
    case Stream::kOdometry:
      return odometry_.empty() ? kNever : odometry_.front().t;
  }
  return kNever;
}

void StreamMerger::release(Perception& perception, bool everything) {
  std::array<StreamFront, kStreams.size()> fronts;
  if (!everything) {
    const auto until = awaited_until();
    for (Stream s : kStreams) fronts[index(s)].next = until[index(s)];
  }
  while (true) {
    for (Stream s : kStreams) fronts[index(s)].held = held_time(s);
    const TimeOrderStep step = next_in_time_order(fronts);
    if (step.earliest == TimeOrderStep::kNone || step.waiting_for != TimeOrderStep::kNone) return;
    released_until_ = std::max(released_until_, fronts[step.earliest].held);
    switch (kStreams[step.earliest]) {
      case Stream::kEvents: {
        // The front message's events up to run_until (at least one), handed over in place.
        const std::vector<Event>& front = events_.front();
        const auto first = front.begin() + static_cast<std::ptrdiff_t>(events_released_);
        auto last = std::upper_bound(first, front.end(), step.run_until,
                                     [](TimeNs t, const Event& e) { return t < e.t; });
        if (last == first) ++last;
        released_until_ = std::max(released_until_, (last - 1)->t);
        perception.push_events(
            std::span<const Event>(&*first, static_cast<std::size_t>(last - first)));
        events_released_ = static_cast<std::size_t>(last - front.begin());
        if (events_released_ == front.size()) {
          events_.pop_front();
          events_released_ = 0;
        }
        break;
      }
      case Stream::kImu:
        perception.push_imu(imu_.front());
        imu_.pop_front();
        break;
      case Stream::kDepth:
        perception.push_depth(depth_.front());
        depth_.pop_front();
        break;
      case Stream::kOdometry:
        perception.push_odometry(odometry_.front());
        odometry_.pop_front();
        break;
    }
  }
}

}  // namespace fdv::ros_core
