#pragma once
/// IMU, odometry (VIO-like) and depth-camera models driven by the exact motion.
///
///   ImuModel imu(config.imu, calib.R_B_I, config.gravity_W_m_s2, seed);
///   ImuSample s = imu.sample(t, vehicle.at(to_seconds(t)));   // call in increasing time
///
/// IMU: ω_I = R_I_B ω_B + b_g + n_g, f_I = R_I_B R_B_W (a_W - g_W) + b_a + n_a, with white noise
/// of σ = density / sqrt(Δt) and biases that random-walk by σ = walk · sqrt(Δt) per sample
/// (discrete-time equivalents of the continuous noise densities), initial biases ~ N(0, σ_b).
/// Odometry: position + drift (fraction × path length along a fixed random direction) + white
/// jitter; velocity + first-order Gauss-Markov error; attitude ⊗ Gauss-Markov rotation error;
/// body rate + white noise. Depth: z-depth by ray casting from the depth camera, σ(z) =
/// z² s / (f B), invalid (0) for holes (random, and more at depth edges) and outside the range.
/// Each model is not thread-safe (the depth model uses the pool's threads).
#include <Eigen/Core>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"
#include "fdv/core/thread_pool.h"
#include "fdv/sim/random.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/scene.h"
#include "fdv/sim/trajectory.h"

namespace fdv::sim {

class ImuModel {
 public:
  ImuModel(const ImuConfig& config, const Eigen::Matrix3d& R_B_I, const Eigen::Vector3d& gravity_W,
           std::uint64_t seed);
  ImuSample sample(TimeNs t, const BodyState& s);
  const Eigen::Vector3d& gyro_bias() const { return bg_; }
  const Eigen::Vector3d& accel_bias() const { return ba_; }

 private:
  ImuConfig config_;
  Eigen::Matrix3d R_I_B_;
  Eigen::Vector3d g_W_;
  Rng rng_;
  Eigen::Vector3d bg_, ba_;
  double dt_;
};

class OdometryModel {
 public:
  OdometryModel(const OdometryConfig& config, std::uint64_t seed);
  OdometrySample sample(TimeNs t, const BodyState& s);

 private:
  Eigen::Vector3d gauss3() { return {rng_.normal(), rng_.normal(), rng_.normal()}; }
  OdometryConfig config_;
  Rng rng_;
  Eigen::Vector3d drift_dir_, v_err_, att_err_;
  double path_m_ = 0;
  bool first_ = true;
  TimeNs last_t_ = 0;
  double last_speed_ = 0;
};

class DepthModel {
 public:
  DepthModel(const DepthCameraConfig& config, const Calibration& calib, const Scene& scene,
             std::uint64_t seed, ThreadPool& pool);
  /// `state`'s model reading `scene` (equal to the one `state` reads) on `pool`: a fork of a run.
  DepthModel(const DepthModel& state, const Scene& scene, ThreadPool& pool);
  /// The frame at time t; `frame_index` selects the random streams.
  DepthFrame render(TimeNs t, const BodyState& body, const std::vector<BallState>& balls,
                    const std::vector<double>& radii, std::uint64_t frame_index) const;

 private:
  DepthCameraConfig config_;
  PinholeCamera camera_;
  Eigen::Isometry3d T_B_D_;
  // Not owned (pointers, so that a fork can read its own copies).
  const Scene* scene_;
  std::uint64_t seed_;
  ThreadPool* pool_;
};

}  // namespace fdv::sim
