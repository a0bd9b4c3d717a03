#include "fdv/pipeline/sensor_policy.h"

#include <fmt/format.h>

#include <algorithm>

#include "fdv/core/error.h"

namespace fdv {

DeclaredSensors declared_sensors(const RecordingInfo& info, std::optional<Calibration> calibration) {
  auto declares = [&](StreamKind k) { return std::find(info.streams.begin(), info.streams.end(), k) != info.streams.end(); };
  DeclaredSensors d;
  d.imu = declares(StreamKind::kImu);
  d.depth = declares(StreamKind::kDepth);
  d.odometry = declares(StreamKind::kOdometry);
  d.calibration = calibration ? std::move(calibration) : info.calibration;
  d.width = info.width;
  d.height = info.height;
  return d;
}

Calibration pixel_only_calibration(int width, int height) {
  Calibration c;
  const double f = std::max(width, height);
  c.event_camera = {width, height, f, f, 0.5 * (width - 1), 0.5 * (height - 1), {}};
  return c;
}

namespace {

/// Rules 2-3: the best compensation the sensors allow.
CompensationMethod method_the_sensors_allow(const DeclaredSensors& input, const Calibration& calibration,
                                            CompensationMethod method, std::vector<std::string>& warnings) {
  using enum CompensationMethod;
  if (!input.imu && (method == kRotation || method == kRotationTranslation)) {
    warnings.push_back(fmt::format("no IMU in the input: '{}' compensation impossible, using 'none'", to_string(method)));
    return kNone;
  }
  if (method == kRotationTranslation && (!input.depth || !input.odometry || !calibration.depth_camera)) {
    warnings.push_back(
        "no depth frames, depth camera or odometry: translational compensation impossible, using 'rotation'");
    return kRotation;
  }
  return method;
}

}  // namespace

const char* const kNoOdometryWarning =
    "no odometry: the camera's poses are unknown, so no 3D estimation (if the vehicle did not move, say so: "
    "PerceptionOptions::assume_static_vehicle, fdv run --assume-static)";

SensorPolicy apply_sensor_policy(const DeclaredSensors& input, PerceptionOptions requested) {
  SensorPolicy p;
  p.options = std::move(requested);
  PerceptionOptions& o = p.options;
  if (input.calibration) {
    p.calibration = *input.calibration;
  } else {  // 1. pixel coordinates only
    if (input.width <= 0 || input.height <= 0)
      throw ConfigError("no calibration and no sensor size: pass --calib FILE");
    p.calibration = pixel_only_calibration(input.width, input.height);
    p.pixel_only = true;
    p.warnings.push_back(
        "no calibration: detecting in pixel coordinates with no motion compensation and no 3D estimation");
    if (o.assume_static_vehicle)
      p.warnings.push_back("--assume-static ignored (assume_static_vehicle): no calibration, so no 3D estimation");
    o.estimate_trajectories = false;
    o.compensation.method = CompensationMethod::kNone;
  }
  const PinholeCamera& cam = p.calibration.event_camera;
  if (input.width > 0 && (cam.width != input.width || cam.height != input.height))
    throw ConfigError(fmt::format("calibration is {}x{} but the recording is {}x{}", cam.width, cam.height,
                                  input.width, input.height));
  if (!p.pixel_only)
    o.compensation.method = method_the_sensors_allow(input, p.calibration, o.compensation.method, p.warnings);
  // 4. No camera poses, so no 3D, unless the vehicle is declared static.
  if (o.estimate_trajectories && !input.odometry && !o.assume_static_vehicle) {
    p.warnings.push_back(kNoOdometryWarning);
    o.estimate_trajectories = false;
  }
  return p;
}

}  // namespace fdv
