#include "fdv/estimation/residuals.h"

#include <ceres/numeric_diff_cost_function.h>
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "ballistic_scenario.h"

namespace fdv {
namespace {

Eigen::Isometry3d random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized())
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return T;
}

/// Evaluates residuals and the 6-column Jacobian of a cost function at x.
template <int N>
void evaluate(const ceres::CostFunction& f, const double* x, Eigen::Matrix<double, N, 1>& r,
              Eigen::Matrix<double, N, 6, Eigen::RowMajor>& J) {
  const double* params[] = {x};
  double* jac[] = {J.data()};
  ASSERT_TRUE(f.Evaluate(params, r.data(), jac));
}

// Residual values against a hand computation, and autodiff Jacobians against central differences.
TEST(Residuals, ValuesAndJacobiansMatchIndependentComputation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d g(0, 0, -9.81);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Isometry3d T_W_C = random_pose(rng);
    const double tau = 0.2 * (u(rng) + 1);
    // A point ~4 m in front of the camera at τ, and (p0, v0) consistent with it plus a
    // perturbation.
    const Eigen::Vector3d v0(3 * u(rng), 3 * u(rng), 3 * u(rng));
    const Eigen::Vector3d p_tau = T_W_C * Eigen::Vector3d(u(rng), u(rng), 4 + u(rng));
    const Eigen::Vector3d p0 = p_tau - tau * v0 - 0.5 * tau * tau * g;
    double x[6];
    for (int i = 0; i < 3; ++i) x[i] = p0[i] + 0.1 * u(rng), x[3 + i] = v0[i] + 0.1 * u(rng);
    const Eigen::Vector2d xn(0.1 * u(rng), 0.1 * u(rng));
    const double sigma_n = 0.003, sigma_d = 0.07, depth = 4.1;

    // Independent expectation: the model written out with Eigen.
    const Eigen::Vector3d p = Eigen::Map<const Eigen::Vector3d>(x) +
                              tau * Eigen::Map<const Eigen::Vector3d>(x + 3) + 0.5 * tau * tau * g;
    const Eigen::Vector3d c = T_W_C.inverse() * p;
    const Eigen::Vector2d r_event = (c.head<2>() / c.z() - xn) / sigma_n;
    const double r_depth = (c.z() - depth) / sigma_d;

    std::unique_ptr<ceres::CostFunction> ev(
        EventResidual::create(tau, T_W_C, g, xn, sigma_n, 0.05));
    std::unique_ptr<ceres::CostFunction> dp(DepthResidual::create(tau, T_W_C, g, depth, sigma_d));
    auto ev_num =
        std::make_unique<ceres::NumericDiffCostFunction<EventResidual, ceres::CENTRAL, 2, 6>>(
            new EventResidual(tau, T_W_C, g, xn, sigma_n, 0.05));
    auto dp_num =
        std::make_unique<ceres::NumericDiffCostFunction<DepthResidual, ceres::CENTRAL, 1, 6>>(
            new DepthResidual(tau, T_W_C, g, depth, sigma_d));

    Eigen::Matrix<double, 2, 1> re, re_num;
    Eigen::Matrix<double, 2, 6, Eigen::RowMajor> Je, Je_num;
    evaluate<2>(*ev, x, re, Je);
    evaluate<2>(*ev_num, x, re_num, Je_num);
    EXPECT_LT((re - r_event).norm(), 1e-9 * (1 + r_event.norm()));
    EXPECT_LT((Je - Je_num).norm(), 1e-6 * (1 + Je.norm())) << Je << "\n" << Je_num;

    Eigen::Matrix<double, 1, 1> rd, rd_num;
    Eigen::Matrix<double, 1, 6, Eigen::RowMajor> Jd, Jd_num;
    evaluate<1>(*dp, x, rd, Jd);
    evaluate<1>(*dp_num, x, rd_num, Jd_num);
    EXPECT_NEAR(rd(0), r_depth, 1e-9 * (1 + std::abs(r_depth)));
    EXPECT_LT((Jd - Jd_num).norm(), 1e-6 * (1 + Jd.norm()));
  }
}

TEST(Residuals, EventResidualRefusesPointsBehindTheCamera) {
  const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  EventResidual f(0.0, T, Eigen::Vector3d::Zero(), Eigen::Vector2d::Zero(), 0.01, 0.05);
  double r[2];
  const double behind[6] = {0, 0, -1, 0, 0, 0};
  const double in_front[6] = {0.5, 0, 2, 0, 0, 0};
  EXPECT_FALSE(f(behind, r));
  ASSERT_TRUE(f(in_front, r));
  EXPECT_NEAR(r[0], 0.25 / 0.01, 1e-12);  // x/z = 0.25, σ = 0.01
}

}  // namespace
}  // namespace fdv
