#include "fdv/pipeline/replay.h"

#include "fdv/io/time_ordered_merger.h"

namespace fdv {

PerceptionCounters replay(std::unique_ptr<RecordingReader> reader, const Calibration& calib,
                          const PerceptionOptions& options, const PerceptionCallbacks& callbacks,
                          ReadReport* reader_report) {
  Perception perception(calib, options, callbacks);
  std::vector<std::unique_ptr<RecordingReader>> sources;
  sources.push_back(std::move(reader));
  TimeOrderedMerger merger(std::move(sources));
  StreamItem item;
  while (merger.next(item)) {
    switch (item.kind) {
      case StreamKind::kEvents:
        perception.push_events(item.events);
        break;
      case StreamKind::kImu:
        perception.push_imu(*item.imu);
        break;
      case StreamKind::kDepth:
        perception.push_depth(*item.depth);
        break;
      case StreamKind::kOdometry:
        perception.push_odometry(*item.odometry);
        break;
      case StreamKind::kGroundTruth:
        break;  // evaluation only, never the pipeline
    }
  }
  perception.finish();
  if (reader_report) {  // the pipeline's own drops beside the reader's: one report of the input
    *reader_report = merger.source(0).report();
    reader_report->merge(perception.input_report());
  }
  return perception.counters();
}

}  // namespace fdv
