#include "fdv/tracking/kalman_filter.h"

#include <Eigen/Cholesky>
#include <cassert>
#include <cmath>

#include "fdv/core/error.h"
#include "fdv/core/numeric.h"

namespace fdv {

std::string ImageFilterOptions::validate() const {
  if (!positive_finite(measurement_sigma_px)) return "measurement_sigma_px must be > 0";
  if (!std::isfinite(jerk_psd_px2_s5) || jerk_psd_px2_s5 < 0) return "jerk_psd_px2_s5 must be >= 0";
  if (!positive_finite(init_velocity_sigma_px_s)) return "init_velocity_sigma_px_s must be > 0";
  if (!positive_finite(init_acceleration_sigma_px_s2))
    return "init_acceleration_sigma_px_s2 must be > 0";
  return {};
}

double ImagePrediction::mahalanobis2(const Eigen::Vector2d& z) const {
  const Eigen::Vector2d y = z - position();
  return y.dot(innovation_covariance().ldlt().solve(y));
}

ImageKalmanFilter::Covariance ImageKalmanFilter::transition(double dt) {
  Covariance F = Covariance::Identity();
  for (int a = 0; a < 2; ++a) {
    F(a, 2 + a) = dt;
    F(a, 4 + a) = 0.5 * dt * dt;
    F(2 + a, 4 + a) = dt;
  }
  return F;
}

ImageKalmanFilter::Covariance ImageKalmanFilter::process_noise(double dt, double q) {
  dt = std::abs(dt);
  const double d2 = dt * dt, d3 = d2 * dt, d4 = d3 * dt, d5 = d4 * dt;
  // Per axis, derivative order i, j in {0, 1, 2}: integral of the white-jerk response.
  const double q1[3][3] = {
      {d5 / 20, d4 / 8, d3 / 6}, {d4 / 8, d3 / 3, d2 / 2}, {d3 / 6, d2 / 2, dt}};
  Covariance Q = Covariance::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int a = 0; a < 2; ++a) Q(2 * i + a, 2 * j + a) = q * q1[i][j];
  return Q;
}

ImageKalmanFilter::ImageKalmanFilter(const ImageFilterOptions& options, TimeNs t,
                                     const Eigen::Vector2d& z_px)
    : options_(options), t_(t) {
  if (const auto err = options.validate(); !err.empty())
    throw ConfigError("ImageFilterOptions: " + err);
  x_.head<2>() = z_px;
  const double sp = options.measurement_sigma_px, sv = options.init_velocity_sigma_px_s,
               sa = options.init_acceleration_sigma_px_s2;
  P_.diagonal() << sp * sp, sp * sp, sv * sv, sv * sv, sa * sa, sa * sa;
}

void ImageKalmanFilter::change_coordinates(const Eigen::Vector2d& position, const Eigen::Matrix2d& J) {
  Covariance T = Covariance::Zero();
  for (int k = 0; k < 3; ++k) T.block<2, 2>(2 * k, 2 * k) = J;
  x_ = T * x_;
  x_.head<2>() = position;
  P_ = T * P_ * T.transpose();
}

ImagePrediction ImageKalmanFilter::predict(TimeNs t, const Eigen::Vector2d& extra_variance_px2) const {
  const double dt = to_seconds(t - t_);
  const Covariance F = transition(dt);
  ImagePrediction p;
  p.t = t;
  p.x = F * x_;
  p.P = F * P_ * F.transpose() + process_noise(dt, options_.jerk_psd_px2_s5);
  const double r = options_.measurement_sigma_px * options_.measurement_sigma_px;
  p.R = Eigen::Matrix2d::Identity() * r;
  p.R.diagonal() += extra_variance_px2;
  return p;
}

double ImageKalmanFilter::update(TimeNs t, const Eigen::Vector2d& z_px, const Eigen::Vector2d& extra_variance_px2) {
  assert(t >= t_);
  const ImagePrediction p = predict(t, extra_variance_px2);
  const Eigen::Vector2d y = z_px - p.position();
  const Eigen::Matrix2d S = p.innovation_covariance();
  const Eigen::LDLT<Eigen::Matrix2d> S_ldlt(S);
  // K = P H^T S^-1, with H = [I2 0 0] so P H^T is the first two columns of P.
  const Eigen::Matrix<double, 6, 2> K = S_ldlt.solve(p.P.leftCols<2>().transpose()).transpose();
  x_ = p.x + K * y;
  // Joseph form keeps P symmetric positive semi-definite under rounding.
  Covariance IKH = Covariance::Identity();
  IKH.leftCols<2>() -= K;
  P_ = IKH * p.P * IKH.transpose() + K * p.R * K.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
  t_ = t;
  return y.dot(S_ldlt.solve(y));
}

}  // namespace fdv
