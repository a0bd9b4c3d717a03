#include "fdv/estimation/collision_risk.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace fdv {
namespace {

// Centred isotropic Gaussian: |x|²/σ² is χ²₂, so P(|x| <= R) = 1 - exp(-R²/2σ²) (Rayleigh CDF) and
// E|x| = σ sqrt(π/2) (Rayleigh mean); rotating or shifting nothing changes it.
TEST(GaussianDisc, CentredIsotropicIsRayleigh) {
  for (double sigma : {0.01, 0.3, 1.0, 7.0}) {
    for (double R : {0.0, 0.1, 0.5, 2.0, 30.0}) {
      const double expected = 1 - std::exp(-R * R / (2 * sigma * sigma));
      EXPECT_NEAR(gaussian_disc_probability(Eigen::Vector2d::Zero(), sigma * sigma * Eigen::Matrix2d::Identity(), R),
                  expected, 1e-7)
          << "sigma " << sigma << " R " << R;
    }
    EXPECT_NEAR(gaussian_expected_norm(Eigen::Vector2d::Zero(), sigma * sigma * Eigen::Matrix2d::Identity()),
                sigma * std::sqrt(M_PI / 2), 1e-8 * sigma);
  }
}

// Rank 0: the indicator of the mean in the disc, and E|x| = |mean|.
TEST(GaussianDisc, ZeroCovarianceIsTheIndicator) {
  const Eigen::Matrix2d zero = Eigen::Matrix2d::Zero();
  EXPECT_EQ(gaussian_disc_probability({0.3, 0.39}, zero, 0.5), 1.0);
  EXPECT_EQ(gaussian_disc_probability({0.3, 0.41}, zero, 0.5), 0.0);
  EXPECT_DOUBLE_EQ(gaussian_expected_norm({3, 4}, zero), 5.0);
}

// Rank 1: x = mean + σ z e with e = (1, 1)/√2. With the mean (0.3, -0.3) ⊥ e, |x|² = 0.18 + σ²z², so x
// leaves the disc of radius 0.5 when |σ z| > sqrt(0.07): P = erf(sqrt(0.07) / (σ√2)). E|x| = E sqrt(0.18 + σ² z²); for σ → 0 it is |mean|.
TEST(GaussianDisc, RankOneIsAOneDimensionalInterval) {
  const Eigen::Vector2d e = Eigen::Vector2d(1, 1).normalized();
  const Eigen::Vector2d mean(0.3, -0.3);
  for (double sigma : {0.05, 0.2, 1.0}) {
    const Eigen::Matrix2d cov = sigma * sigma * e * e.transpose();
    EXPECT_NEAR(gaussian_disc_probability(mean, cov, 0.5), std::erf(std::sqrt(0.07) / (sigma * std::sqrt(2.0))), 1e-12);
  }
  // The mean beyond the radius across the line: never inside.
  EXPECT_EQ(gaussian_disc_probability({0.4, -0.4}, 0.04 * e * e.transpose(), 0.5), 0.0);
  // E|x| by a plain trapezoid over z (independent of the implementation's quadrature).
  const double sigma = 0.2;
  double expected = 0;
  const double dz = 1e-4;
  for (double z = -10; z <= 10; z += dz)
    expected += dz * std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI) * std::sqrt(0.18 + sigma * sigma * z * z);
  EXPECT_NEAR(gaussian_expected_norm(mean, sigma * sigma * e * e.transpose()), expected, 1e-7);
}

// A mean 12 σ away from a disc of radius 1 σ: the probability is below e^-60.
TEST(GaussianDisc, FarMeanIsNearZero) {
  const Eigen::Matrix2d cov = Eigen::Vector2d(0.04, 0.01).asDiagonal();
  EXPECT_LT(gaussian_disc_probability({0, 2.6}, cov, 0.2), 1e-20);
  EXPECT_NEAR(gaussian_expected_norm({0, 260}, cov), 260.0, 1e-3);  // + σ²/(2|μ|) ≈ 8e-5
}

// Anisotropic, axis-aligned: the disc lies between its inscribed and circumscribed squares, whose
// probabilities are products of erfs (independent axes).
TEST(GaussianDisc, AnisotropicBetweenItsSquares) {
  const Eigen::Vector2d mean(0.1, -0.2);
  const double sx = 0.3, sy = 0.05, R = 0.25;
  const Eigen::Matrix2d cov = Eigen::Vector2d(sx * sx, sy * sy).asDiagonal();
  auto box = [&](double half) {
    auto p = [](double m, double s, double h) {
      return 0.5 * (std::erf((h - m) / (s * std::sqrt(2.0))) - std::erf((-h - m) / (s * std::sqrt(2.0))));
    };
    return p(mean.x(), sx, half) * p(mean.y(), sy, half);
  };
  const double P = gaussian_disc_probability(mean, cov, R);
  EXPECT_GT(P, box(R / std::sqrt(2.0)));
  EXPECT_LT(P, box(R));
  // Rotating the mean and the covariance together changes nothing.
  const Eigen::Matrix2d rot = Eigen::Rotation2Dd(0.7).toRotationMatrix();
  EXPECT_NEAR(gaussian_disc_probability(rot * mean, rot * cov * rot.transpose(), R), P, 1e-9);
}

// Offset isotropic: |x| is Rice(ν = |mean|, σ). P(|x| <= R) and E|x| against a Monte Carlo of
// 400 000 draws (fixed seed): the binomial std of the fraction is <= 0.5/sqrt(4e5) = 8e-4, the std of
// the mean of |x| is σ/sqrt(4e5) = 1.6e-3 σ; tolerances are 4 standard errors.
TEST(GaussianDisc, OffsetIsotropicAgainstMonteCarlo) {
  const double sigma = 0.3;
  const Eigen::Vector2d mean(0.25, 0.35);
  const double R = 0.5;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, sigma);
  const int N = 400000;
  int inside = 0;
  double sum_norm = 0;
  for (int i = 0; i < N; ++i) {
    const Eigen::Vector2d x = mean + Eigen::Vector2d(n(rng), n(rng));
    inside += x.norm() <= R;
    sum_norm += x.norm();
  }
  const Eigen::Matrix2d cov = sigma * sigma * Eigen::Matrix2d::Identity();
  EXPECT_NEAR(gaussian_disc_probability(mean, cov, R), double(inside) / N, 4 * 0.5 / std::sqrt(double(N)));
  EXPECT_NEAR(gaussian_expected_norm(mean, cov), sum_norm / N, 4 * sigma / std::sqrt(double(N)));
}

}  // namespace
}  // namespace fdv
