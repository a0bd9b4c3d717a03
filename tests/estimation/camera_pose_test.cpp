#include "fdv/estimation/camera_pose.h"

#include <gtest/gtest.h>

#include <limits>

namespace fdv {
namespace {

OdometrySample sample(TimeNs t, double yaw, const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                      double yaw_rate) {
  OdometrySample s;
  s.t = t;
  s.p_W_B = p;
  s.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  s.v_W = v;
  s.omega_B = Eigen::Vector3d(0, 0, yaw_rate);
  return s;
}

// A vehicle moving at constant velocity and yaw rate: the interpolated camera pose at a time
// between samples equals the analytic pose (linear position, constant-rate yaw).
TEST(CameraPose, InterpolatesBetweenSamplesAndComposesTheMount) {
  const Eigen::Vector3d v(2, 0, 0);
  const double rate = 1.0;
  std::vector<OdometrySample> odo;
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.01 * k;
    odo.push_back(sample(from_seconds(t), rate * t, v * t, v, rate));
  }
  Eigen::Isometry3d T_B_C = Eigen::Isometry3d::Identity();
  T_B_C.translation() = Eigen::Vector3d(0.1, 0, 0);
  const TimeNs t = from_seconds(0.0437);
  const auto T = camera_pose_at(odo, t, T_B_C);
  ASSERT_TRUE(T.has_value());
  const double yaw = rate * 0.0437;
  EXPECT_NEAR((T->translation() -
               (v * 0.0437 + Eigen::Vector3d(0.1 * std::cos(yaw), 0.1 * std::sin(yaw), 0)))
                  .norm(),
              0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(T->linear()).angle(), yaw, 1e-12);
}

TEST(CameraPose, ExtrapolatesOnlyWithinTheLimit) {
  const Eigen::Vector3d v(2, 0, 0);
  std::vector<OdometrySample> odo = {sample(0, 0, Eigen::Vector3d::Zero(), v, 1.0),
                                     sample(10 * kNsPerMs, 0.01, v * 0.01, v, 1.0)};
  EXPECT_FALSE(camera_pose_at({}, 0, Eigen::Isometry3d::Identity()).has_value());
  EXPECT_FALSE(camera_pose_at(odo, 15 * kNsPerMs, Eigen::Isometry3d::Identity(), 0).has_value());
  const auto T = camera_pose_at(odo, 15 * kNsPerMs, Eigen::Isometry3d::Identity(), 10 * kNsPerMs);
  ASSERT_TRUE(T.has_value());
  EXPECT_NEAR(T->translation().x(), 0.03, 1e-12);                     // 2 m/s × 15 ms
  EXPECT_NEAR(Eigen::AngleAxisd(T->linear()).angle(), 0.015, 1e-12);  // 1 rad/s × 15 ms
  EXPECT_FALSE(camera_pose_at(odo, -11 * kNsPerMs, Eigen::Isometry3d::Identity(), 10 * kNsPerMs)
                   .has_value());
}

// Times from the two ends of int64 (any value a push may carry): out of reach, not an overflow.
// Found by fuzz_perception_push (UBSan: signed overflow in front.t - t).
TEST(CameraPose, TimesFarApartAreOutOfReachNotAnOverflow) {
  const Eigen::Vector3d v(2, 0, 0);
  const TimeNs big = std::numeric_limits<TimeNs>::max(), small = std::numeric_limits<TimeNs>::min();
  const std::vector<OdometrySample> odo = {sample(kNsPerS, 0, Eigen::Vector3d::Zero(), v, 1.0)};
  EXPECT_FALSE(body_state_at(odo, small, 10 * kNsPerMs).has_value());
  EXPECT_FALSE(body_state_at(odo, big, 10 * kNsPerMs).has_value());
  const std::vector<OdometrySample> late = {sample(big - 1, 0, Eigen::Vector3d::Zero(), v, 1.0)};
  EXPECT_FALSE(body_state_at(late, small, big).has_value());  // the gap exceeds any limit
  EXPECT_TRUE(body_state_at(late, big, 10).has_value());     // 1 ns ahead: within reach
}

}  // namespace
}  // namespace fdv
