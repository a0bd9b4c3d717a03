#pragma once
/// What every run of the node starts from (C++20, not for the ROS node): the options asked for
/// (file and overrides), the calibration and the configured sensor size; it makes each run's
/// fresh decoder and Perception. A run ends with NodeCore::finish(), and the next message starts
/// the next one (a replay looped, a sensor restarted).
/// Immutable after construction: its members may be called concurrently.
/// Thread safety: const methods may be called concurrently; NodeCore calls it from one thread.
#include <memory>
#include <optional>
#include <utility>

#include "fdv/core/calibration.h"
#include "fdv/io/rosbag/message_decoder.h"
#include "fdv/pipeline/perception.h"
#include "node_core.h"
#include "streams.h"

namespace fdv::ros_core {

class RunSetup {
 public:
  /// Throws std::runtime_error (InputError / ConfigError) naming the file and key at fault.
  explicit RunSetup(const NodeConfig& config);

  /// The sensor size from the calibration or the configuration; 0 x 0 when the events must say.
  std::pair<int, int> configured_size() const;
  /// A run's decoder; a configured sensor size is required of every event message.
  bag::MessageDecoder new_decoder() const;
  /// A run's Perception for a `width` x `height` sensor, with the sensor policy as `fdv run`
  /// applies it and the subscribed streams as the declared sensors; its warnings go to `warn`.
  std::unique_ptr<Perception> new_perception(int width, int height, PerceptionCallbacks callbacks,
                                             const Warn& warn) const;

 private:
  bool imu_, depth_, odometry_, cdr_;
  int width_, height_;
  PerceptionOptions requested_;
  std::optional<Calibration> calibration_;
};

}  // namespace fdv::ros_core
