// IMU of a known constant-rate rotation and constant acceleration: exact without noise, and
// within the discrete-time noise model with it. Expectations computed here from first principles.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "fdv/sim/simulator.h"
#include "sim_test_util.h"

namespace fdv::sim {
namespace {

using test::kDeg;

ScenarioConfig spinning_and_accelerating() {
  ScenarioConfig c = test::still_scene(32, 24, 1.0);
  c.vehicle.velocity_W_m_s = {0.5, -0.2, 0.1};
  c.vehicle.acceleration_W_m_s2 = {1.0, 0.5, -0.3};
  c.vehicle.omega_B_rad_s = {0.3, -0.2, 0.5};
  c.vehicle.rpy0_deg = {10.0, -5.0, 30.0};
  c.imu.rate_hz = 500;
  c.imu.gyro_noise_density = c.imu.accel_noise_density = 0;
  c.imu.gyro_random_walk = c.imu.accel_random_walk = 0;
  c.imu.gyro_bias_sigma = c.imu.accel_bias_sigma = 0;
  return c;
}

/// The true IMU reading: body rate and specific force R_W_B^T (a - g), rotated into the IMU
/// frame of an FRD IMU on an FLU body (R_B_I = diag(1, -1, -1)).
void expected(const ScenarioConfig& c, double t, Eigen::Vector3d& gyro, Eigen::Vector3d& accel) {
  const Eigen::Vector3d w = c.vehicle.omega_B_rad_s;
  const Eigen::Matrix3d R0 = (Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(-5 * kDeg, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(10 * kDeg, Eigen::Vector3d::UnitX()))
                                 .toRotationMatrix();
  const Eigen::Matrix3d R_W_B =
      R0 * Eigen::AngleAxisd(w.norm() * t, w.normalized()).toRotationMatrix();
  const Eigen::Matrix3d R_I_B = Eigen::Vector3d(1, -1, -1).asDiagonal();
  gyro = R_I_B * w;
  accel =
      R_I_B * R_W_B.transpose() * (c.vehicle.acceleration_W_m_s2 - Eigen::Vector3d(0, 0, -9.81));
}

TEST(SimImu, ExactWithoutNoise) {
  const ScenarioConfig c = spinning_and_accelerating();
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  ASSERT_EQ(sink.imu.size(), 501u);  // 0, 2 ms, ..., 1 s
  for (const auto& s : sink.imu) {
    Eigen::Vector3d g, a;
    expected(c, to_seconds(s.t), g, a);
    EXPECT_LT((s.gyro_rad_s - g).norm(), 1e-9);
    EXPECT_LT((s.accel_m_s2 - a).norm(), 1e-9);
  }
  // The true body motion handed out as truth agrees with the same model.
  ASSERT_FALSE(sink.body.empty());
  const auto& b = sink.body.back();
  const double t = to_seconds(b.t);
  const Eigen::Vector3d p = c.vehicle.start_W_m + c.vehicle.velocity_W_m_s * t +
                            0.5 * c.vehicle.acceleration_W_m_s2 * t * t;
  EXPECT_LT((b.p_W_B - p).norm(), 1e-9);
}

TEST(SimImu, WhiteNoiseMatchesTheDensity) {
  ScenarioConfig c = spinning_and_accelerating();
  c.imu.gyro_noise_density = 1e-4;  // σ per sample = density * sqrt(rate)
  c.imu.accel_noise_density = 1.5e-3;
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  const double n = static_cast<double>(sink.imu.size()) * 3;
  double sg = 0, sa = 0, mg = 0, ma = 0;
  for (const auto& s : sink.imu) {
    Eigen::Vector3d g, a;
    expected(c, to_seconds(s.t), g, a);
    const Eigen::Vector3d eg = s.gyro_rad_s - g, ea = s.accel_m_s2 - a;
    sg += eg.squaredNorm(), sa += ea.squaredNorm(), mg += eg.sum(), ma += ea.sum();
  }
  const double sigma_g = 1e-4 * std::sqrt(500.0), sigma_a = 1.5e-3 * std::sqrt(500.0);
  // Sample σ of 1503 values: relative standard error ~1.8 %; allow 10 %.
  EXPECT_NEAR(std::sqrt(sg / n), sigma_g, 0.1 * sigma_g);
  EXPECT_NEAR(std::sqrt(sa / n), sigma_a, 0.1 * sigma_a);
  // Zero mean (no bias configured): 5 standard errors.
  EXPECT_LT(std::abs(mg / n), 5 * sigma_g / std::sqrt(n));
  EXPECT_LT(std::abs(ma / n), 5 * sigma_a / std::sqrt(n));
}

TEST(SimImu, BiasRandomWalkGrowsAsTheSquareRootOfTime) {
  // Gyro bias random walk only: after T seconds the bias has σ = walk * sqrt(T) per axis.
  // Over 20 seeds x 3 axes the pooled σ of the final bias error must match within 35 %.
  double sum2 = 0;
  int count = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    ScenarioConfig c = spinning_and_accelerating();
    c.seed = seed;
    c.duration_s = 0.5;
    c.imu.gyro_random_walk = 0.01;
    Simulator sim(c);
    MemorySink sink;
    sim.run(sink);
    Eigen::Vector3d g, a;
    expected(c, to_seconds(sink.imu.back().t), g, a);
    const Eigen::Vector3d e = sink.imu.back().gyro_rad_s - g;
    sum2 += e.squaredNorm();
    count += 3;
  }
  const double sigma = 0.01 * std::sqrt(0.5);
  EXPECT_NEAR(std::sqrt(sum2 / count), sigma, 0.35 * sigma);
}

}  // namespace
}  // namespace fdv::sim
