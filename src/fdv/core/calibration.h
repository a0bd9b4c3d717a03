#pragma once
/// Sensor rig calibration: cameras, extrinsics, IMU alignment. Frames: B body, E event camera,
/// D depth camera, I IMU. T_B_E maps E coordinates into B.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <string_view>

#include "fdv/core/camera.h"

namespace fdv {

struct Calibration {
  PinholeCamera event_camera;
  std::optional<PinholeCamera> depth_camera;
  Eigen::Isometry3d T_B_E = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_B_D = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R_B_I = Eigen::Matrix3d::Identity();  ///< IMU-to-body rotation

  /// Rotation taking IMU-frame vectors into the event-camera frame: R_E_I = R_B_E^T R_B_I.
  Eigen::Matrix3d R_E_I() const { return T_B_E.linear().transpose() * R_B_I; }
  /// Empty when valid, else the first problem found (key and reason).
  std::string validate() const;
};

/// Reads a calibration file. Two layouts are recognised:
///  - the project's YAML (docs/FORMATS.md: `event_camera`, optional `depth_camera`, `T_B_E`,
///    `T_B_D`, `R_B_I`), parsed with yaml-cpp;
///  - OpenCV's FileStorage layout, XML (first line `<?xml`, root `<opencv_storage>`) or YAML
///    (first line `%YAML:1.x`), with `camera_matrix` and `distortion_coefficients`
///    (`opencv-matrix`: rows, cols, dt, data), `image_width`, `image_height`, at the top level or
///    inside one named node (as written by the DV software and OpenCV's calibration sample).
///    Extrinsics are identity then. Read with yaml-cpp / tinyxml2, not OpenCV (whose parser
///    hangs or overflows the stack on some malformed text); a matrix may declare at most 14
///    elements.
/// The file may hold at most kMaxConfigFileBytes (fdv/core/config_text.h). Throws InputError
/// naming the file, the key (or line) and the reason; nothing else.
Calibration load_calibration(const std::string& path);

/// Same as load_calibration on text in memory; `name` stands for the file in errors. The layout
/// is detected from the text's first line.
Calibration load_calibration_text(std::string_view text, const std::string& name);

/// Writes the project's YAML layout (round-trips through load_calibration).
void save_calibration(const Calibration& calib, const std::string& path);

}  // namespace fdv
