#include "fdv/tracking/kalman_filter.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

#include "fdv/core/error.h"

namespace fdv {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;

// The transition matrix against the kinematics written out by hand, and the process noise
// against the closed form of ∫ F(s) G q Gᵀ F(s)ᵀ ds for white jerk (per axis, dt = 0.5 s).
TEST(ImageKalmanFilter, TransitionAndProcessNoiseClosedForms) {
  const Mat6 F = ImageKalmanFilter::transition(0.5);
  Eigen::Matrix<double, 6, 1> x;
  x << 10, 20, 3, -4, 2, 6;  // u v u' v' u'' v''
  const Eigen::Matrix<double, 6, 1> y = F * x;
  EXPECT_NEAR(y(0), 10 + 3 * 0.5 + 0.5 * 2 * 0.25, 1e-12);
  EXPECT_NEAR(y(1), 20 - 4 * 0.5 + 0.5 * 6 * 0.25, 1e-12);
  EXPECT_NEAR(y(2), 3 + 2 * 0.5, 1e-12);
  EXPECT_NEAR(y(3), -4 + 6 * 0.5, 1e-12);
  EXPECT_NEAR(y(5), 6, 1e-12);

  const double q = 3.0, dt = 0.5;
  const Mat6 Q = ImageKalmanFilter::process_noise(dt, q);
  EXPECT_NEAR(Q(0, 0), q * std::pow(dt, 5) / 20, 1e-15);
  EXPECT_NEAR(Q(0, 2), q * std::pow(dt, 4) / 8, 1e-15);
  EXPECT_NEAR(Q(0, 4), q * std::pow(dt, 3) / 6, 1e-15);
  EXPECT_NEAR(Q(2, 2), q * std::pow(dt, 3) / 3, 1e-15);
  EXPECT_NEAR(Q(2, 4), q * dt * dt / 2, 1e-15);
  EXPECT_NEAR(Q(4, 4), q * dt, 1e-15);
  EXPECT_EQ(Q(0, 1), 0.0);  // axes independent
  EXPECT_EQ(Q(1, 1), Q(0, 0));

  // A continuous-time model composes: two steps equal one step of the summed length.
  const double a = 0.013, b = 0.029;
  EXPECT_LT((ImageKalmanFilter::transition(a) * ImageKalmanFilter::transition(b) -
             ImageKalmanFilter::transition(a + b))
                .norm(),
            1e-12);
  const Mat6 Qab = ImageKalmanFilter::process_noise(a, q) +
                   ImageKalmanFilter::transition(a) * ImageKalmanFilter::process_noise(b, q) *
                       ImageKalmanFilter::transition(a).transpose();
  EXPECT_LT((Qab - ImageKalmanFilter::process_noise(a + b, q)).norm(), 1e-12 * q);
}

TEST(ImageKalmanFilter, RejectsInvalidOptions) {
  ImageFilterOptions o;
  o.measurement_sigma_px = 0;
  EXPECT_THROW(ImageKalmanFilter(o, 0, Eigen::Vector2d::Zero()), ConfigError);
}

// Truth driven by continuous white jerk (integrated at 0.1 ms, independently of the filter's Q),
// measured every 25 ms with 1.5 px noise and a few missed windows. A consistent filter gives a
// mean normalised innovation squared of 2 (χ², 2 dof) and keeps the true position inside its 3σ
// ellipse (χ²₂ ≤ 11.83) ~99.7 % of the time.
TEST(ImageKalmanFilter, ConsistentOnWhiteJerkTruth) {
  ImageFilterOptions o;
  o.measurement_sigma_px = 1.5;
  o.jerk_psd_px2_s5 = 6e7;
  std::mt19937 rng(5);
  std::normal_distribution<double> n01(0, 1);
  double nis_sum = 0, inside = 0;
  int nis_n = 0, nees_n = 0;
  for (int run = 0; run < 40; ++run) {
    // State per axis: position, velocity, acceleration; jerk white with PSD q.
    Eigen::Matrix<double, 3, 2> s;
    s << 320, 240, 800 * n01(rng), 800 * n01(rng), 3000 * n01(rng), 3000 * n01(rng);
    const double h = 1e-4;
    TimeNs t = 0;
    auto measure = [&]() {
      return Eigen::Vector2d(s(0, 0) + o.measurement_sigma_px * n01(rng),
                             s(0, 1) + o.measurement_sigma_px * n01(rng));
    };
    // Start with the truth's velocity and acceleration inside the prior.
    ImageKalmanFilter f(o, t, measure());
    for (int k = 1; k <= 40; ++k) {
      for (int i = 0; i < 250;
           ++i) {  // 25 ms of white jerk, exact discretisation of each tiny step
        for (int a = 0; a < 2; ++a) {
          const double j = std::sqrt(o.jerk_psd_px2_s5 / h) * n01(rng);
          s(0, a) += h * s(1, a) + 0.5 * h * h * s(2, a) + h * h * h / 6 * j;
          s(1, a) += h * s(2, a) + 0.5 * h * h * j;
          s(2, a) += h * j;
        }
      }
      t += 25 * kNsPerMs;
      if (k % 7 == 3) continue;  // missed detection: predict through it
      const Eigen::Vector2d z = measure();
      const ImagePrediction p = f.predict(t);
      const double d2 = f.update(t, z);
      EXPECT_NEAR(d2, p.mahalanobis2(z), 1e-9);
      if (k > 5) {  // after the prior has washed out
        nis_sum += d2;
        ++nis_n;
        const Eigen::Vector2d e = f.state().head<2>() - s.row(0).transpose();
        inside += e.dot(f.covariance().topLeftCorner<2, 2>().ldlt().solve(e)) <= 11.83;
        ++nees_n;
      }
    }
  }
  const double nis = nis_sum / nis_n;
  EXPECT_GT(nis, 1.7) << nis;
  EXPECT_LT(nis, 2.3) << nis;
  EXPECT_GT(inside / nees_n, 0.98);
}

// Constant acceleration (no jerk) with a gap of three missed windows: the error stays within
// 3σ of the filter's covariance at every prediction and update, and the estimate converges.
TEST(ImageKalmanFilter, TracksConstantAccelerationThroughMisses) {
  ImageFilterOptions o;
  std::mt19937 rng(9);
  std::normal_distribution<double> n01(0, 1);
  const Eigen::Vector2d p0(100, 400), v0(900, -600), a0(-2000, 1500);
  auto truth = [&](TimeNs t) {
    const double s = to_seconds(t);
    return Eigen::Vector2d(p0 + s * v0 + 0.5 * s * s * a0);
  };
  ImageKalmanFilter f(o, 0, truth(0) + 1.5 * Eigen::Vector2d(n01(rng), n01(rng)));
  for (int k = 1; k <= 16; ++k) {
    const TimeNs t = k * 25 * kNsPerMs;
    const ImagePrediction p = f.predict(t);
    const Eigen::Vector2d e = p.position() - truth(t);
    EXPECT_LE(e.dot(p.position_covariance().ldlt().solve(e)), 11.83)
        << "prediction at window " << k;
    if (k >= 8 && k <= 10) continue;  // three missed windows
    f.update(t, truth(t) + 1.5 * Eigen::Vector2d(n01(rng), n01(rng)));
  }
  // Final position and velocity within their 3σ ellipses; position within a pixel and a half.
  const Eigen::Vector2d ep = f.state().head<2>() - truth(16 * 25 * kNsPerMs);
  const Eigen::Vector2d ev = f.state().segment<2>(2) - (v0 + 0.4 * a0);
  EXPECT_LE(ep.dot(f.covariance().topLeftCorner<2, 2>().ldlt().solve(ep)), 11.83);
  EXPECT_LE(ev.dot(f.covariance().block<2, 2>(2, 2).ldlt().solve(ev)), 11.83);
  EXPECT_LT(ep.norm(), 3.0);
}

}  // namespace
}  // namespace fdv
