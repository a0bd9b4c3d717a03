#pragma once
// Synthetic ballistic throws seen from a moving vehicle, with exact ground truth (tests only).
// Frames: W z up; body B x forward, y left, z up; event camera E x right, y down, z forward.
#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "fdv/estimation/ballistic.h"
#include "fdv/estimation/trajectory_estimator.h"

namespace fdv::test {

inline Eigen::Isometry3d forward_camera_T_B_E() {
  Eigen::Matrix3d R;  // columns: E's axes in B
  R.col(0) = Eigen::Vector3d(0, -1, 0);
  R.col(1) = Eigen::Vector3d(0, 0, -1);
  R.col(2) = Eigen::Vector3d(1, 0, 0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = Eigen::Vector3d(0.10, 0.02, 0.05);
  return T;
}

/// σ(z) = z² s / (f B), D435 defaults of DESIGN.md.
inline double d435_sigma(double z) { return z * z * 0.08 / (385.7 * 0.05); }

struct Scene {
  std::function<Eigen::Isometry3d(TimeNs)> T_W_B;  ///< exact body pose
  Eigen::Isometry3d T_B_E = forward_camera_T_B_E();
  BallisticTrajectory truth;
  std::vector<TimeNs> event_times, depth_times;
  double focal_px = 536.3;

  Eigen::Isometry3d T_W_E(TimeNs t) const { return T_W_B(t) * T_B_E; }
};

/// Paper Table II, "fast forward": vehicle at 2 m/s forward, ball thrown across at ~12 m/s;
/// 7 event detections and 3 depth observations over 0.18 s.
inline Scene forward_scene() {
  Scene s;
  s.T_W_B = [](TimeNs t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(2.0 * to_seconds(t), 0, 1.5);
    return T;
  };
  s.truth = {0, {6.0, 1.2, 1.6}, {-1.0, -12.0, 2.0}, {0, 0, -9.81}};
  for (int k = 0; k < 7; ++k) s.event_times.push_back(k * 30 * kNsPerMs);
  s.depth_times = {33 * kNsPerMs, 100 * kNsPerMs, 167 * kNsPerMs};
  return s;
}

/// Paper Table II, "swing": the same throw while the vehicle yaws and rolls (±0.3 rad at 2 Hz,
/// ±0.2 rad at 1.5 Hz); 6 event and 3 depth observations over 0.16 s.
inline Scene swing_scene() {
  Scene s = forward_scene();
  s.T_W_B = [](TimeNs t) {
    const double ts = to_seconds(t);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(0.3 * std::sin(2 * M_PI * 2.0 * ts), Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(0.2 * std::sin(2 * M_PI * 1.5 * ts), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(2.0 * ts, 0.3 * std::sin(2 * M_PI * ts), 1.5);
    return T;
  };
  s.event_times.clear();
  for (int k = 0; k < 6; ++k) s.event_times.push_back(k * 32 * kNsPerMs);
  s.depth_times = {20 * kNsPerMs, 80 * kNsPerMs, 140 * kNsPerMs};
  return s;
}

struct Observations {
  std::vector<EventObservation> events;
  std::vector<DepthMeasurement> depths;
};

/// Observations of the true ball with Gaussian pixel noise sigma_px (0 = exact) and the D435 depth
/// noise model (depth_noise = false: exact depth, sigma still from the model).
inline Observations observe(const Scene& s, std::mt19937& rng, double sigma_px, bool depth_noise) {
  std::normal_distribution<double> n01(0.0, 1.0);
  Observations o;
  for (TimeNs t : s.event_times) {
    const Eigen::Isometry3d T = s.T_W_E(t);
    const Eigen::Vector3d X = T.inverse() * s.truth.position(t);
    Eigen::Vector2d xn = X.head<2>() / X.z();
    xn += sigma_px / s.focal_px * Eigen::Vector2d(n01(rng), n01(rng));
    o.events.push_back({t, xn, T, 0.0});
  }
  for (TimeNs t : s.depth_times) {
    const Eigen::Isometry3d T = s.T_W_E(t);
    const double z = (T.inverse() * s.truth.position(t)).z();
    const double d = z + (depth_noise ? d435_sigma(z) * n01(rng) : 0.0);
    o.depths.push_back({t, d, d435_sigma(d), T});
  }
  return o;
}

/// RMSE of the position error over [t0, t1] sampled every millisecond (the APE of Table II).
inline double ape_rmse(const BallisticTrajectory& est, const BallisticTrajectory& truth, TimeNs t0,
                       TimeNs t1) {
  double sum = 0;
  int n = 0;
  for (TimeNs t = t0; t <= t1; t += kNsPerMs, ++n)
    sum += (est.position(t) - truth.position(t)).squaredNorm();
  return std::sqrt(sum / n);
}

}  // namespace fdv::test
