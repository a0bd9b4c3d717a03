#include "fdv/estimation/collision_risk.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <vector>

#include "fdv/core/error.h"

namespace fdv {

namespace {

constexpr double kSqrt1_2 = 0.70710678118654752440;
constexpr double kInvSqrt2Pi = 0.39894228040143267794;
/// Gaussian tails beyond this many sigmas (< 2e-19 of the mass) are left out of the quadratures.
constexpr double kTailSigmas = 9.0;
/// Most bisections of one adaptive quadrature (each 15 evaluations): a bound on the work when an
/// integrand is rough (a step when a conditional std is 0).
constexpr int kMaxBisections = 2000;
/// gaussian_expected_norm integrates in polar coordinates down to this σu/σv (beyond, the angular
/// peak along the long axis gets too narrow to find reliably; a nested quadrature takes over).
constexpr double kPolarMinAxisRatio = 1e-3;
/// Covariances: relative asymmetry and negative eigenvalue (of max(1, largest entry)) tolerated as
/// round-off.
constexpr double kSymmetryTolerance = 1e-9;
/// A vehicle state may precede the estimate's newest observation by this much (docs/ESTIMATION.md).
constexpr TimeNs kStateLatenessToleranceNs = 1 * kNsPerMs;
/// Below this miss distance [m] its direction is undefined.
constexpr double kZeroMissM = 1e-9;

double normal_pdf(double z) { return kInvSqrt2Pi * std::exp(-0.5 * z * z); }

/// P(lo <= μ + σ z <= hi), z ~ N(0, 1); σ = 0 is the indicator.
double normal_interval(double mu, double sigma, double lo, double hi) {
  if (!(hi > lo)) return 0.0;
  if (sigma <= 0) return (mu >= lo && mu <= hi) ? 1.0 : 0.0;
  return 0.5 * (std::erf((hi - mu) * kSqrt1_2 / sigma) - std::erf((lo - mu) * kSqrt1_2 / sigma));
}

/// Adaptive Gauss-Kronrod (7-15 points, QUADPACK's QK15 rule) on [a, b] to an absolute tolerance:
/// an interval is bisected while |K15 - G7| exceeds its share of the tolerance and the round-off
/// floor (50 ε ∫|f|), within a budget of bisections. Deterministic.
template <class F>
double integrate(const F& f, double a, double b, double abs_tol, int& budget) {
  static constexpr std::array<double, 8> xk = {
      0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
      0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
      0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
      0.207784955007898467600689403773245, 0.0};
  static constexpr std::array<double, 8> wk = {
      0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
      0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
      0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
      0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
  // Gauss weights of the nodes xk[1], xk[3], xk[5], xk[7].
  static constexpr std::array<double, 4> wg = {
      0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
      0.381830050505118944950369775488975, 0.417959183673469387755102040816327};
  const double c = 0.5 * (a + b), h = 0.5 * (b - a);
  const double fc = f(c);
  double kronrod = wk[7] * fc, gauss = wg[3] * fc, kronrod_abs = wk[7] * std::abs(fc);
  for (int i = 0; i < 7; ++i) {
    const double f1 = f(c - h * xk[i]), f2 = f(c + h * xk[i]);
    kronrod += wk[i] * (f1 + f2);
    kronrod_abs += wk[i] * (std::abs(f1) + std::abs(f2));
    if (i % 2 == 1) gauss += wg[i / 2] * (f1 + f2);
  }
  kronrod *= h;
  gauss *= h;
  const double error = std::abs(kronrod - gauss);
  if (error <= abs_tol || error <= 50 * std::numeric_limits<double>::epsilon() * std::abs(h) * kronrod_abs ||
      budget <= 0)
    return kronrod;
  --budget;
  return integrate(f, a, c, 0.5 * abs_tol, budget) + integrate(f, c, b, 0.5 * abs_tol, budget);
}

/// ∫ over [a, b] split at the breakpoints inside it (kinks and peaks of the integrand).
template <class F>
double integrate_split(const F& f, double a, double b, std::vector<double> breaks, double abs_tol) {
  if (!(b > a)) return 0.0;
  breaks.push_back(a);
  breaks.push_back(b);
  std::sort(breaks.begin(), breaks.end());
  int budget = kMaxBisections;
  double sum = 0;
  double lo = a;
  for (double x : breaks) {
    if (x <= lo || x > b) continue;
    sum += integrate(f, lo, x, abs_tol * (x - lo) / (b - a), budget);
    lo = x;
  }
  return sum;
}

/// The Gaussian in its eigenbasis: independent axes u (std σu ≤ σv) and v; the mean's coordinates
/// (a, b) on them. A std is exactly 0 along a null direction of the covariance.
struct EigenGaussian2 {
  double a = 0, b = 0, sigma_u = 0, sigma_v = 0;
  Eigen::Vector2d u_axis = Eigen::Vector2d::UnitX(), v_axis = Eigen::Vector2d::UnitY();
};

EigenGaussian2 eigen_gaussian(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(0.5 * (covariance + covariance.transpose()));
  const Eigen::Vector2d lambda = es.eigenvalues();  // ascending
  EigenGaussian2 g;
  g.u_axis = es.eigenvectors().col(0);
  g.v_axis = es.eigenvectors().col(1);
  g.a = g.u_axis.dot(mean);
  g.b = g.v_axis.dot(mean);
  // Below 1e-12 of the largest eigenvalue (the solver's round-off on a singular matrix), or below
  // 1e-30 m² on an all-zero one, a direction is exactly degenerate.
  const double scale2 = std::max(lambda(1), 0.0);
  g.sigma_v = scale2 > 1e-30 ? std::sqrt(scale2) : 0.0;
  g.sigma_u = lambda(0) > 1e-12 * scale2 && g.sigma_v > 0 ? std::sqrt(lambda(0)) : 0.0;
  return g;
}

}  // namespace

double gaussian_disc_probability(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance,
                                 double radius) {
  if (!(radius >= 0)) return 0.0;
  const EigenGaussian2 g = eigen_gaussian(mean, covariance);
  const double R2 = radius * radius;
  // Given u, v must lie within ±h(u) = ±sqrt(R² - u²): the conditional probability is an erf.
  auto chord = [&](double u) { return std::sqrt(std::max(0.0, R2 - u * u)); };
  if (g.sigma_u == 0) {
    if (std::abs(g.a) > radius) return 0.0;
    const double h = chord(g.a);
    return normal_interval(g.b, g.sigma_v, -h, h);
  }
  // Integrate over the narrow axis u (z = standardised u), where the density is confined to a few
  // σu; the chord's square-root ends at u = ±R are breakpoints.
  const double z_lo = std::max(-kTailSigmas, (-radius - g.a) / g.sigma_u);
  const double z_hi = std::min(kTailSigmas, (radius - g.a) / g.sigma_u);
  auto f = [&](double z) {
    const double h = chord(g.a + g.sigma_u * z);
    return normal_pdf(z) * normal_interval(g.b, g.sigma_v, -h, h);
  };
  return std::clamp(integrate_split(f, z_lo, z_hi, {-g.a / g.sigma_u}, 1e-10), 0.0, 1.0);
}

double gaussian_expected_norm(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance) {
  const EigenGaussian2 g = eigen_gaussian(mean, covariance);
  if (g.sigma_v == 0) return mean.norm();
  const double tol = 1e-10 * (mean.norm() + g.sigma_v);
  // E over v of sqrt(u² + v²), u fixed: a kink at v = 0 when u = 0.
  auto along_v = [&](double u) {
    auto f = [&](double w) {
      const double v = g.b + g.sigma_v * w;
      return normal_pdf(w) * std::sqrt(u * u + v * v);
    };
    return integrate_split(f, -kTailSigmas, kTailSigmas, {-g.b / g.sigma_v}, tol);
  };
  if (g.sigma_u == 0) return along_v(g.a);
  if (g.sigma_u < kPolarMinAxisRatio * g.sigma_v) {  // nearly a line: the nested quadrature
    auto f = [&](double z) { return normal_pdf(z) * along_v(g.a + g.sigma_u * z); };
    return integrate_split(f, -kTailSigmas, kTailSigmas, {-g.a / g.sigma_u}, tol);
  }
  // Polar coordinates about the origin: along each direction ω the density is a Gaussian in r,
  // exp(-½(A r² - 2 B r + K)) with K = μᵀΣ⁻¹μ, so ∫ r·r p(rω) dr is closed-form (the second moment of a normal
  // truncated to r >= 0, t = B/√A); one quadrature over the angle remains. Breakpoints where the
  // integrand peaks: the mean's direction and the long axis, at the angular spreads σv/|μ| and σu/σv.
  const double iu = 1 / (g.sigma_u * g.sigma_u), iv = 1 / (g.sigma_v * g.sigma_v);
  auto f = [&](double phi) {
    const double cu = std::cos(phi), cv = std::sin(phi);
    const double A = cu * cu * iu + cv * cv * iv, B = g.a * cu * iu + g.b * cv * iv;
    const double s = 1 / std::sqrt(A), t = B * s;
    const double Phi = 0.5 * std::erfc(-t * kSqrt1_2);
    // K - B²/A, the Mahalanobis distance² of the mean from the line along ω, without cancellation:
    const double d = g.a * cv - g.b * cu;
    return std::exp(-0.5 * iu * iv * d * d / A) * s * s * s * ((t * t + 1) * Phi + t * normal_pdf(t)) *
           kInvSqrt2Pi / (g.sigma_u * g.sigma_v);
  };
  std::vector<double> breaks;
  const double mean_dir = std::atan2(g.b, g.a), spread_mean = g.sigma_v / std::max(std::hypot(g.a, g.b), 1e-300);
  const double spread_axis = g.sigma_u / g.sigma_v;
  for (double k : {0.0, 1.0, 4.0, 16.0}) {
    for (double sign : {-1.0, 1.0}) {
      if (k * spread_mean < M_PI) breaks.push_back(std::remainder(mean_dir + sign * k * spread_mean, 2 * M_PI));
      for (double axis : {-M_PI / 2, M_PI / 2})
        if (k * spread_axis < M_PI / 2) breaks.push_back(axis + sign * k * spread_axis);
    }
  }
  return integrate_split(f, -M_PI, M_PI, breaks, tol);
}

namespace {

/// P(|p| <= R and ℓ >= -sqrt(R² - |p|²)) for (p, ℓ) ~ N(mean, covariance), p in the plane: the
/// object crosses the disc |p| <= R, or is inside the sphere, on the side ℓ >= 0 of it. Given p, ℓ is
/// normal (regression on p's eigen-axes); the conditional probability is integrated over the disc.
double crossing_probability(const Eigen::Vector3d& mean, const Eigen::Matrix3d& covariance, double radius) {
  const EigenGaussian2 g = eigen_gaussian(mean.head<2>(), covariance.topLeftCorner<2, 2>());
  const Eigen::Vector2d cross = covariance.topRightCorner<2, 1>();
  const double c_u = g.u_axis.dot(cross), c_v = g.v_axis.dot(cross);
  const double beta_u = g.sigma_u > 0 ? c_u / (g.sigma_u * g.sigma_u) : 0.0;
  const double beta_v = g.sigma_v > 0 ? c_v / (g.sigma_v * g.sigma_v) : 0.0;
  const double sigma_l = std::sqrt(std::max(0.0, covariance(2, 2) - beta_u * c_u - beta_v * c_v));
  const double R2 = radius * radius;
  const double inf = std::numeric_limits<double>::infinity();
  auto given = [&](double u, double v) {  // P(ℓ >= -chord | p = (u, v))
    const double chord = std::sqrt(std::max(0.0, R2 - u * u - v * v));
    return normal_interval(mean(2) + beta_u * (u - g.a) + beta_v * (v - g.b), sigma_l, -chord, inf);
  };
  auto along_v = [&](double u) {  // ∫ over the chord at u of the density of v times given(u, v)
    const double h = std::sqrt(std::max(0.0, R2 - u * u));
    if (g.sigma_v == 0) return std::abs(g.b) <= h ? given(u, g.b) : 0.0;
    auto f = [&](double w) { return normal_pdf(w) * given(u, g.b + g.sigma_v * w); };
    return integrate_split(f, std::max(-kTailSigmas, (-h - g.b) / g.sigma_v),
                           std::min(kTailSigmas, (h - g.b) / g.sigma_v), {}, 1e-10);
  };
  if (g.sigma_u == 0) return std::abs(g.a) <= radius ? along_v(g.a) : 0.0;
  auto f = [&](double z) { return normal_pdf(z) * along_v(g.a + g.sigma_u * z); };
  const double z_lo = std::max(-kTailSigmas, (-radius - g.a) / g.sigma_u);
  const double z_hi = std::min(kTailSigmas, (radius - g.a) / g.sigma_u);
  return std::clamp(integrate_split(f, z_lo, z_hi, {-g.a / g.sigma_u}, 1e-9), 0.0, 1.0);
}


/// Why a covariance is unusable, or empty.
std::string covariance_problem(const Eigen::Matrix<double, 6, 6>& cov) {
  if (!cov.allFinite()) return "is not finite";
  const double scale = std::max(1.0, cov.cwiseAbs().maxCoeff());
  if ((cov - cov.transpose()).cwiseAbs().maxCoeff() > kSymmetryTolerance * scale) return "is not symmetric";
  const double min_eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(cov, Eigen::EigenvaluesOnly)
                             .eigenvalues()(0);
  if (min_eig < -kSymmetryTolerance * scale)
    return fmt::format("is not positive semi-definite (smallest eigenvalue {:.3g})", min_eig);
  return {};
}

/// Why the inputs give no risk, or empty.
std::string input_problem(const TrajectoryEstimate& estimate, const VehicleState& vehicle) {
  if (!estimate.converged)
    return "estimate not converged" + (estimate.message.empty() ? std::string() : ": " + estimate.message);
  if (!estimate.covariance) return "estimate has no (p0, v0) covariance";
  const BallisticTrajectory& tr = estimate.trajectory;
  if (!tr.p0_W.allFinite() || !tr.v0_W.allFinite() || !tr.gravity_W.allFinite())
    return "estimate trajectory (p0, v0, g) is not finite";
  if (auto e = covariance_problem(*estimate.covariance); !e.empty()) return "estimate covariance " + e;
  const OdometrySample& o = vehicle.odometry;
  if (!o.p_W_B.allFinite() || !o.v_W.allFinite() || !o.q_W_B.coeffs().allFinite())
    return "vehicle state (p_W_B, v_W, q_W_B) is not finite";
  if (auto e = covariance_problem(vehicle.covariance); !e.empty()) return "vehicle covariance " + e;
  if (o.t < estimate.t_last - kStateLatenessToleranceNs)
    return fmt::format("vehicle state at t = {} ns is {:.1f} ms older than the estimate's newest observation", o.t,
                       to_seconds(estimate.t_last - o.t) * 1e3);
  return {};
}

/// Two unit vectors spanning the plane normal to w (any plane basis if w = 0).
Eigen::Matrix<double, 3, 2> plane_basis(const Eigen::Vector3d& w) {
  const Eigen::Vector3d n = w.norm() > 0 ? Eigen::Vector3d(w.normalized()) : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d e1 = n.unitOrthogonal();
  Eigen::Matrix<double, 3, 2> E;
  E << e1, n.cross(e1);
  return E;
}

}  // namespace

Eigen::Matrix<double, 6, 6> vehicle_state_covariance(const PredictionOptions& options) {
  Eigen::Matrix<double, 6, 1> variances;
  variances << Eigen::Vector3d::Constant(options.odometry_position_sigma_m * options.odometry_position_sigma_m),
      Eigen::Vector3d::Constant(options.odometry_velocity_sigma_m_s * options.odometry_velocity_sigma_m_s);
  return variances.asDiagonal();
}

RiskAssessment assess_collision_risk(const TrajectoryEstimate& estimate, const VehicleState& vehicle,
                                     const PredictionOptions& options) {
  if (auto err = options.validate(); !err.empty()) throw ConfigError("PredictionOptions: " + err);
  RiskAssessment out;
  out.reason = input_problem(estimate, vehicle);
  if (!out.reason.empty()) return out;

  const BallisticTrajectory& tr = estimate.trajectory;
  const OdometrySample& od = vehicle.odometry;
  CollisionRisk risk;
  risk.nominal = predict_collision(tr, od, options);
  const ClosestApproach& ca = risk.nominal.closest;

  // d(s) = a + b s + c s² with s = t - vehicle.t; a, b are linear in x = (p0, v0, p_B, v_B), p0 and
  // v0 given at t0 (eq. 11): a = p0 + τ v0 + ½ g τ² - p_B, b = v0 + g τ - v_B, τ = vehicle.t - t0.
  const double tau = to_seconds(od.t - tr.t0);
  const Eigen::Vector3d a = tr.position(od.t) - od.p_W_B;
  const Eigen::Vector3d b = tr.velocity(od.t) - od.v_W;
  const Eigen::Vector3d c = 0.5 * tr.gravity_W;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 3, 12> da, db;
  da << I, tau * I, -I, Eigen::Matrix3d::Zero();
  db << Eigen::Matrix3d::Zero(), I, Eigen::Matrix3d::Zero(), -I;
  Eigen::Matrix<double, 12, 12> sigma_x = Eigen::Matrix<double, 12, 12>::Zero();
  sigma_x.topLeftCorner<6, 6>() = *estimate.covariance;
  sigma_x.bottomRightCorner<6, 6>() = vehicle.covariance;

  const double s = ca.time_from_now_s;
  const Eigen::Vector3d m = a + s * b + s * s * c;  // d(s*)
  const Eigen::Vector3d w = b + 2 * s * c;           // ḋ(s*)
  const Eigen::Matrix<double, 3, 12> dd = da + s * db;  // ∂d/∂x at fixed s
  // s* solves f(s, x) = d·ḋ = 0 inside (0, H): ∂s*/∂x = -(∂f/∂x) / (∂f/∂s) (implicit function
  // theorem), ∂f/∂s = ḋ·ḋ + d·d̈. At an end of [0, H], s* stays there under small changes.
  Eigen::Matrix<double, 1, 12> ds = Eigen::Matrix<double, 1, 12>::Zero();
  const bool clamped = ca.receding || s >= options.horizon_s;
  const double df_ds = w.squaredNorm() + m.dot(2 * c);
  if (!clamped && df_ds > 0) ds = -(w.transpose() * dd + m.transpose() * db) / df_ds;
  const Eigen::Matrix<double, 3, 12> J = dd + w * ds;
  const Eigen::Matrix3d sigma_m = J * sigma_x * J.transpose();

  risk.closest_offset_covariance_W = sigma_m;
  const Eigen::Matrix3d R_BW = od.q_W_B.conjugate().toRotationMatrix();
  risk.offset_covariance_B = R_BW * sigma_m * R_BW.transpose();
  risk.closest_time_sigma_s = std::sqrt(std::max(0.0, double(ds * sigma_x * ds.transpose())));
  risk.relative_velocity_W = w;

  // The plane normal to the relative velocity at s* (E's columns) and its normal n.
  const Eigen::Matrix<double, 3, 2> E = plane_basis(w);
  const Eigen::Vector3d n = E.col(0).cross(E.col(1));
  const Eigen::Vector2d m_plane = E.transpose() * m;
  const Eigen::Matrix2d sigma_plane = E.transpose() * sigma_m * E;
  if (m.norm() > kZeroMissM) {
    const Eigen::Vector3d u = m.normalized();
    risk.miss_distance_sigma_m = std::sqrt(std::max(0.0, double(u.transpose() * sigma_m * u)));
  } else {
    risk.miss_distance_sigma_m =
        std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(sigma_plane).eigenvalues()(1)));
  }

  const double R = options.safety_radius_m;
  if (a.norm() <= R) {
    risk.probability = 1.0;
  } else if (!clamped) {
    risk.probability = gaussian_disc_probability(m_plane, sigma_plane, R);
  } else {
    // The closest approach is at an end of the horizon: the object crosses the plane normal to ḋ
    // (if at all) after s = H (still approaching) or before s = 0 (receding). Contact needs the
    // crossing of the disc inside [0, H]: with ℓ = n·d the signed distance along ḋ at that end,
    // ℓ >= -sqrt(R² - |p|²) at H, or ℓ <= +sqrt(R² - |p|²) at 0 (the reflection ℓ -> -ℓ).
    Eigen::Matrix3d basis;
    basis << E, ca.receding ? Eigen::Vector3d(-n) : n;
    risk.probability = crossing_probability(basis.transpose() * m, basis.transpose() * sigma_m * basis, R);
  }
  out.risk = risk;
  return out;
}

}  // namespace fdv
