// Mean angular velocity of a window from IMU samples: hand-computed integrals.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "fdv/compensation/imu_window.h"

namespace fdv {
namespace {

ImuSample gyro(TimeNs t_ms, double wx) { return {t_ms * kNsPerMs, {wx, 0, 0}, {0, 0, 0}}; }

TEST(ImuWindow, RampIsAveragedExactly) {
  // ω_x(t) = t [ms] rad/s sampled every ms: the mean over [0, 25] ms is 12.5.
  std::vector<ImuSample> imu;
  for (int t = -5; t <= 30; ++t) imu.push_back(gyro(t, t));
  const ImuWindowSummary s = summarize_imu(imu, 0, 25 * kNsPerMs, 20 * kNsPerMs);
  ASSERT_TRUE(s.available);
  EXPECT_NEAR(s.mean_gyro_I.x(), 12.5, 1e-12);
  EXPECT_FALSE(s.gap);
  EXPECT_EQ(s.largest_gap_ns, kNsPerMs);
}

TEST(ImuWindow, HeldConstantBeyondTheOuterSamples) {
  // Samples at 5 ms (1 rad/s) and 15 ms (3 rad/s), window [0, 20] ms:
  // 1·5 (held) + (1+3)/2·10 + 3·5 (held) = 40 rad/s·ms over 20 ms -> 2 rad/s.
  const std::vector<ImuSample> imu{gyro(5, 1), gyro(15, 3)};
  const ImuWindowSummary s = summarize_imu(imu, 0, 20 * kNsPerMs, 20 * kNsPerMs);
  ASSERT_TRUE(s.available);
  EXPECT_NEAR(s.mean_gyro_I.x(), 2.0, 1e-12);
  EXPECT_EQ(s.largest_gap_ns, 10 * kNsPerMs);
  EXPECT_FALSE(s.gap);
  EXPECT_TRUE(summarize_imu(imu, 0, 20 * kNsPerMs, 8 * kNsPerMs).gap);
}

TEST(ImuWindow, NothingNearTheWindowIsMissing) {
  const std::vector<ImuSample> imu{gyro(-100, 1), gyro(-50, 1), gyro(200, 1)};
  EXPECT_FALSE(summarize_imu(imu, 0, 25 * kNsPerMs, 20 * kNsPerMs).available);
  EXPECT_FALSE(summarize_imu({}, 0, 25 * kNsPerMs, 20 * kNsPerMs).available);
  // One sample 15 ms after the window's end is within 20 ms: available, held constant, flagged
  // as a gap only if the distance from the window start exceeds the limit (40 ms > 20 ms).
  const std::vector<ImuSample> late{gyro(40, 2)};
  const ImuWindowSummary s = summarize_imu(late, 0, 25 * kNsPerMs, 20 * kNsPerMs);
  ASSERT_TRUE(s.available);
  EXPECT_NEAR(s.mean_gyro_I.x(), 2.0, 1e-12);
  EXPECT_TRUE(s.gap);
}

TEST(ImuWindow, BadSamplesAreSkippedAndCounted) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // 0, 10, 20 ms at 1 rad/s; a NaN sample at 5 ms; an out-of-order sample (back to 2 ms) at 100 rad/s.
  const std::vector<ImuSample> imu{gyro(0, 1), gyro(5, nan), gyro(10, 1), gyro(2, 100), gyro(20, 1)};
  const ImuWindowSummary s = summarize_imu(imu, 0, 20 * kNsPerMs, 20 * kNsPerMs);
  ASSERT_TRUE(s.available);
  EXPECT_EQ(s.samples_skipped, 2);
  EXPECT_EQ(s.samples_used, 3);
  EXPECT_NEAR(s.mean_gyro_I.x(), 1.0, 1e-12);
}

// A constant 2 rad/s about x for 30 ms: a fixed direction's coordinates turn by −0.06 rad about x
// (the frame turns the other way), backwards by the transpose; without samples nothing is known.
TEST(ImuTurn, ConstantRateTurnsFixedDirectionsBackwards) {
  std::vector<ImuSample> imu;
  for (int t = -5; t <= 40; ++t) imu.push_back(gyro(t, 2.0));
  const auto R = imu_turn(imu, 0, 30 * kNsPerMs, 20 * kNsPerMs);
  ASSERT_TRUE(R.has_value());
  const Eigen::Matrix3d expected = Eigen::AngleAxisd(-0.06, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_LT((*R - expected).norm(), 1e-12);
  const auto back = imu_turn(imu, 30 * kNsPerMs, 0, 20 * kNsPerMs);
  ASSERT_TRUE(back.has_value());
  EXPECT_LT((*back - expected.transpose()).norm(), 1e-12);
  EXPECT_FALSE(imu_turn({}, 0, 30 * kNsPerMs, 20 * kNsPerMs).has_value());
  EXPECT_TRUE(imu_turn(imu, 5 * kNsPerMs, 5 * kNsPerMs, 20 * kNsPerMs)->isIdentity());
}

// A rate ramping about z, ω(t) = 100 t (t in s): the angle turned over [0, 0.1] s is 0.5 rad, which
// the 5 ms steps' means give exactly (one axis: the rotations commute).
TEST(ImuTurn, ARampIntegratesToItsAngle) {
  std::vector<ImuSample> imu;
  for (int t = -5; t <= 105; ++t) imu.push_back({t * kNsPerMs, {0, 0, 0.1 * t}, {0, 0, 0}});
  const auto R = imu_turn(imu, 0, 100 * kNsPerMs, 20 * kNsPerMs);
  ASSERT_TRUE(R.has_value());
  EXPECT_LT((*R - Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix()).norm(), 1e-9);
}

}  // namespace
}  // namespace fdv
