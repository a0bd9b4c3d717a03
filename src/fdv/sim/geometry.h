#pragma once
/// Small geometric helpers shared by the simulator's parts.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "fdv/core/camera.h"

namespace fdv::sim {

inline constexpr double kDegToRad = 0.017453292519943295;

/// R = Rz(yaw) Ry(pitch) Rx(roll), angles in degrees (roll, pitch, yaw).
/// exp of a rotation vector (axis · angle) as a unit quaternion.
inline Eigen::Quaterniond rotation_exp_q(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-15) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}

inline Eigen::Matrix3d rotation_from_rpy_deg(const Eigen::Vector3d& rpy_deg) {
  return (Eigen::AngleAxisd(rpy_deg.z() * kDegToRad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy_deg.y() * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy_deg.x() * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

/// R_B_C of a forward-looking camera on an FLU body: camera z = body x, camera x = body -y
/// (right), camera y = body -z (down).
inline Eigen::Matrix3d forward_camera_rotation() {
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return R;
}

/// Largest normalised radius up to which the lens's radial map r (1 + k1 r² + k2 r⁴ + k3 r⁶)
/// keeps increasing (capped at 4). Beyond it the polynomial folds back and projecting there
/// gives wrong pixels.
inline double lens_monotonic_radius(const PinholeCamera& cam) {
  const auto& d = cam.distortion;
  double r = 0;
  for (int i = 1; i <= 4000; ++i) {
    r = i * 1e-3;
    const double r2 = r * r;
    const double deriv = 1 + 3 * d.k1 * r2 + 5 * d.k2 * r2 * r2 + 7 * d.k3 * r2 * r2 * r2;
    if (deriv <= 0.05) return r - 1e-3;
  }
  return r;
}

/// Normalised (distorted) radius of the largest circle about the principal point that fits in
/// the image.
inline double inscribed_radius_distorted(const PinholeCamera& cam) {
  const double dx = std::min(cam.cx + 0.5, cam.width - 0.5 - cam.cx) / cam.fx;
  const double dy = std::min(cam.cy + 0.5, cam.height - 0.5 - cam.cy) / cam.fy;
  return std::min(dx, dy);
}

/// True when the lens map is monotonic out past the largest centred circle in the image (with
/// 10 % margin). Real calibrations such as the DAVIS346's fold back in the corners, beyond the
/// calibration pattern's reach; the simulator renders pixels there with radial_extension().
inline bool lens_is_usable(const PinholeCamera& cam) {
  const double r_max = lens_monotonic_radius(cam);
  const auto& d = cam.distortion;
  const double r2 = r_max * r_max;
  const double rd_max = r_max * (1 + d.k1 * r2 + d.k2 * r2 * r2 + d.k3 * r2 * r2 * r2);
  const double tangential = 2 * (std::abs(d.p1) + std::abs(d.p2)) * r2;
  return rd_max - tangential > 1.1 * inscribed_radius_distorted(cam);
}

/// Viewing ray (normalised undistorted coordinates) for a distorted point `xd` beyond the radius
/// where the lens polynomial folds back: the magnification at the fold, continued outwards, so
/// that rays stay continuous and keep growing towards the corners.
inline Eigen::Vector2d radial_extension(const PinholeCamera& cam, const Eigen::Vector2d& xd) {
  const double r = lens_monotonic_radius(cam), r2 = r * r;
  const auto& d = cam.distortion;
  return xd / (1 + d.k1 * r2 + d.k2 * r2 * r2 + d.k3 * r2 * r2 * r2);
}

}  // namespace fdv::sim
