#include "fdv/io/recording_summary.h"

namespace fdv {
namespace {

struct StreamSummary {
  std::uint64_t count = 0;
  TimeNs first = 0, last = 0;
  template <typename T>
  void add(const std::vector<T>& items) {
    if (items.empty()) return;
    if (count == 0) first = items.front().t;
    last = items.back().t;
    count += items.size();
  }
  nlohmann::json to_json() const {
    nlohmann::json j = {{"count", count}};
    if (count) j["first_s"] = to_seconds(first), j["last_s"] = to_seconds(last);
    return j;
  }
};

}  // namespace

nlohmann::json summarize_recording(RecordingReader& reader) {
  StreamSummary events, imu, depth, odometry, truth;
  std::uint64_t on_events = 0;
  SensorChunk chunk;
  while (reader.read(chunk)) {
    events.add(chunk.events);
    for (const auto& e : chunk.events) on_events += e.polarity;
    imu.add(chunk.imu);
    depth.add(chunk.depth);
    odometry.add(chunk.odometry);
    truth.add(chunk.ground_truth);
  }
  const auto& info = reader.info();
  nlohmann::json j;
  j["path"] = info.path;
  j["format"] = info.format;
  j["resolution"] = {info.width, info.height};
  j["events"] = events.count;
  j["events_on"] = on_events;
  if (events.count) {
    j["first_t_s"] = to_seconds(events.first);
    j["last_t_s"] = to_seconds(events.last);
    // No overflow: readers hand out only valid_time() times, whose differences fit (core/time.h).
    j["duration_s"] = to_seconds(events.last - events.first);
  }
  j["imu"] = imu.to_json();
  j["depth"] = depth.to_json();
  j["odometry"] = odometry.to_json();
  j["ground_truth"] = truth.to_json();
  j["calibration"] = info.calibration.has_value();
  j["notes"] = info.notes;
  if (!info.topics.empty()) {
    j["topics"] = nlohmann::json::array();
    for (const auto& t : info.topics)
      j["topics"].push_back(
          {{"topic", t.topic}, {"type", t.type}, {"count", t.count}, {"rate_hz", t.rate_hz}});
  }
  j["report"] = reader.report().to_json();
  return j;
}

}  // namespace fdv
