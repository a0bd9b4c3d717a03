#include "fdv/io/time_ordered_merger.h"

#include <gtest/gtest.h>

#include <random>

namespace fdv {
namespace {

RecordingInfo info_with(std::vector<StreamKind> streams) {
  RecordingInfo info;
  info.format = "memory";
  info.width = 100;
  info.height = 100;
  info.streams = std::move(streams);
  return info;
}

// A reader whose streams are badly out of step: all IMU first, then all events. The merger
// must still interleave them by time.
class SkewedReader final : public RecordingReader {
 public:
  SkewedReader(std::vector<Event> e, std::vector<ImuSample> i)
      : info_(info_with({StreamKind::kEvents, StreamKind::kImu})), events_(std::move(e)), imu_(std::move(i)) {}
  const RecordingInfo& info() const override { return info_; }
  const ReadReport& report() const override { return report_; }
  bool read(SensorChunk& c) override {
    c.clear();
    if (imu_pos_ < imu_.size()) {
      c.imu.push_back(imu_[imu_pos_++]);
      return true;
    }
    if (event_pos_ < events_.size()) {
      for (int k = 0; k < 7 && event_pos_ < events_.size(); ++k) c.events.push_back(events_[event_pos_++]);
      return true;
    }
    return false;
  }

 private:
  RecordingInfo info_;
  ReadReport report_;
  std::vector<Event> events_;
  std::vector<ImuSample> imu_;
  std::size_t imu_pos_ = 0, event_pos_ = 0;
};

struct Flat {
  std::vector<std::pair<TimeNs, StreamKind>> order;
  std::vector<Event> events;
  std::size_t imu = 0, odometry = 0, depth = 0;
};

Flat drain(TimeOrderedMerger& m) {
  Flat f;
  StreamItem item;
  while (m.next(item)) {
    if (item.kind == StreamKind::kEvents) {
      EXPECT_FALSE(item.events.empty());
      for (const auto& e : item.events) f.order.emplace_back(e.t, item.kind), f.events.push_back(e);
    } else {
      f.order.emplace_back(item.t, item.kind);
      f.imu += item.kind == StreamKind::kImu;
      f.odometry += item.kind == StreamKind::kOdometry;
      f.depth += item.kind == StreamKind::kDepth;
    }
  }
  return f;
}

bool non_decreasing(const Flat& f) {
  for (std::size_t i = 1; i < f.order.size(); ++i)
    if (f.order[i].first < f.order[i - 1].first) return false;
  return true;
}

TEST(TimeOrderedMerger, InterleavesStreamsThatArriveOutOfStep) {
  std::vector<Event> events;
  for (int i = 0; i < 100; ++i) events.push_back({i * 10, 1, 1, true});
  std::vector<ImuSample> imu;
  for (int i = 0; i < 10; ++i) imu.push_back({i * 100 + 5, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});
  std::vector<std::unique_ptr<RecordingReader>> sources;
  sources.push_back(std::make_unique<SkewedReader>(events, imu));
  TimeOrderedMerger merger(std::move(sources), 16);
  const Flat f = drain(merger);
  EXPECT_EQ(f.events, events);
  EXPECT_EQ(f.imu, 10u);
  EXPECT_TRUE(non_decreasing(f));
  // By hand: IMU at t=105 comes right after the event at t=100 and before the one at t=110.
  const auto it = std::find(f.order.begin(), f.order.end(), std::make_pair(TimeNs{105}, StreamKind::kImu));
  ASSERT_NE(it, f.order.end());
  EXPECT_EQ((it - 1)->first, 100);
  EXPECT_EQ((it + 1)->first, 110);
}

TEST(TimeOrderedMerger, MergesSeveralRecordingsCompletelyAndInOrder) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<TimeNs> dt(0, 50);
  auto make = [&](int n_events, int n_odo, int n_depth) {
    SensorChunk d;
    TimeNs t = 0;
    for (int i = 0; i < n_events; ++i) d.events.push_back({t += dt(rng), 2, 3, false});
    t = 0;
    for (int i = 0; i < n_odo; ++i) {
      OdometrySample o;
      o.t = (t += 20 * dt(rng));
      d.odometry.push_back(o);
    }
    t = 0;
    for (int i = 0; i < n_depth; ++i) d.depth.push_back({t += 200 * dt(rng), 1, 1, {1.0f}});
    return d;
  };
  std::vector<std::unique_ptr<RecordingReader>> sources;
  sources.push_back(std::make_unique<MemoryRecording>(
      info_with({StreamKind::kEvents}), make(5000, 0, 0), 333));
  sources.push_back(std::make_unique<MemoryRecording>(
      info_with({StreamKind::kOdometry, StreamKind::kDepth}), make(0, 200, 20), 50));
  TimeOrderedMerger merger(std::move(sources), 100);
  const Flat f = drain(merger);
  EXPECT_EQ(f.events.size(), 5000u);
  EXPECT_EQ(f.odometry, 200u);
  EXPECT_EQ(f.depth, 20u);
  EXPECT_TRUE(non_decreasing(f));
  EXPECT_TRUE(merger.report().repaired().empty());
}

TEST(TimeOrderedMerger, ADeclaredButSilentStreamDoesNotHoldEverythingBack) {
  SensorChunk d;
  for (int i = 0; i < 1000; ++i) d.events.push_back({i, 1, 1, true});
  std::vector<std::unique_ptr<RecordingReader>> sources;
  // Declares IMU but never produces any: the merger may buffer at most 100 events waiting.
  sources.push_back(std::make_unique<MemoryRecording>(
      info_with({StreamKind::kEvents, StreamKind::kImu}), d, 50));
  TimeOrderedMerger merger(std::move(sources), 10, 100);
  StreamItem item;
  ASSERT_TRUE(merger.next(item));
  EXPECT_EQ(item.kind, StreamKind::kEvents);
  EXPECT_EQ(item.t, 0);
  std::size_t n = item.events.size();
  while (merger.next(item)) n += item.events.size();
  EXPECT_EQ(n, 1000u);
}

}  // namespace
}  // namespace fdv
