#pragma once
/// The sensor-availability policy: what a run does with the streams and the calibration its input
/// declares, decided once, before any data is read. `fdv run`, a program that drives Perception
/// itself and the bindings call it alike, so that they fall back alike and say so in the same words.
///
///   const RecordingInfo info = reader->info();
///   const SensorPolicy policy = apply_sensor_policy(declared_sensors(info), requested_options);
///   for (const std::string& w : policy.warnings) log(w);
///   Perception perception(policy.calibration, policy.options, callbacks);
///
/// The rules, in this order (each fallback raises one warning):
/// 1. No calibration: an ideal camera of the sensor's size (pixel_only_calibration), "none"
///    compensation (silently: rule 1's warning says it), and no 3D estimation, even for a vehicle
///    declared static (the camera's rays are unknown; warned when assume_static_vehicle is set).
/// 2. No IMU: "rotation" and "rotation_translation" fall back to "none".
/// 3. No depth frames, no depth camera in the calibration or no odometry: "rotation_translation"
///    falls back to "rotation".
/// 4. No odometry: no 3D estimation (the camera's poses are unknown), unless
///    assume_static_vehicle says the vehicle did not move.
/// A stream that is declared but turns out empty or short is Perception's to notice, while it runs
/// (the compensation's fallback flags, its "no pose" warning).
///
/// Throws ConfigError when there is neither a calibration nor a sensor size, or when the
/// calibration's image size is not the sensor's.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <optional>
#include <string>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/perception.h"

namespace fdv {

/// What an input declares it carries (RecordingInfo for a recording; a live source knows it).
struct DeclaredSensors {
  bool imu = false;
  bool depth = false;  ///< depth frames
  bool odometry = false;
  std::optional<Calibration> calibration;  ///< none: pixel coordinates only (rule 1)
  int width = 0;   ///< event sensor size [px]; 0 when unknown
  int height = 0;
};

/// The streams, sensor size and calibration `info` declares; `calibration` (e.g. a file the user
/// gave) replaces the recording's own when set.
DeclaredSensors declared_sensors(const RecordingInfo& info, std::optional<Calibration> calibration = std::nullopt);

struct SensorPolicy {
  PerceptionOptions options;  ///< the requested options, with every fallback applied
  Calibration calibration;    ///< the declared calibration, or pixel_only_calibration()
  bool pixel_only = false;    ///< no calibration was declared (rule 1)
  std::vector<std::string> warnings;  ///< one line per fallback, in rule order
};

SensorPolicy apply_sensor_policy(const DeclaredSensors& input, PerceptionOptions requested);

/// Rule 4's warning; Perception gives the same when odometry is declared but none arrives.
extern const char* const kNoOdometryWarning;

/// An ideal camera of the sensor's size (no distortion, f = the larger side, centred): pixel
/// coordinates pass through unchanged.
Calibration pixel_only_calibration(int width, int height);

}  // namespace fdv
