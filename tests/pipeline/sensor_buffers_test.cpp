#include "fdv/pipeline/sensor_buffers.h"

#include <gtest/gtest.h>

namespace fdv {
namespace {

ImuSample gyro(TimeNs t, double wz) { return {t, Eigen::Vector3d(0, 0, wz), Eigen::Vector3d::Zero()}; }

TEST(ImuBuffer, MeanOfALinearRampIsItsMidpointValue) {
  ImuBuffer b;
  // wz(t) = t [ms] rad/s, sampled every 1 ms: over [10, 35] ms the mean is 22.5.
  for (int ms = 0; ms <= 50; ++ms) ASSERT_TRUE(b.push(gyro(ms * kNsPerMs, ms)));
  const auto m = b.mean_gyro(10 * kNsPerMs, 35 * kNsPerMs);
  ASSERT_TRUE(m.has_value());
  EXPECT_NEAR(m->gyro_rad_s.z(), 22.5, 1e-12);
  EXPECT_FALSE(m->gap);
  EXPECT_EQ(m->samples, 26);
  // Off-grid interval [10.5, 11.5] ms: mean 11.
  EXPECT_NEAR(b.mean_gyro(10'500'000, 11'500'000)->gyro_rad_s.z(), 11.0, 1e-12);
}

TEST(ImuBuffer, GapsAreFlaggedAndMissingDataIsNothing) {
  ImuBuffer b(2 * kNsPerS, 20 * kNsPerMs);
  b.push(gyro(0, 1));
  b.push(gyro(5 * kNsPerMs, 1));
  b.push(gyro(100 * kNsPerMs, 3));  // 95 ms gap
  const auto m = b.mean_gyro(10 * kNsPerMs, 35 * kNsPerMs);
  ASSERT_TRUE(m.has_value());
  EXPECT_TRUE(m->gap);
  EXPECT_EQ(m->largest_gap_ns, 95 * kNsPerMs);
  EXPECT_FALSE(b.mean_gyro(400 * kNsPerMs, 425 * kNsPerMs).has_value());  // far beyond the data
  EXPECT_FALSE(b.push(gyro(50 * kNsPerMs, 0)));                          // older sample refused
  EXPECT_FALSE(ImuBuffer().mean_gyro(0, 10).has_value());
}

TEST(OdometryBuffer, InterpolatesAndExtrapolatesOnlyABoundedTime) {
  OdometryBuffer b(5 * kNsPerS, 50 * kNsPerMs);
  for (int i = 0; i <= 10; ++i) {
    OdometrySample s;
    s.t = i * 10 * kNsPerMs;
    s.p_W_B = {2.0 * i * 0.01, 0, 1};  // 2 m/s along x
    s.v_W = {2, 0, 0};
    b.push(s);
  }
  EXPECT_NEAR(b.at(35 * kNsPerMs)->p_W_B.x(), 0.07, 1e-12);
  EXPECT_NEAR(b.at(130 * kNsPerMs)->p_W_B.x(), 0.26, 1e-12);  // 30 ms past the end at 2 m/s
  EXPECT_FALSE(b.at(200 * kNsPerMs).has_value());
  EXPECT_FALSE(OdometryBuffer().at(0).has_value());
}

}  // namespace
}  // namespace fdv
