#include "fdv/io/recording.h"

#include <string>

namespace fdv {

const char* to_string(StreamKind kind) {
  switch (kind) {
    case StreamKind::kEvents: return "events";
    case StreamKind::kImu: return "imu";
    case StreamKind::kDepth: return "depth";
    case StreamKind::kOdometry: return "odometry";
    case StreamKind::kGroundTruth: return "ground_truth";
  }
  return "?";
}

void SensorChunk::clear() {
  events.clear();
  imu.clear();
  depth.clear();
  odometry.clear();
  ground_truth.clear();
}

bool SensorChunk::empty() const {
  return events.empty() && imu.empty() && depth.empty() && odometry.empty() && ground_truth.empty();
}

void EventSanitizer::append(const Event* first, const Event* last, std::vector<Event>& out,
                            ReadReport& report, const EventLocator& where) {
  // Per reason: the count in this batch and the index of its first event (located once, at the end).
  struct Dropped {
    std::uint64_t n = 0;
    std::size_t first = 0;
    void add(std::size_t i) {
      if (n++ == 0) first = i;
    }
  } corrupt, outside, backwards;
  std::uint64_t far_ahead = 0;
  std::string far_ahead_where;  // the held event's: it may come from an earlier batch
  auto drop_held = [&] {
    if (far_ahead++ == 0) far_ahead_where = held_where_;
  };
  // b follows a: not behind it, at most kMaxForwardJumpNs ahead (unsigned: no overflow).
  const auto follows = [](TimeNs a, TimeNs b) {
    return b >= a && static_cast<std::uint64_t>(b) - static_cast<std::uint64_t>(a) <=
                         static_cast<std::uint64_t>(kMaxForwardJumpNs);
  };
  // Locals in the loop: out.push_back may alias the members as far as the compiler knows.
  TimeNs t_last = last_t_;
  bool started = t_last != std::numeric_limits<TimeNs>::min(), holding = held_.has_value();
  for (const Event* e = first; e != last; ++e) {
    const auto i = static_cast<std::size_t>(e - first);
    if (!valid_time(e->t)) [[unlikely]] {
      corrupt.add(i);
    } else if (e->x >= width_ || e->y >= height_) {
      outside.add(i);
    } else if (e->t < t_last) {
      backwards.add(i);
    } else if (holding || (started && !follows(t_last, e->t))) [[unlikely]] {
      if (!holding) {  // the class comment: held until the next event decides
        held_ = *e;
        held_where_ = where(i);
        holding = true;
      } else if (follows(t_last, e->t)) {  // the held time was corrupt
        drop_held();
        held_.reset();
        holding = false;
        t_last = e->t;
        out.push_back(*e);
      } else if (follows(held_->t, e->t)) {  // a real jump
        out.push_back(*held_);
        held_.reset();
        holding = false;
        t_last = e->t;
        out.push_back(*e);
      } else {  // far ahead of both: the older one cannot be right
        drop_held();
        held_ = *e;
        held_where_ = where(i);
      }
    } else {
      t_last = e->t;
      started = true;
      out.push_back(*e);
    }
  }
  last_t_ = t_last;
  if (corrupt.n) report.drop("event time out of range (corrupt)", where(corrupt.first), corrupt.n);
  if (outside.n) report.drop("event pixel outside the sensor", where(outside.first), outside.n);
  if (backwards.n) report.drop("event timestamp went backwards", where(backwards.first), backwards.n);
  if (far_ahead) report.drop("event time far ahead of the stream", far_ahead_where, far_ahead);
}

}  // namespace fdv
