// Exact motion: velocities, accelerations and body rates are the derivatives of the positions
// and attitudes (checked by central differences); throws reach their targets.
#include "fdv/sim/trajectory.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

namespace fdv::sim {
namespace {

Eigen::Vector3d vee(const Eigen::Matrix3d& S) { return {S(2, 1), S(0, 2), S(1, 0)}; }

void expect_consistent_derivatives(const VehicleTrajectory& v, double t) {
  // h = 1 µs: truncation error (h²/6)·A·ω⁴ ~ 5e-7 m/s² for the fastest vibration component,
  // round-off ~1e-10.
  const double h = 1e-6;
  const BodyState s = v.at(t), a = v.at(t - h), b = v.at(t + h);
  EXPECT_LT(((b.p_W - a.p_W) / (2 * h) - s.v_W).norm(), 1e-7) << "t=" << t;
  EXPECT_LT(((b.v_W - a.v_W) / (2 * h) - s.a_W).norm(), 2e-6) << "t=" << t;
  // Body rate: R^T dR/dt = [ω]x.
  const Eigen::Matrix3d dR = (b.R_W_B - a.R_W_B) / (2 * h);
  EXPECT_LT((vee(s.R_W_B.transpose() * dR) - s.omega_B).norm(), 1e-6) << "t=" << t;
  EXPECT_LT((s.R_W_B.transpose() * s.R_W_B - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(Trajectory, VehicleDerivativesAreExact) {
  for (const char* name : {"hover_headon", "fast_forward", "swing", "scene1_no_object"}) {
    const ScenarioConfig c = make_preset(name, 4);
    const VehicleTrajectory v(c.vehicle, c.seed, c.gravity_W_m_s2);
    for (double t : {0.0, 0.137, 0.5, 0.93}) expect_consistent_derivatives(v, t);
  }
}

TEST(Trajectory, SwingRollsWithTheSwayItsTiltProduces) {
  ScenarioConfig c = make_preset("swing", 1);
  c.vehicle.vibration_angle_deg = 0;
  c.vehicle.vibration_position_m = 0;
  const VehicleTrajectory v(c.vehicle, c.seed, c.gravity_W_m_s2);
  double max_roll = 0;
  for (double t = 0; t < 2; t += 0.01) {
    const BodyState s = v.at(t);
    const double roll = std::atan2(s.R_W_B(2, 1), s.R_W_B(2, 2));
    max_roll = std::max(max_roll, std::abs(roll));
    // Small-angle multirotor: lateral acceleration (left) = -g * roll.
    EXPECT_NEAR(s.a_W.y(), -9.81 * roll, 0.1) << t;
    EXPECT_NEAR(s.v_W.x(), 2.0, 1e-9);  // steady forward speed
  }
  EXPECT_NEAR(max_roll * 180 / 3.141592653589793, c.vehicle.swing_roll_deg, 0.2);
}

TEST(Trajectory, AimedThrowReachesItsTargetAtItsSpeed) {
  const ScenarioConfig c = make_preset("fast_forward", 2);
  const VehicleTrajectory v(c.vehicle, c.seed, c.gravity_W_m_s2);
  const BallConfig& bc = c.balls[0];
  const BallTrajectory ball(bc, v, c.gravity_W_m_s2, 2.0);
  EXPECT_LT((ball.origin_W() - (v.at(bc.release_t_s).p_W + bc.from_m)).norm(), 1e-12);
  // At rest before release.
  EXPECT_LT((ball.at(bc.release_t_s - 0.01).p_W - ball.origin_W()).norm(), 1e-12);
  EXPECT_EQ(ball.at(bc.release_t_s - 0.01).v_W.norm(), 0.0);
  // Flight time T: |target - origin| = speed * T, target moving with the vehicle.
  double T = 0.1;
  for (int i = 0; i < 200; ++i)
    T = ((v.at(bc.release_t_s + T).p_W + bc.to_m) - ball.origin_W()).norm() / bc.speed_m_s;
  const Eigen::Vector3d target = v.at(bc.release_t_s + T).p_W + bc.to_m;
  EXPECT_LT((ball.at(bc.release_t_s + T).p_W - target).norm(), 1e-9);
  // Ballistic: constant acceleration g after release.
  const double t = bc.release_t_s + 0.2, h = 1e-4;
  const Eigen::Vector3d acc = (ball.at(t + h).v_W - ball.at(t - h).v_W) / (2 * h);
  EXPECT_LT((acc - c.gravity_W_m_s2).norm(), 1e-9);
}

TEST(Trajectory, DragDeceleratesAsHalfRhoCdAOverM) {
  ScenarioConfig c = make_preset("hover_headon", 1);
  BallConfig bc = c.balls[0];
  bc.drag_coefficient = 0.47, bc.mass_kg = 0.4;
  const VehicleTrajectory v(c.vehicle, c.seed, c.gravity_W_m_s2);
  const BallTrajectory ball(bc, v, c.gravity_W_m_s2, 3.0);
  const double k = 0.5 * 1.2 * 0.47 * 3.141592653589793 * bc.radius_m * bc.radius_m / 0.4;
  for (double t : {0.3, 0.6, 0.9}) {
    const double h = 1e-4;
    const BallState s = ball.at(t);
    const Eigen::Vector3d acc = (ball.at(t + h).v_W - ball.at(t - h).v_W) / (2 * h);
    const Eigen::Vector3d expected = c.gravity_W_m_s2 - k * s.v_W.norm() * s.v_W;
    EXPECT_LT((acc - expected).norm(), 1e-4) << t;
    const Eigen::Vector3d vel = (ball.at(t + h).p_W - ball.at(t - h).p_W) / (2 * h);
    EXPECT_LT((vel - s.v_W).norm(), 1e-6) << t;
  }
  // The aimed throw with drag still reaches its target (the release velocity was solved for).
  double T = 0.1;
  for (int i = 0; i < 200; ++i)
    T = ((v.at(bc.release_t_s + T).p_W + bc.to_m) - ball.origin_W()).norm() / bc.speed_m_s;
  EXPECT_LT((ball.at(bc.release_t_s + T).p_W - (v.at(bc.release_t_s + T).p_W + bc.to_m)).norm(),
            1e-3);
}

}  // namespace
}  // namespace fdv::sim
