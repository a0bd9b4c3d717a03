#pragma once
/// Writes the project's dataset folder (layout in dataset_reader.h and docs/FORMATS.md).
///
///   DatasetWriter w(dir, calib);     // creates dir, writes calibration.yaml
///   w.add_events(events); w.add_imu(s); w.add_depth(frame); ...
///   w.finish(extra_manifest_yaml);   // writes the event count and dataset.yaml
///
/// Each stream must be added in non-decreasing time. Not thread-safe.
#include <fstream>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"
#include "fdv/io/dataset/depth_image.h"

namespace fdv {

class DatasetWriter {
 public:
  /// Depth frames go to depth/NNNNNN.zst (Zstandard) or depth/NNNNNN.png (depth_image.h).
  DatasetWriter(const std::string& dir, const Calibration& calib,
                DepthEncoding depth_encoding = DepthEncoding::kZstd);
  ~DatasetWriter();
  DatasetWriter(const DatasetWriter&) = delete;
  DatasetWriter& operator=(const DatasetWriter&) = delete;

  void add_events(std::span<const Event> events);
  void add_imu(const ImuSample& s);
  void add_odometry(const OdometrySample& s);
  void add_depth(const DepthFrame& frame);  ///< metres -> 16-bit millimetres (0 invalid)
  void add_object_truth(const ObjectState& s);
  void add_body_truth(const OdometrySample& s);
  /// truth/body_unflown.csv, created by the first row: the path a flown vehicle would have
  /// taken without its manoeuvre (same layout as truth/body.csv).
  void add_unflown_body_truth(const OdometrySample& s);
  /// Completes events.bin and writes dataset.yaml; `manifest_extra` is a YAML mapping text
  /// merged into the manifest (e.g. scenario name, seed, ball radius).
  void finish(const std::string& manifest_extra = "");
  std::uint64_t event_count() const { return event_count_; }

 private:
  std::string dir_;
  int width_, height_;
  std::ofstream events_, imu_, odometry_, depth_index_, objects_, body_, body_unflown_;
  std::uint64_t event_count_ = 0;
  DepthEncoding depth_encoding_;
  std::vector<std::uint16_t> millimetres_;
  int depth_count_ = 0;
  bool finished_ = false;
};

/// A sample as a reader of the written folder gets it back: the text rows' 9 significant digits
/// (the reader's parsing, a unit quaternion renormalised), depth in whole millimetres; nothing
/// for a row the reader would drop. A consumer fed live beside the writer (the closed loop) so
/// sees exactly what `fdv run` on the folder sees.
std::optional<ImuSample> as_stored(const ImuSample& s);
std::optional<OdometrySample> as_stored(const OdometrySample& s);
DepthFrame as_stored(const DepthFrame& frame);

}  // namespace fdv
