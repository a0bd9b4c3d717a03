#include "fdv/core/sensor_data.h"

#include <gtest/gtest.h>

#include <numbers>

namespace fdv {
namespace {

TEST(InterpolateOdometry, LinearInPositionAndSlerpInAttitude) {
  OdometrySample a, b;
  a.t = 0;
  b.t = 10 * kNsPerMs;
  a.p_W_B = {0, 0, 0};
  b.p_W_B = {1, 2, -3};
  a.v_W = {1, 0, 0};
  b.v_W = {3, 0, 0};
  b.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitZ()));
  const OdometrySample m = interpolate_odometry({a, b}, 5 * kNsPerMs);
  EXPECT_TRUE(m.p_W_B.isApprox(Eigen::Vector3d(0.5, 1, -1.5)));
  EXPECT_TRUE(m.v_W.isApprox(Eigen::Vector3d(2, 0, 0)));
  const Eigen::AngleAxisd aa(m.q_W_B);
  EXPECT_NEAR(aa.angle(), std::numbers::pi / 4, 1e-12);
  // Clamped at both ends.
  EXPECT_EQ(interpolate_odometry({a, b}, -5).p_W_B, a.p_W_B);
  EXPECT_EQ(interpolate_odometry({a, b}, 20 * kNsPerMs).p_W_B, b.p_W_B);
}

TEST(Time, SecondsConversionIsExactForWholeNanoseconds) {
  EXPECT_EQ(from_seconds(1.5), 1'500'000'000);
  EXPECT_DOUBLE_EQ(to_seconds(250 * kNsPerMs), 0.25);
}

}  // namespace
}  // namespace fdv
