#include "fdv/estimation/collision_risk.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace fdv {

namespace {

constexpr double kSqrt1_2 = 0.70710678118654752440;
constexpr double kInvSqrt2Pi = 0.39894228040143267794;
/// Gaussian tails beyond this many sigmas (< 2e-19 of the mass) are left out of the quadratures.
constexpr double kTailSigmas = 9.0;

double normal_pdf(double z) { return kInvSqrt2Pi * std::exp(-0.5 * z * z); }

/// P(lo <= μ + σ z <= hi), z ~ N(0, 1); σ = 0 is the indicator.
double normal_interval(double mu, double sigma, double lo, double hi) {
  if (!(hi > lo)) return 0.0;
  if (sigma <= 0) return (mu >= lo && mu <= hi) ? 1.0 : 0.0;
  return 0.5 * (std::erf((hi - mu) * kSqrt1_2 / sigma) - std::erf((lo - mu) * kSqrt1_2 / sigma));
}

/// Adaptive Gauss-Kronrod (7-15 points, QUADPACK's QK15 rule) on [a, b] to an absolute tolerance:
/// an interval is bisected while |K15 - G7| exceeds its share of the tolerance. Deterministic.
template <class F>
double integrate(const F& f, double a, double b, double abs_tol, int depth = 0) {
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
  double kronrod = wk[7] * fc, gauss = wg[3] * fc;
  for (int i = 0; i < 7; ++i) {
    const double pair = f(c - h * xk[i]) + f(c + h * xk[i]);
    kronrod += wk[i] * pair;
    if (i % 2 == 1) gauss += wg[i / 2] * pair;
  }
  kronrod *= h;
  gauss *= h;
  if (std::abs(kronrod - gauss) <= abs_tol || depth >= 40) return kronrod;
  return integrate(f, a, c, 0.5 * abs_tol, depth + 1) + integrate(f, c, b, 0.5 * abs_tol, depth + 1);
}

/// ∫ over [a, b] split at the breakpoints inside it (kinks of the integrand).
template <class F>
double integrate_split(const F& f, double a, double b, std::vector<double> breaks, double abs_tol) {
  if (!(b > a)) return 0.0;
  breaks.push_back(a);
  breaks.push_back(b);
  std::sort(breaks.begin(), breaks.end());
  double sum = 0;
  double lo = a;
  for (double x : breaks) {
    if (x <= lo || x > b) continue;
    sum += integrate(f, lo, x, abs_tol * (x - lo) / (b - a));
    lo = x;
  }
  return sum;
}

/// The Gaussian in its eigenbasis: independent axes u (std σu ≤ σv) and v; the mean's coordinates
/// (a, b) on them. A std is exactly 0 along a null direction of the covariance.
struct EigenGaussian2 {
  double a = 0, b = 0, sigma_u = 0, sigma_v = 0;
};

EigenGaussian2 eigen_gaussian(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(0.5 * (covariance + covariance.transpose()));
  const Eigen::Vector2d lambda = es.eigenvalues();  // ascending
  EigenGaussian2 g;
  g.a = es.eigenvectors().col(0).dot(mean);
  g.b = es.eigenvectors().col(1).dot(mean);
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
  auto f = [&](double z) { return normal_pdf(z) * along_v(g.a + g.sigma_u * z); };
  return integrate_split(f, -kTailSigmas, kTailSigmas, {-g.a / g.sigma_u}, tol);
}

}  // namespace fdv
