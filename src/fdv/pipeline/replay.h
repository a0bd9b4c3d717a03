#pragma once
/// Replaying a recording through the pipeline: every stream in time order into a Perception.
///
///   PerceptionCounters c = replay(open_recording(path), calib, options, callbacks);
#include <memory>

#include "fdv/io/read_report.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/perception.h"

namespace fdv {

/// Feeds every stream of `reader` in time order into a Perception built from `calib`, `options`
/// and `callbacks`, then finishes it. Ground truth streams are never fed. Returns the counters.
PerceptionCounters replay(std::unique_ptr<RecordingReader> reader, const Calibration& calib,
                          const PerceptionOptions& options, const PerceptionCallbacks& callbacks,
                          ReadReport* reader_report = nullptr);

}  // namespace fdv
