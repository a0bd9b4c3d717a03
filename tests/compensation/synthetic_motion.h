#pragma once
// Exact synthetic event windows for the compensation tests: static 3D points seen by a camera that
// rotates with constant angular velocity ω and translates with constant velocity v (both in the
// camera frame at t0, E0). The camera pose at time t relative to E0 is
//     R(t) = exp([ω]× (t − t0)),   p(t) = v·(t − t0),
// so a point P (E0 coordinates) has coordinates X_t = R(t)ᵀ (P − p(t)) in the camera at t. Events
// are P's exact projections through the lens model, rounded to the nearest raw pixel.
#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/depth/depth_registration.h"

namespace fdv::test {

inline Eigen::Matrix3d rotation_at(const Eigen::Vector3d& omega, double t_s) {
  const double angle = omega.norm() * t_s;
  return angle > 0 ? Eigen::AngleAxisd(angle, omega.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

struct SyntheticWindow {
  std::vector<Eigen::Vector3d> points;  // E0 coordinates
  std::vector<Event> events;
  std::vector<int> point_of_event;      // which point made each event
  RegisteredDepth depth;                // z in E_t at each event's pixel (exact, per event)
};

/// Points on a grid of raw pixels at t0 (spacing `spacing_px`, margin from the border), at depths
/// in [z_min, z_max]; events every `dt_ns` for each point over [0, duration). The camera's rotation
/// R(t) relative to E0 is `rotation(t − t0 [s])`.
template <class Rotation>
SyntheticWindow make_window_rotating(const PinholeCamera& cam, const Rotation& rotation, const Eigen::Vector3d& v_E,
                                     TimeNs t0, TimeNs duration, TimeNs dt_ns, int spacing_px = 48,
                                     int margin_px = 60, double z_min = 3.0, double z_max = 6.0, unsigned seed = 7) {
  SyntheticWindow w;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> depth(z_min, z_max), jitter(-0.45, 0.45);
  for (int y = margin_px; y < cam.height - margin_px; y += spacing_px)
    for (int x = margin_px; x < cam.width - margin_px; x += spacing_px) {
      const Eigen::Vector2d px(x + jitter(rng), y + jitter(rng));
      w.points.push_back(cam.back_project(px, depth(rng)));
    }
  w.depth.t = t0;
  w.depth.width = cam.width;
  w.depth.height = cam.height;
  w.depth.depth_m.assign(static_cast<std::size_t>(cam.width) * cam.height, 0.0f);
  for (TimeNs t = 0; t < duration; t += dt_ns) {
    const double ts = to_seconds(t);
    const Eigen::Matrix3d R = rotation(ts);
    for (std::size_t i = 0; i < w.points.size(); ++i) {
      const Eigen::Vector3d X = R.transpose() * (w.points[i] - v_E * ts);
      if (X.z() <= 0.1) continue;
      const Eigen::Vector2d px = cam.project(X);
      if (!cam.in_image(px)) continue;
      const int x = static_cast<int>(std::lround(px.x())), y = static_cast<int>(std::lround(px.y()));
      if (x < 0 || y < 0 || x >= cam.width || y >= cam.height) continue;
      w.events.push_back({t0 + t, static_cast<std::uint16_t>(x), static_cast<std::uint16_t>(y), true});
      w.point_of_event.push_back(static_cast<int>(i));
      w.depth.depth_m[static_cast<std::size_t>(y) * cam.width + x] = static_cast<float>(X.z());
    }
  }
  return w;
}

/// make_window_rotating with the constant rate ω_E: R(t) = exp([ω]× t).
inline SyntheticWindow make_window(const PinholeCamera& cam, const Eigen::Vector3d& omega_E,
                                   const Eigen::Vector3d& v_E, TimeNs t0, TimeNs duration, TimeNs dt_ns,
                                   int spacing_px = 48, int margin_px = 60, double z_min = 3.0,
                                   double z_max = 6.0, unsigned seed = 7) {
  return make_window_rotating(
      cam, [&](double t_s) { return rotation_at(omega_E, t_s); }, v_E, t0, duration, dt_ns, spacing_px, margin_px,
      z_min, z_max, seed);
}

/// Constant-rate IMU samples (IMU frame) every `period_ns` over [from, to].
inline std::vector<ImuSample> constant_imu(const Eigen::Vector3d& gyro_I, TimeNs from, TimeNs to, TimeNs period_ns) {
  std::vector<ImuSample> imu;
  for (TimeNs t = from; t <= to; t += period_ns) imu.push_back({t, gyro_I, {0, 0, 9.81}});
  return imu;
}

}  // namespace fdv::test
