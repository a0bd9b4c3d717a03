#pragma once
/// The ROS node's core, free of any transport: serialized sensor messages in, the pipeline's
/// results out. The ROS 1 node (ros/node) is a thin layer over it, and a ROS 2 binding would be
/// another (the same decoders read CDR).
///
///   NodeConfig config;  config.calibration_file = "davis346.yaml";
///   NodeOutputs out;  out.on_window = [](const WindowOutput& w) { publish(w); };
///   NodeCore core(config, std::move(out));          // throws std::runtime_error for bad config
///   core.push(Stream::kEvents, "dvs_msgs/EventArray", bytes, size);   // per received message
///   core.finish();                                  // end of input: the last window
///
/// This header is C++17 and includes no fdv header, because ROS 1's generated message headers
/// compile only as C++17 while the library is C++20. Results cross it as the rows of a `fdv run`
/// results folder (src/fdv/results/schema.h), as JSON with the same keys, so that the schema
/// stays the one owner of what each field means and the node's messages mirror the files.
///
/// Time: only message stamps count, never the wall clock (which only measures latency). Streams
/// are put into one time order before the pipeline, as `fdv run`'s merger does for a recording:
/// an item is released once every awaited stream has passed its time, so a complete, slow replay
/// gives `fdv run`'s windows exactly. Depth is awaited only with `wait_for_depth` (a 30 Hz camera
/// would add up to 33 ms of latency). A stream silent for `max_hold_s` of stream time is no longer
/// awaited; one that never arrived within `missing_after_s` is reported missing. Durations in
/// seconds are rounded to the nearest nanosecond.
///
/// Not thread-safe: one call at a time (the ROS 1 node's single spinner thread). The outputs are
/// called on the caller's thread, inside push() and finish().
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace fdv::ros_core {

enum class Stream { kEvents, kImu, kDepth, kOdometry };
const char* to_string(Stream s);

struct NodeConfig {
  /// PerceptionOptions as `fdv run --config` reads them; "" = defaults.
  std::string options_file;
  /// Single keys over the file: ("detector.min_peak", "0.3"), ("window_ms", "20"); values are
  /// YAML scalars. An unknown key or a bad value is an error naming it.
  std::vector<std::pair<std::string, std::string>> option_overrides;
  /// The project's YAML or OpenCV XML/YAML; "" = pixel coordinates only (no 3D, a warning).
  std::string calibration_file;
  /// Event sensor size when there is no calibration file [px]; 0 = from the first event message.
  int width = 0, height = 0;
  /// Which streams are subscribed (the sensors declared to the sensor policy).
  bool imu = true, depth = true, odometry = true;
  bool cdr = false;  ///< ROS 2 (CDR) bytes instead of ROS 1
  bool wait_for_depth = false;
  double max_hold_s = 0.1;        ///< stream time an awaited stream may lag before it is skipped
  double missing_after_s = 1.0;   ///< stream time after which a stream never seen is reported
  double path_horizon_s = 1.0;    ///< predicted positions in each estimate's path
  double path_step_s = 0.02;
};

/// One event window: `window` is a detections.jsonl line (WindowRow), `tracks` the live image
/// tracks after it ([{id, confirmed, first_t, last_update_t, hits, misses, center, velocity,
/// center_covariance, box_size}], pixels raw, times s), plus processing time and latency.
struct WindowOutput {
  nlohmann::json window;
  nlohmann::json tracks;
  std::uint64_t index = 0;
  double processing_ms = 0;
  /// From the arrival of the event message that completed the window (its events reach the
  /// window's end) to this output [ms]; NaN for a window closed by finish() (the end of input).
  double latency_ms = 0;
};

struct NodeOutputs {
  std::function<void(const WindowOutput&)> on_window;
  /// A trajectories.jsonl line (TrajectoryRow) plus "path": [[t, x, y, z], ...] predicted from
  /// the observed end over path_horizon_s (world, s and m).
  std::function<void(const nlohmann::json&)> on_estimate;
  std::function<void(const nlohmann::json&)> on_prediction;  ///< a predictions.jsonl line
  std::function<void(const nlohmann::json&)> on_dodge;       ///< a dodge.jsonl line
  /// A warning; `key` names its cause, for throttling (the same key: the same kind of trouble).
  std::function<void(const std::string& key, const std::string& message)> on_warning;
};

class NodeCore {
 public:
  /// Throws std::runtime_error (fdv's InputError / ConfigError) naming the file and key at fault.
  NodeCore(NodeConfig config, NodeOutputs outputs);
  ~NodeCore();
  NodeCore(const NodeCore&) = delete;
  NodeCore& operator=(const NodeCore&) = delete;

  /// One received message of `datatype` ("dvs_msgs/EventArray", "sensor_msgs/Imu", ...).
  /// Returns false when it was dropped (counted in diagnostics(), warned through on_warning):
  /// an unsupported type or encoding, a malformed message, a stamp going backwards, an image of
  /// the wrong type, events whose sensor size does not fit the calibration.
  bool push(Stream stream, const std::string& datatype, const std::uint8_t* data, std::size_t size);
  /// End of input: releases everything held and closes the last window. A later push starts a
  /// new run (a replay looped, a sensor restarted) with fresh state.
  void finish();
  /// Counts per stream (messages, dropped by reason, late), the pipeline's counters, windows and
  /// latency over the last 2000 windows; what the node publishes on /diagnostics.
  nlohmann::json diagnostics() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fdv::ros_core
