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
                            ReadReport& report, const std::string& where) {
  std::uint64_t backwards = 0, outside = 0, far_ahead = 0;
  // b follows a: not behind it, at most kMaxForwardJumpNs ahead (unsigned: no overflow).
  const auto follows = [](TimeNs a, TimeNs b) {
    return b >= a && static_cast<std::uint64_t>(b) - static_cast<std::uint64_t>(a) <=
                         static_cast<std::uint64_t>(kMaxForwardJumpNs);
  };
  // Locals in the loop: out.push_back may alias the members as far as the compiler knows.
  TimeNs t_last = last_t_;
  bool started = t_last != std::numeric_limits<TimeNs>::min(), holding = held_.has_value();
  for (const Event* e = first; e != last; ++e) {
    if (e->x >= width_ || e->y >= height_) {
      ++outside;
    } else if (e->t < t_last) {
      ++backwards;
    } else if (holding || (started && !follows(t_last, e->t))) [[unlikely]] {
      if (!holding) {  // the class comment: held until the next event decides
        held_ = *e;
        holding = true;
      } else if (follows(t_last, e->t)) {  // the held time was corrupt
        ++far_ahead;
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
        ++far_ahead;
        held_ = *e;
      }
    } else {
      t_last = e->t;
      started = true;
      out.push_back(*e);
    }
  }
  last_t_ = t_last;
  if (outside) report.drop("event pixel outside the sensor", where, outside);
  if (backwards) report.drop("event timestamp went backwards", where, backwards);
  if (far_ahead) report.drop("event time far ahead of the stream", where, far_ahead);
}

}  // namespace fdv
