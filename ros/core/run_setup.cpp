#include "run_setup.h"

#include <algorithm>

#include "fdv/pipeline/sensor_policy.h"
#include "option_overrides.h"

namespace fdv::ros_core {

RunSetup::RunSetup(const NodeConfig& config)
    : imu_(config.imu),
      depth_(config.depth),
      odometry_(config.odometry),
      cdr_(config.cdr),
      width_(std::max(config.width, 0)),
      height_(std::max(config.height, 0)),
      requested_(load_options(config)) {
  if (!config.calibration_file.empty()) calibration_ = load_calibration(config.calibration_file);
}

std::pair<int, int> RunSetup::configured_size() const {
  if (calibration_) return {calibration_->event_camera.width, calibration_->event_camera.height};
  return {width_, height_};
}

bag::MessageDecoder RunSetup::new_decoder() const {
  bag::MessageDecoder decoder(cdr_ ? bag::Dialect::kCdr : bag::Dialect::kRos1);
  // A day before ROS 1 time ends (2^32 s, in 2106): every time the node publishes (a window's end
  // at most window_ms later, a prediction) is then one ros::Time can hold; ros::Time aborts the
  // process on a time beyond it.
  constexpr TimeNs kLatestStampNs = ((TimeNs{1} << 32) - 86'400) * kNsPerS;
  decoder.set_latest_time(kLatestStampNs, "stamp beyond ROS time's range (2106)");
  if (const auto [width, height] = configured_size(); width > 0 && height > 0) {
    decoder.set_sensor_size(width, height);
    decoder.require_event_message_size(width, height);
  }
  return decoder;
}

std::unique_ptr<Perception> RunSetup::new_perception(int width, int height,
                                                     PerceptionCallbacks callbacks,
                                                     const Warn& warn) const {
  DeclaredSensors declared;
  declared.imu = imu_;
  declared.depth = depth_;
  declared.odometry = odometry_;
  declared.calibration = calibration_;
  declared.width = width;
  declared.height = height;
  SensorPolicy policy = apply_sensor_policy(declared, requested_);
  for (const std::string& w : policy.warnings) warn(w, w);
  return std::make_unique<Perception>(policy.calibration, policy.options, std::move(callbacks));
}

}  // namespace fdv::ros_core
