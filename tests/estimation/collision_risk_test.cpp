#include "fdv/estimation/collision_risk.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "fdv/core/error.h"

namespace fdv {
namespace {

// Centred isotropic Gaussian: |x|²/σ² is χ²₂, so P(|x| <= R) = 1 - exp(-R²/2σ²) (Rayleigh CDF) and
// E|x| = σ sqrt(π/2) (Rayleigh mean); rotating or shifting nothing changes it.
TEST(GaussianDisc, CenterdIsotropicIsRayleigh) {
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

// E|x| from nearly round to a line (the polar quadrature, the nested one below σu/σv = 1e-3, and
// rank 1) against a plain 2D trapezoid over the standardised axes (step 0.01 over ±8 σ).
TEST(GaussianDisc, ExpectedNormFromRoundToALine) {
  const Eigen::Vector2d mean(0.05, 0.3);
  const double sigma_v = 0.4;
  const Eigen::Matrix2d rot = Eigen::Rotation2Dd(0.3).toRotationMatrix();
  for (double ratio : {0.7, 0.05, 2e-3, 0.5e-3, 1e-7, 0.0}) {
    const double sigma_u = ratio * sigma_v;
    const Eigen::Matrix2d cov = rot * Eigen::Vector2d(sigma_u * sigma_u, sigma_v * sigma_v).asDiagonal() * rot.transpose();
    const Eigen::Vector2d m = rot.transpose() * mean;  // in the axes (u, v)
    const double h = 0.01;
    const int n = static_cast<int>(16 / h);
    double expected = 0;
    for (int i = 0; i <= n; ++i) {
      const double z = -8 + i * h;
      double inner = 0;
      for (int j = 0; j <= n; ++j) {
        const double w = -8 + j * h;
        inner += std::exp(-0.5 * w * w) * std::hypot(m.x() + sigma_u * z, m.y() + sigma_v * w);
      }
      expected += std::exp(-0.5 * z * z) * inner * h * h / (2 * M_PI);
    }
    EXPECT_NEAR(gaussian_expected_norm(mean, cov), expected, 1e-8) << "ratio " << ratio;
  }
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

using Matrix6d = Eigen::Matrix<double, 6, 6>;

Matrix6d diagonal6(double sigma_p, double sigma_v) {
  Eigen::Matrix<double, 6, 1> d;
  d << Eigen::Vector3d::Constant(sigma_p * sigma_p), Eigen::Vector3d::Constant(sigma_v * sigma_v);
  return d.asDiagonal();
}

/// A (p0, v0) covariance as the estimator's: p0 and v0 correlated (a short arc trades one for the
/// other), anisotropic (range worse than bearing along x).
Matrix6d estimator_like(double sigma_p, double sigma_v) {
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  A.diagonal() << 1.5 * sigma_p, sigma_p, 0.8 * sigma_p, 1.5 * sigma_v, sigma_v, 0.8 * sigma_v;
  A(3, 0) = -0.6 * sigma_v;  // v0x error with p0x error
  A(4, 1) = 0.3 * sigma_v;
  return A * A.transpose();
}

struct Throw {
  TrajectoryEstimate estimate;
  VehicleState vehicle;
};

/// An object passing the vehicle at `miss_W` (⊥ to the relative velocity then) `s_closest` s after
/// the vehicle's time, with relative velocity `rel_v` at the vehicle's time; the estimate's t0 is
/// 0.15 s before the vehicle's state (the prediction propagates (p0, v0) over that gap).
Throw make_throw(const Eigen::Vector3d& miss_W, double s_closest, const Eigen::Vector3d& rel_v,
                 const Matrix6d& estimate_cov, const Matrix6d& vehicle_cov, const Eigen::Vector3d& vehicle_v = {0, 0, 0},
                 double yaw = 0, const Eigen::Vector3d& g = {0, 0, -9.81}) {
  const TimeNs t_vehicle = 2 * kNsPerS + 150 * kNsPerMs;
  Throw th;
  OdometrySample& o = th.vehicle.odometry;
  o.t = t_vehicle;
  o.p_W_B = {1.0, -2.0, 1.5};
  o.v_W = vehicle_v;
  o.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  th.vehicle.covariance = vehicle_cov;
  const Eigen::Vector3d c = 0.5 * g;
  // d(s) = a + b s + c s² with d(s_c) = miss; the caller makes miss ⊥ ḋ(s_c) = b + 2 c s_c.
  const Eigen::Vector3d a = miss_W - rel_v * s_closest - c * s_closest * s_closest;
  const BallisticTrajectory at_vehicle{t_vehicle, o.p_W_B + a, o.v_W + rel_v, g};
  th.estimate.usable = th.estimate.converged = true;
  th.estimate.trajectory = at_vehicle.anchored_at(2 * kNsPerS);
  th.estimate.covariance = estimate_cov;
  th.estimate.t_first = kNsPerS;
  th.estimate.t_last = t_vehicle;
  return th;
}

/// A miss vector of length r at s_c, normal to the relative velocity then, tilted by `angle`
/// about it from the horizontal.
Eigen::Vector3d miss_normal_to(const Eigen::Vector3d& rel_v, double s_c, double r, double angle,
                               const Eigen::Vector3d& g = {0, 0, -9.81}) {
  const Eigen::Vector3d w = (rel_v + g * s_c).normalized();
  const Eigen::Vector3d side = w.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(w);
  return r * (std::cos(angle) * side + std::sin(angle) * up);
}

struct Sampled {
  double contact_fraction = 0;
  Eigen::Matrix3d miss_covariance = Eigen::Matrix3d::Zero();
  double closest_time_std_s = 0;
};

/// predict_collision on N draws of x = (p0, v0, p_B, v_B) from the block-diagonal covariance.
Sampled sample(const Throw& th, const PredictionOptions& po, int N, std::uint64_t seed) {
  Eigen::Matrix<double, 12, 12> cov = Eigen::Matrix<double, 12, 12>::Zero();
  cov.topLeftCorner<6, 6>() = *th.estimate.covariance;
  cov.bottomRightCorner<6, 6>() = th.vehicle.covariance;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> es(cov);
  const Eigen::Matrix<double, 12, 12> L =
      es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  std::vector<Eigen::Vector3d> miss(N);
  std::vector<double> times(N);
  int contacts = 0;
  for (int i = 0; i < N; ++i) {
    Eigen::Matrix<double, 12, 1> z;
    for (int k = 0; k < 12; ++k) z(k) = n01(rng);
    const Eigen::Matrix<double, 12, 1> dx = L * z;
    BallisticTrajectory tr = th.estimate.trajectory;
    tr.p0_W += dx.segment<3>(0);
    tr.v0_W += dx.segment<3>(3);
    OdometrySample o = th.vehicle.odometry;
    o.p_W_B += dx.segment<3>(6);
    o.v_W += dx.segment<3>(9);
    const CollisionPrediction c = predict_collision(tr, o, po);
    contacts += c.contact.has_value();
    miss[i] = c.closest.object_W - c.closest.vehicle_W;
    times[i] = c.closest.time_from_now_s;
  }
  Sampled out;
  out.contact_fraction = double(contacts) / N;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  double tmean = 0;
  for (int i = 0; i < N; ++i) mean += miss[i] / N, tmean += times[i] / N;
  double tvar = 0;
  for (int i = 0; i < N; ++i) {
    out.miss_covariance += (miss[i] - mean) * (miss[i] - mean).transpose() / (N - 1);
    tvar += (times[i] - tmean) * (times[i] - tmean) / (N - 1);
  }
  out.closest_time_std_s = std::sqrt(tvar);
  return out;
}

CollisionRisk risk_of(const Throw& th, const PredictionOptions& po) {
  const RiskAssessment r = assess_collision_risk(th.estimate, th.vehicle, po);
  EXPECT_TRUE(r.risk.has_value()) << r.reason;
  EXPECT_TRUE(r.reason.empty());
  return r.risk.value_or(CollisionRisk{});
}

// Straight line, no gravity, only p0 uncertain with isotropic σ: the miss vector is p0's error
// projected on the plane normal to the (exact) relative velocity, so its covariance is σ²(I - n nᵀ),
// the probability is the disc formula 1 - exp(-R²/2σ²) at dead centre, |m| has std σ, and the time
// of closest approach moves by the along-track error over the speed: std σ / |b|.
TEST(CollisionRisk, StraightLineIsotropicIsTheDiscFormula) {
  const double sigma = 0.2, speed = 8.0;
  const Eigen::Vector3d rel_v(-speed, 0, 0);
  PredictionOptions po;
  for (double offset : {0.0, 0.3}) {
    const Throw th = make_throw({0, offset, 0}, 0.7, rel_v, diagonal6(sigma, 0), Matrix6d::Zero(), {0, 0, 0}, 0,
                                Eigen::Vector3d::Zero());
    const CollisionRisk r = risk_of(th, po);
    EXPECT_NEAR(r.nominal.closest.time_from_now_s, 0.7, 1e-9);
    EXPECT_NEAR(r.nominal.closest.miss_distance_m, offset, 1e-9);
    const double R = po.safety_radius_m;
    const double expected = offset == 0 ? 1 - std::exp(-R * R / (2 * sigma * sigma))
                                        : gaussian_disc_probability({offset, 0}, sigma * sigma * Eigen::Matrix2d::Identity(), R);
    EXPECT_NEAR(r.probability, expected, 1e-7);
    const Eigen::Vector3d n = rel_v.normalized();
    EXPECT_NEAR((r.closest_offset_covariance_W - sigma * sigma * (Eigen::Matrix3d::Identity() - n * n.transpose()))
                    .norm(), 0, 1e-12);
    EXPECT_NEAR(r.miss_distance_sigma_m, sigma, 1e-12);
    EXPECT_NEAR(r.closest_time_sigma_s, sigma / speed, 1e-12);
    EXPECT_NEAR((r.relative_velocity_W - rel_v).norm(), 0, 1e-9);
  }
}

// Without any covariance the probability is the indicator of the nominal contact, also when the
// closest approach is at an end of the horizon (receding, or still approaching at its end).
TEST(CollisionRisk, ZeroCovarianceIsTheNominalContact) {
  const Eigen::Vector3d rel_v(-9, 0.5, 3);
  PredictionOptions po;
  for (double r : {0.3, 0.49, 0.51, 1.0}) {
    const Throw th = make_throw(miss_normal_to(rel_v, 0.6, r, 0.4), 0.6, rel_v, Matrix6d::Zero(), Matrix6d::Zero());
    const CollisionRisk risk = risk_of(th, po);
    EXPECT_EQ(risk.probability, risk.nominal.contact ? 1.0 : 0.0) << r;
    EXPECT_EQ(risk.probability, r < 0.5 ? 1.0 : 0.0) << r;
  }
  // Still approaching at the horizon's end, 0.3 s short of the sphere.
  po.horizon_s = 0.3;
  const Throw late = make_throw(miss_normal_to(rel_v, 0.6, 0.1, 0), 0.6, rel_v, Matrix6d::Zero(), Matrix6d::Zero());
  const CollisionRisk l = risk_of(late, po);
  EXPECT_TRUE(l.nominal.closest.at_horizon_end);
  EXPECT_FALSE(l.nominal.contact);
  EXPECT_EQ(l.probability, 0.0);
  // Receding: closest 0.2 s in the past.
  po.horizon_s = 2;
  const Throw gone = make_throw(miss_normal_to(rel_v, -0.2, 0.1, 0), -0.2, rel_v, Matrix6d::Zero(), Matrix6d::Zero());
  const CollisionRisk g = risk_of(gone, po);
  EXPECT_TRUE(g.nominal.closest.receding);
  EXPECT_EQ(g.probability, 0.0);
  // Already inside the sphere now: certain.
  const Throw inside = make_throw(miss_normal_to(rel_v, -0.02, 0.1, 0), -0.02, rel_v, estimator_like(0.2, 0.5),
                                  Matrix6d::Zero());
  EXPECT_EQ(risk_of(inside, po).probability, 1.0);
}

// The linear propagation against sampling (20 000 draws each, fixed seed). Tolerances: the contact
// fraction's binomial std is <= 0.0035, and the linearisation (s* moves by ~0.02 s at these
// covariances; the curvature term ½ g δs² is ~2 mm) adds less than that: 0.015. The sample
// covariance of a 3-vector from 20 000 draws has a relative Frobenius error ~ sqrt(2/N) ≈ 1 %: 5 %.
// The figures are quoted in docs/ESTIMATION.md ("Collision risk").
TEST(CollisionRisk, LinearPropagationAgainstSampling) {
  struct Case {
    const char* name;
    Throw th;
    double horizon_s = 2.0;
  };
  const Eigen::Vector3d rel_v(-10, 0.3, 2.5);
  const Matrix6d est = estimator_like(0.08, 0.25);
  const Matrix6d veh = diagonal6(0.05, 0.1);
  std::vector<Case> cases = {
      {"dead centre", make_throw(Eigen::Vector3d::Zero(), 0.6, rel_v, est, veh)},
      {"offset 0.65 m", make_throw(miss_normal_to(rel_v, 0.6, 0.65, 0.5), 0.6, rel_v, est, veh)},
      {"clear miss", make_throw(miss_normal_to(rel_v, 0.6, 1.5, -1.0), 0.6, rel_v, est, veh)},
      {"vehicle moving, yawed", make_throw(miss_normal_to(rel_v, 0.5, 0.45, 2.0), 0.5, rel_v, est, veh, {2, 0.5, 0.2}, 1.0)},
      {"vehicle covariance only", make_throw(miss_normal_to(rel_v, 0.6, 0.4, 1.0), 0.6, rel_v, Matrix6d::Zero(),
                                             diagonal6(0.15, 0.2))},
  };
  int seed = 11;
  for (const Case& c : cases) {
    PredictionOptions po;
    po.horizon_s = c.horizon_s;
    const CollisionRisk r = risk_of(c.th, po);
    const Sampled s = sample(c.th, po, 20000, seed++);
    fmt::print("[ figures  ] {:<24} sampled {:.3f} vs linear {:.3f}; miss cov rel. diff {:.3f}; t* std sampled {:.4f} vs "
               "linear {:.4f} s\n",
                c.name, s.contact_fraction, r.probability,
                (s.miss_covariance - r.closest_offset_covariance_W).norm() / s.miss_covariance.norm(),
                s.closest_time_std_s, r.closest_time_sigma_s);
    EXPECT_NEAR(r.probability, s.contact_fraction, 0.015) << c.name;
    EXPECT_LT((s.miss_covariance - r.closest_offset_covariance_W).norm(), 0.05 * s.miss_covariance.norm()) << c.name;
    EXPECT_NEAR(r.closest_time_sigma_s, s.closest_time_std_s, 0.05 * s.closest_time_std_s) << c.name;
    // The point of passage's covariance is the same in B.
    const Eigen::Matrix3d R_BW = c.th.vehicle.odometry.q_W_B.conjugate().toRotationMatrix();
    EXPECT_NEAR((r.offset_covariance_B - R_BW * s.miss_covariance * R_BW.transpose()).norm(), 0,
                0.05 * s.miss_covariance.norm()) << c.name;
  }
}

// Beyond the linear regime and at the horizon's end, only the probability is compared, within a
// looser 0.05: a large covariance (σ(p0) ~ 0.5 m, σ(v0) ~ 1.5 m/s, the first usable estimates'
// order), and the closest approach at an end of the horizon (still approaching when a short
// horizon ends; receding), where the probability is that of crossing the disc inside the horizon.
TEST(CollisionRisk, ProbabilityAgainstSamplingOutsideTheLinearRegime) {
  const Eigen::Vector3d rel_v(-10, 0.3, 2.5);
  {
    const Throw th = make_throw(miss_normal_to(rel_v, 0.6, 0.5, 0.3), 0.6, rel_v, estimator_like(0.4, 1.2),
                                diagonal6(0.05, 0.1));
    const PredictionOptions po;
    const double p = risk_of(th, po).probability, sampled = sample(th, po, 20000, 5).contact_fraction;
    fmt::print("[ figures  ] large covariance         sampled {:.3f} vs linear {:.3f}\n", sampled, p);
    EXPECT_NEAR(p, sampled, 0.05);
  }
  {
    const Throw th = make_throw(miss_normal_to(rel_v, 0.6, 0.2, 0.3), 0.6, rel_v, estimator_like(0.1, 0.3),
                                diagonal6(0.05, 0.1));
    PredictionOptions po;
    po.horizon_s = 0.56;  // ~ the sphere's entry time (0.6 s - R / |ḋ| ≈ 0.55 s)
    const CollisionRisk r = risk_of(th, po);
    EXPECT_TRUE(r.nominal.closest.at_horizon_end);
    const double sampled = sample(th, po, 20000, 6).contact_fraction;
    fmt::print("[ figures  ] at the horizon's end     sampled {:.3f} vs linear {:.3f}\n", sampled, r.probability);
    EXPECT_NEAR(r.probability, sampled, 0.05);
  }
  {
    // Receding: the closest approach 0.06 s ago, 0.2 m off; now 0.65 m away, just outside the sphere.
    const Throw th = make_throw(miss_normal_to(rel_v, -0.06, 0.2, 0.3), -0.06, rel_v, estimator_like(0.1, 0.3),
                                diagonal6(0.05, 0.1));
    const PredictionOptions po;
    const CollisionRisk r = risk_of(th, po);
    EXPECT_TRUE(r.nominal.closest.receding);
    EXPECT_FALSE(r.nominal.contact);
    const double sampled = sample(th, po, 20000, 8).contact_fraction;
    fmt::print("[ figures  ] receding                 sampled {:.3f} vs linear {:.3f}\n", sampled, r.probability);
    EXPECT_NEAR(r.probability, sampled, 0.05);
  }
}

TEST(CollisionRisk, VehicleStateCovarianceFromOptions) {
  PredictionOptions po;
  po.odometry_position_sigma_m = 0.02;
  po.odometry_velocity_sigma_m_s = 0.3;
  const Matrix6d c = vehicle_state_covariance(po);
  EXPECT_EQ(c, diagonal6(0.02, 0.3));
  po.odometry_velocity_sigma_m_s = -1;
  EXPECT_NE(po.validate(), "");
  const Throw th = make_throw({0, 0.1, 0}, 0.5, {-8, 0, 0}, diagonal6(0.1, 0.1), Matrix6d::Zero());
  EXPECT_THROW(assess_collision_risk(th.estimate, th.vehicle, po), ConfigError);
}

// Each bad input gives no risk and a reason naming the cause.
TEST(CollisionRisk, BadInputGivesAReason) {
  const Throw good = make_throw({0, 0.1, 0}, 0.5, {-8, 0, 0}, estimator_like(0.1, 0.2), diagonal6(0.05, 0.1));
  const PredictionOptions po;
  auto reason = [&](const Throw& th) {
    const RiskAssessment r = assess_collision_risk(th.estimate, th.vehicle, po);
    EXPECT_FALSE(r.risk.has_value());
    return r.reason;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Throw t = good;
  t.estimate.usable = t.estimate.converged = false;
  t.estimate.message = "too few observations";
  EXPECT_EQ(reason(t), "estimate not converged: too few observations");
  // Converged but not usable (too wide at the usable horizon): a risk, the caller decides.
  t = good;
  t.estimate.usable = false;
  EXPECT_TRUE(assess_collision_risk(t.estimate, t.vehicle, po).risk.has_value());
  t = good;
  t.estimate.covariance.reset();
  EXPECT_EQ(reason(t), "estimate has no (p0, v0) covariance");
  t = good;
  t.estimate.trajectory.v0_W.y() = nan;
  EXPECT_EQ(reason(t), "estimate trajectory (p0, v0, g) is not finite");
  t = good;
  (*t.estimate.covariance)(2, 2) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(reason(t), "estimate covariance is not finite");
  t = good;
  (*t.estimate.covariance)(1, 4) += 0.01;
  EXPECT_EQ(reason(t), "estimate covariance is not symmetric");
  t = good;
  t.vehicle.odometry.p_W_B.x() = nan;
  EXPECT_EQ(reason(t), "vehicle state (p_W_B, v_W, q_W_B) is not finite");
  t = good;
  t.vehicle.covariance(4, 4) = nan;
  EXPECT_EQ(reason(t), "vehicle covariance is not finite");
  t = good;
  t.vehicle.covariance(0, 3) = 0.001;
  EXPECT_EQ(reason(t), "vehicle covariance is not symmetric");
  t = good;
  t.vehicle.covariance(1, 1) = -0.01;
  EXPECT_EQ(reason(t), "vehicle covariance is not positive semi-definite (smallest eigenvalue -0.01)");
  // Older than the estimate's newest observation: refused beyond 1 ms, accepted within.
  t = good;
  t.estimate.t_last = t.vehicle.odometry.t + 2 * kNsPerMs;
  EXPECT_EQ(reason(t), "vehicle state at t = 2150000000 ns is 2.0 ms older than the estimate's newest observation");
  t.estimate.t_last = t.vehicle.odometry.t + kNsPerMs / 2;
  EXPECT_TRUE(assess_collision_risk(t.estimate, t.vehicle, po).risk.has_value());
}

}  // namespace
}  // namespace fdv
