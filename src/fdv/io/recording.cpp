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
  std::uint64_t backwards = 0, outside = 0;
  for (const Event* e = first; e != last; ++e) {
    if (e->x >= width_ || e->y >= height_) {
      ++outside;
    } else if (e->t < last_t_) {
      ++backwards;
    } else {
      last_t_ = e->t;
      out.push_back(*e);
    }
  }
  if (outside) report.drop("event pixel outside the sensor", where, outside);
  if (backwards) report.drop("event timestamp went backwards", where, backwards);
}

}  // namespace fdv
