#include "fdv/estimation/collision.h"

#include <algorithm>
#include <cmath>
#include <unsupported/Eigen/Polynomials>
#include <vector>

#include "fdv/core/error.h"

namespace fdv {

namespace {

/// Real roots of Σ c[i] sⁱ in [lo, hi], ascending. Leading coefficients negligible against the
/// others are dropped first (the solver needs a non-zero leading coefficient).
std::vector<double> real_roots_in(std::vector<double> c, double lo, double hi) {
  double scale = 0;
  for (double v : c) scale = std::max(scale, std::abs(v));
  std::vector<double> roots;
  if (scale == 0) return roots;
  while (c.size() > 1 && std::abs(c.back()) <= 1e-13 * scale) c.pop_back();
  if (c.size() < 2) return roots;
  auto eval = [&c](double s, double& dp) {
    double p = 0;
    dp = 0;
    for (std::size_t i = c.size(); i-- > 0;) {
      dp = dp * s + p;
      p = p * s + c[i];
    }
    return p;
  };
  Eigen::VectorXd coeffs =
      Eigen::Map<const Eigen::VectorXd>(c.data(), static_cast<Eigen::Index>(c.size()));
  std::vector<double> candidates;
  if (c.size() == 2) {
    candidates.push_back(-c[0] / c[1]);
  } else {
    Eigen::PolynomialSolver<double, Eigen::Dynamic> solver(coeffs);
    for (const auto& z : solver.roots())
      if (std::abs(z.imag()) <= 1e-6 * std::max(1.0, std::abs(z))) candidates.push_back(z.real());
  }
  for (double s : candidates) {
    for (int it = 0; it < 3; ++it) {  // Newton polish
      double dp = 0;
      const double p = eval(s, dp);
      if (dp == 0) break;
      s -= p / dp;
    }
    if (s >= lo && s <= hi && std::isfinite(s)) roots.push_back(s);
  }
  std::sort(roots.begin(), roots.end());
  return roots;
}

}  // namespace

std::string PredictionOptions::validate() const {
  if (!(horizon_s > 0) || !std::isfinite(horizon_s)) return "horizon_s must be > 0";
  if (!(safety_radius_m >= 0) || !std::isfinite(safety_radius_m))
    return "safety_radius_m must be >= 0";
  if (!(odometry_position_sigma_m >= 0) || !std::isfinite(odometry_position_sigma_m))
    return "odometry_position_sigma_m must be >= 0";
  if (!(odometry_velocity_sigma_m_s >= 0) || !std::isfinite(odometry_velocity_sigma_m_s))
    return "odometry_velocity_sigma_m_s must be >= 0";
  return {};
}

CollisionPrediction predict_collision(const BallisticTrajectory& object,
                                      const OdometrySample& vehicle,
                                      const PredictionOptions& options) {
  if (auto err = options.validate(); !err.empty()) throw ConfigError("PredictionOptions: " + err);
  const TimeNs now = vehicle.t;
  const Eigen::Vector3d a = object.position(now) - vehicle.p_W_B;
  const Eigen::Vector3d b = object.velocity(now) - vehicle.v_W;
  const Eigen::Vector3d c = 0.5 * object.gravity_W;
  auto rel = [&](double s) -> Eigen::Vector3d { return a + s * b + s * s * c; };
  const double H = options.horizon_s;

  // |d|² = c·c s⁴ + 2 b·c s³ + (b·b + 2 a·c) s² + 2 a·b s + a·a ; derivative / 2:
  const std::vector<double> quartic = {a.dot(a), 2 * a.dot(b), b.dot(b) + 2 * a.dot(c),
                                       2 * b.dot(c), c.dot(c)};
  const std::vector<double> half_derivative = {a.dot(b), b.dot(b) + 2 * a.dot(c), 3 * b.dot(c),
                                               2 * c.dot(c)};

  double s_best = 0, d2_best = a.squaredNorm();
  auto consider = [&](double s) {
    const double d2 = rel(s).squaredNorm();
    if (d2 < d2_best) d2_best = d2, s_best = s;
  };
  for (double s : real_roots_in(half_derivative, 0, H)) consider(s);
  consider(H);

  CollisionPrediction out;
  ClosestApproach& ca = out.closest;
  ca.time_from_now_s = s_best;
  ca.t = now + from_seconds(s_best);
  ca.miss_distance_m = std::sqrt(d2_best);
  ca.vehicle_W = vehicle.p_W_B + s_best * vehicle.v_W;
  ca.object_W = ca.vehicle_W + rel(s_best);
  ca.offset_B = vehicle.q_W_B.conjugate() * rel(s_best);
  ca.at_horizon_end = s_best == H && rel(H).dot(b + 2 * H * c) < 0;
  ca.receding = s_best == 0;

  const double R2 = options.safety_radius_m * options.safety_radius_m;
  if (a.squaredNorm() <= R2) {
    out.contact = now;
    out.time_to_contact_s = 0;
  } else if (d2_best <= R2) {
    std::vector<double> q = quartic;
    q[0] -= R2;
    const auto roots = real_roots_in(q, 0, s_best);
    const double s = roots.empty() ? s_best : roots.front();
    out.contact = now + from_seconds(s);
    out.time_to_contact_s = s;
  }
  return out;
}

}  // namespace fdv
