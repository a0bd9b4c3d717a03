// The sensor-availability policy, one rule at a time: which compensation, whether 3D is estimated,
// which calibration and which warnings, for inputs that lack one sensor or another.
#include "fdv/pipeline/sensor_policy.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "fdv/core/error.h"

namespace fdv {
namespace {

Calibration calibrated(bool with_depth_camera) {
  Calibration c;
  c.event_camera = {346, 260, 250.0, 251.0, 172.0, 129.0, {}};
  if (with_depth_camera) c.depth_camera = PinholeCamera{640, 480, 380.0, 380.0, 320.0, 240.0, {}};
  return c;
}

// Every sensor, and a calibration with a depth camera.
DeclaredSensors everything() {
  DeclaredSensors d;
  d.imu = d.depth = d.odometry = true;
  d.calibration = calibrated(true);
  d.width = 346;
  d.height = 260;
  return d;
}

PerceptionOptions requesting(CompensationMethod m) {
  PerceptionOptions o;
  o.compensation.method = m;
  return o;
}

bool mentions(const std::vector<std::string>& warnings, const std::string& part) {
  for (const std::string& w : warnings)
    if (w.find(part) != std::string::npos) return true;
  return false;
}

TEST(SensorPolicy, EverySensorKeepsTheRequestAndSaysNothing) {
  for (const CompensationMethod m : all_values(CompensationMethod{})) {
    const SensorPolicy p = apply_sensor_policy(everything(), requesting(m));
    EXPECT_EQ(p.options.compensation.method, m);
    EXPECT_TRUE(p.options.estimate_trajectories);
    EXPECT_FALSE(p.pixel_only);
    EXPECT_EQ(p.calibration.event_camera.fx, 250.0);
    EXPECT_TRUE(p.warnings.empty()) << p.warnings.front();
  }
}

TEST(SensorPolicy, NoCalibrationMeansPixelsNoCompensationAndNo3D) {
  DeclaredSensors d = everything();
  d.calibration.reset();
  const SensorPolicy p = apply_sensor_policy(d, requesting(CompensationMethod::kRotationTranslation));
  EXPECT_TRUE(p.pixel_only);
  EXPECT_EQ(p.options.compensation.method, CompensationMethod::kNone);
  EXPECT_FALSE(p.options.estimate_trajectories);
  // An ideal camera of the sensor's size: f = the larger side, centred, no distortion.
  EXPECT_EQ(p.calibration.event_camera.width, 346);
  EXPECT_EQ(p.calibration.event_camera.height, 260);
  EXPECT_EQ(p.calibration.event_camera.fx, 346.0);
  EXPECT_EQ(p.calibration.event_camera.fy, 346.0);
  EXPECT_EQ(p.calibration.event_camera.cx, 172.5);
  EXPECT_EQ(p.calibration.event_camera.cy, 129.5);
  EXPECT_FALSE(p.calibration.depth_camera);
  // One warning says all of it: no fallback warning, no "no odometry".
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_TRUE(mentions(p.warnings, "no calibration"));
}

TEST(SensorPolicy, NoCalibrationOverridesAStaticVehicleAndSaysSo) {
  DeclaredSensors d = everything();
  d.calibration.reset();
  PerceptionOptions o = requesting(CompensationMethod::kNone);
  o.assume_static_vehicle = true;
  const SensorPolicy p = apply_sensor_policy(d, o);
  EXPECT_FALSE(p.options.estimate_trajectories);
  ASSERT_EQ(p.warnings.size(), 2u);
  EXPECT_TRUE(mentions(p.warnings, "no calibration"));
  EXPECT_NE(p.warnings[1].find("--assume-static ignored"), std::string::npos) << p.warnings[1];
}

TEST(SensorPolicy, NoCalibrationAndNoSensorSizeIsAnError) {
  DeclaredSensors d = everything();
  d.calibration.reset();
  d.width = d.height = 0;
  EXPECT_THROW(apply_sensor_policy(d, PerceptionOptions{}), ConfigError);
}

TEST(SensorPolicy, ACalibrationOfAnotherSizeIsAnError) {
  DeclaredSensors d = everything();
  d.width = 640;
  d.height = 480;
  EXPECT_THROW(apply_sensor_policy(d, PerceptionOptions{}), ConfigError);
  d.width = d.height = 0;  // size unknown: the calibration's is taken
  EXPECT_NO_THROW(apply_sensor_policy(d, PerceptionOptions{}));
}

TEST(SensorPolicy, NoImuFallsBackToNone) {
  DeclaredSensors d = everything();
  d.imu = false;
  for (const CompensationMethod m : {CompensationMethod::kRotation, CompensationMethod::kRotationTranslation}) {
    const SensorPolicy p = apply_sensor_policy(d, requesting(m));
    EXPECT_EQ(p.options.compensation.method, CompensationMethod::kNone);
    EXPECT_TRUE(p.options.estimate_trajectories);
    ASSERT_EQ(p.warnings.size(), 1u);
    EXPECT_EQ(p.warnings[0], fmt::format("no IMU in the input: '{}' compensation impossible, using 'none'", to_string(m)));
  }
  // The methods that use no IMU are kept, silently.
  for (const CompensationMethod m : {CompensationMethod::kNone, CompensationMethod::kContrastMax}) {
    const SensorPolicy p = apply_sensor_policy(d, requesting(m));
    EXPECT_EQ(p.options.compensation.method, m);
    EXPECT_TRUE(p.warnings.empty());
  }
}

TEST(SensorPolicy, NoDepthDepthCameraOrOdometryFallsBackToRotation) {
  DeclaredSensors no_depth = everything(), no_depth_camera = everything(), no_odometry = everything();
  no_depth.depth = false;
  no_depth_camera.calibration = calibrated(false);
  no_odometry.odometry = false;
  no_odometry.calibration = calibrated(true);
  for (const DeclaredSensors& d : {no_depth, no_depth_camera, no_odometry}) {
    const SensorPolicy p = apply_sensor_policy(d, requesting(CompensationMethod::kRotationTranslation));
    EXPECT_EQ(p.options.compensation.method, CompensationMethod::kRotation);
    EXPECT_TRUE(mentions(p.warnings, "translational compensation impossible, using 'rotation'"));
    // Rotation needs none of them: kept.
    EXPECT_EQ(apply_sensor_policy(d, requesting(CompensationMethod::kRotation)).options.compensation.method,
              CompensationMethod::kRotation);
  }
}

TEST(SensorPolicy, NoOdometryMeansNo3DUnlessTheVehicleIsDeclaredStatic) {
  DeclaredSensors d = everything();
  d.odometry = false;
  const SensorPolicy moving = apply_sensor_policy(d, requesting(CompensationMethod::kRotation));
  EXPECT_FALSE(moving.options.estimate_trajectories);
  ASSERT_EQ(moving.warnings.size(), 1u);
  EXPECT_EQ(moving.warnings[0], kNoOdometryWarning);

  PerceptionOptions declared = requesting(CompensationMethod::kRotation);
  declared.assume_static_vehicle = true;
  const SensorPolicy still = apply_sensor_policy(d, declared);
  EXPECT_TRUE(still.options.estimate_trajectories);
  EXPECT_TRUE(still.warnings.empty());

  // 3D not requested: nothing to say.
  PerceptionOptions no_3d = requesting(CompensationMethod::kRotation);
  no_3d.estimate_trajectories = false;
  EXPECT_TRUE(apply_sensor_policy(d, no_3d).warnings.empty());
}

TEST(SensorPolicy, RulesApplyInOrderWithAWarningEach) {
  // Only events and a calibration with a depth camera: "rotation_translation" -> "none" (no IMU,
  // said once), and no 3D (no odometry).
  DeclaredSensors d;
  d.calibration = calibrated(true);
  const SensorPolicy p = apply_sensor_policy(d, requesting(CompensationMethod::kRotationTranslation));
  EXPECT_EQ(p.options.compensation.method, CompensationMethod::kNone);
  EXPECT_FALSE(p.options.estimate_trajectories);
  ASSERT_EQ(p.warnings.size(), 2u);
  EXPECT_TRUE(p.warnings[0].starts_with("no IMU"));
  EXPECT_EQ(p.warnings[1], kNoOdometryWarning);
}

TEST(SensorPolicy, OtherOptionsPassThrough) {
  PerceptionOptions o;
  o.threads = 2;
  o.monocular_baseline = false;
  o.max_lateness_ns = 7 * kNsPerMs;
  const SensorPolicy p = apply_sensor_policy(everything(), o);
  EXPECT_EQ(p.options.threads, 2);
  EXPECT_FALSE(p.options.monocular_baseline);
  EXPECT_EQ(p.options.max_lateness_ns, 7 * kNsPerMs);
}

TEST(SensorPolicy, DeclaredSensorsFromARecordingsInfo) {
  RecordingInfo info;
  info.width = 346;
  info.height = 260;
  info.streams = {StreamKind::kEvents, StreamKind::kImu, StreamKind::kOdometry};
  info.calibration = calibrated(false);
  const DeclaredSensors d = declared_sensors(info);
  EXPECT_TRUE(d.imu);
  EXPECT_FALSE(d.depth);
  EXPECT_TRUE(d.odometry);
  EXPECT_EQ(d.width, 346);
  ASSERT_TRUE(d.calibration);
  EXPECT_FALSE(d.calibration->depth_camera);
  // A calibration given by the user replaces the recording's.
  const DeclaredSensors given = declared_sensors(info, calibrated(true));
  ASSERT_TRUE(given.calibration);
  EXPECT_TRUE(given.calibration->depth_camera);
}

}  // namespace
}  // namespace fdv
