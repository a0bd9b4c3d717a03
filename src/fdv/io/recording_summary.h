#pragma once
/// The JSON summary `fdv info` prints of a recording: format, resolution, per-stream counts and
/// time spans, topics, notes, and the reader's report of what it dropped or repaired.
///
///   auto reader = fdv::open_recording("run.aedat4");
///   std::cout << fdv::summarize_recording(*reader).dump(2);
///
/// Reads the recording to its end. Every string in it is valid UTF-8 (readers escape the bytes of
/// text a file declares), so dumping it never throws.
#include <nlohmann/json.hpp>

#include "fdv/io/recording.h"

namespace fdv {

nlohmann::json summarize_recording(RecordingReader& reader);

}  // namespace fdv
