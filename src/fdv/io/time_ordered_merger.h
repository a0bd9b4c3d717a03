#pragma once
/// Merges every stream of one or more recordings into one time order, streaming.
///
///   std::vector<std::unique_ptr<RecordingReader>> sources;
///   sources.push_back(open_recording("run.aedat4"));
///   sources.push_back(open_recording("depth_and_odometry_folder"));
///   TimeOrderedMerger merger(std::move(sources));
///   StreamItem item;
///   while (merger.next(item)) {
///     switch (item.kind) { case StreamKind::kEvents: use(item.events); break; ... }
///   }
///
/// Each item is either a run of events (all with times not after any item still to come) or one
/// IMU / depth / odometry / ground-truth record. Readers hand out their streams in chunks that
/// need not be aligned with each other; the merger holds an item back until every other stream
/// has moved past its time (each stream is non-decreasing by the reader contract), pulling more
/// chunks as needed. A stream that stays silent while more than `max_buffered_events` events
/// wait is treated as caught up (bounded memory); such items are counted in report() under
/// "merged past a silent stream". Views in StreamItem stay valid until the next call. Not thread-safe.
#include <deque>
#include <memory>
#include <span>
#include <vector>

#include "fdv/io/recording.h"
#include "fdv/io/time_order.h"

namespace fdv {

struct StreamItem {
  StreamKind kind = StreamKind::kEvents;
  TimeNs t = 0;                    ///< time of the item (of the first event of a run)
  std::span<const Event> events;   ///< kEvents
  const ImuSample* imu = nullptr;  ///< kImu
  const DepthFrame* depth = nullptr;
  const OdometrySample* odometry = nullptr;
  const ObjectState* ground_truth = nullptr;
  std::size_t source = 0;  ///< index of the recording it came from
};

class TimeOrderedMerger {
 public:
  explicit TimeOrderedMerger(std::vector<std::unique_ptr<RecordingReader>> sources,
                             std::size_t max_event_run = 1 << 14,
                             std::size_t max_buffered_events = 1 << 22);
  /// The next item in time order; false when every source is exhausted.
  bool next(StreamItem& item);
  const RecordingReader& source(std::size_t i) const { return *sources_[i].reader; }
  std::size_t source_count() const { return sources_.size(); }
  /// The merger's own report (held-back limits); each reader keeps its own.
  const ReadReport& report() const { return report_; }

 private:
  static constexpr std::size_t kKinds = 5;
  struct Source {
    std::unique_ptr<RecordingReader> reader;
    bool exhausted = false;
    bool declares[kKinds] = {};
    TimeNs high_water[kKinds];
    std::deque<Event> events;
    std::deque<ImuSample> imu;
    std::deque<DepthFrame> depth;
    std::deque<OdometrySample> odometry;
    std::deque<ObjectState> truth;
  };
  bool pull(Source& s);
  std::size_t buffered_events() const;
  /// Earliest time any not-yet-buffered item of (s, kind) can have; +inf if none can come.
  TimeNs future_bound(const Source& s, std::size_t kind) const;
  TimeNs head_time(const Source& s, std::size_t kind) const;

  std::vector<Source> sources_;
  std::vector<StreamFront> fronts_;  ///< every (source, kind), for next_in_time_order
  std::size_t max_event_run_, max_buffered_events_;
  SensorChunk chunk_;
  std::vector<Event> run_;
  ImuSample imu_out_;
  DepthFrame depth_out_;
  OdometrySample odometry_out_;
  ObjectState truth_out_;
  ReadReport report_;
};

/// A RecordingReader over data already in memory (tests, the simulator, live adapters).
/// Hands the data out in chunks of about `chunk_events` events like a file reader does.
class MemoryRecording final : public RecordingReader {
 public:
  MemoryRecording(RecordingInfo info, SensorChunk data, std::size_t chunk_events = 1 << 16);
  const RecordingInfo& info() const override { return info_; }
  bool read(SensorChunk& chunk) override;
  const ReadReport& report() const override { return report_; }

 private:
  RecordingInfo info_;
  SensorChunk data_;
  std::size_t chunk_events_;
  std::size_t event_pos_ = 0, imu_pos_ = 0, depth_pos_ = 0, odometry_pos_ = 0, truth_pos_ = 0;
  ReadReport report_;
};

}  // namespace fdv
