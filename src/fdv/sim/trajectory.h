#pragma once
/// Exact motion of the vehicle and of the balls, at any time.
///
///   VehicleTrajectory vehicle(config.vehicle, config.seed, config.gravity_W_m_s2);
///   BodyState s = vehicle.at(t_s);               // pose, velocity, acceleration, body rate
///   BallTrajectory ball(config.balls[0], vehicle, config.gravity_W_m_s2, config.duration_s);
///   BallState b = ball.at(t_s);                  // centre, velocity, spin attitude
///
/// The vehicle path is analytic (sums of sinusoids on top of a nominal path; attitude as ZYX
/// Euler angles with analytic rates), so position, velocity, acceleration and angular velocity
/// are exact derivatives of one another. A ball rests at its origin until release, then flies
/// ballistically (closed form) or, with drag, by RK4 integration at 0.1 ms with cubic Hermite
/// interpolation between nodes. Thread-safe (const after construction).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "fdv/core/sensor_data.h"
#include "fdv/sim/scenario_config.h"

namespace fdv::sim {

struct BodyState {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  ///< body origin in W [m]
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();  ///< [m/s]
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();  ///< [m/s²]
  Eigen::Matrix3d R_W_B = Eigen::Matrix3d::Identity();
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();  ///< body rate in B [rad/s]
};

/// The state as a pose sample (truth/body.csv's row) at time t.
OdometrySample to_pose_sample(TimeNs t, const BodyState& s);

class VehicleTrajectory {
 public:
  VehicleTrajectory(const VehicleConfig& config, std::uint64_t seed,
                    const Eigen::Vector3d& gravity_W);
  BodyState at(double t_s) const;

 private:
  /// a0 + Σ A_k sin(ω_k t + φ_k) with value, first and second derivative.
  struct Wave {
    double offset = 0;
    std::vector<double> amp, omega, phase;
    void add(double a, double w, double p) {
      amp.push_back(a), omega.push_back(w), phase.push_back(p);
    }
    void eval(double t, double& f, double& df, double& ddf) const;
  };
  VehicleConfig config_;
  Wave pos_[3];    ///< W-axis position offsets on top of the nominal path
  Wave angle_[3];  ///< roll, pitch, yaw [rad]
  Eigen::Vector3d heading_dir_;
  Eigen::Vector3d left_dir_;
  Eigen::Matrix3d R0_;
};

struct BallState {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_W_O = Eigen::Matrix3d::Identity();  ///< ball-fixed frame O (spin)
  bool released = false;
  bool exists = true;  ///< false before release for a ball hidden until then
};

class BallTrajectory {
 public:
  /// Resolves an aimed throw against `vehicle` and, with drag, integrates the flight up to
  /// `end_s`. Throws ConfigError if an aimed throw cannot be solved.
  BallTrajectory(const BallConfig& config, const VehicleTrajectory& vehicle,
                 const Eigen::Vector3d& gravity_W, double end_s);
  BallState at(double t_s) const;
  const BallConfig& config() const { return config_; }
  /// Release position and velocity actually used (resolved for aimed throws).
  const Eigen::Vector3d& origin_W() const { return origin_; }
  const Eigen::Vector3d& release_velocity_W() const { return velocity0_; }

 private:
  Eigen::Vector3d acceleration(const Eigen::Vector3d& v) const;
  void integrate(double end_s);
  /// Flight state a time `tau` after release with release velocity v0 (drag: RK4 from scratch).
  void fly(const Eigen::Vector3d& v0, double tau, Eigen::Vector3d& p, Eigen::Vector3d& v) const;

  BallConfig config_;
  Eigen::Vector3d gravity_;
  Eigen::Vector3d origin_, velocity0_;
  double drag_k_ = 0;  ///< a_drag = -k |v| v
  double node_dt_ = 1e-4;
  std::vector<Eigen::Vector3d> node_p_, node_v_;
};

}  // namespace fdv::sim
