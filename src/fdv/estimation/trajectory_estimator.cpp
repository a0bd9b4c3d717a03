#include "fdv/estimation/trajectory_estimator.h"

#include <ceres/covariance.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "fdv/core/error.h"
#include "fdv/estimation/residuals.h"

namespace fdv {

namespace {

bool finite_pose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }
bool positive_finite(double v) { return std::isfinite(v) && v > 0; }

double event_sigma(const EventObservation& o, double default_sigma_n) {
  return o.sigma_n > 0 ? o.sigma_n : default_sigma_n;
}

/// z of the trajectory in camera C at t.
double depth_in_camera(const BallisticTrajectory& tr, const Eigen::Isometry3d& T_W_C, TimeNs t) {
  return T_W_C.linear().col(2).dot(tr.position(t) - T_W_C.translation());
}

/// Least-squares solution of A x = b by column-pivoting QR, or nothing when A's numerical rank
/// is below 6 (|R₆₆| <= tol·|R₁₁|).
std::optional<Eigen::Matrix<double, 6, 1>> solve_full_rank(
    const Eigen::Matrix<double, Eigen::Dynamic, 6>& A, const Eigen::VectorXd& b, double tol) {
  if (A.rows() < 6 || !A.allFinite() || !b.allFinite()) return std::nullopt;
  const Eigen::ColPivHouseholderQR<Eigen::Matrix<double, Eigen::Dynamic, 6>> qr(A);
  const auto& R = qr.matrixR();
  if (!(std::abs(R(5, 5)) > tol * std::abs(R(0, 0)))) return std::nullopt;
  return Eigen::Matrix<double, 6, 1>(qr.solve(b));
}

/// Fallback initialisation: every event observation placed at z_prior along its bearing, then
/// p0, v0 fitted to those points by linear least squares.
std::optional<BallisticTrajectory> prior_depth_solution(const std::vector<EventObservation>& events,
                                                        TimeNs t0, const Eigen::Vector3d& g,
                                                        double z_prior) {
  const int n = static_cast<int>(events.size());
  Eigen::Matrix<double, Eigen::Dynamic, 6> A =
      Eigen::Matrix<double, Eigen::Dynamic, 6>::Zero(3 * n, 6);
  Eigen::VectorXd b(3 * n);
  for (int k = 0; k < n; ++k) {
    const auto& o = events[static_cast<std::size_t>(k)];
    const double tau = to_seconds(o.t - t0);
    const Eigen::Vector3d P = o.T_W_E * (z_prior * Eigen::Vector3d(o.xn.x(), o.xn.y(), 1.0));
    A.block<3, 3>(3 * k, 0).setIdentity();
    A.block<3, 3>(3 * k, 3) = tau * Eigen::Matrix3d::Identity();
    b.segment<3>(3 * k) = P - 0.5 * tau * tau * g;
  }
  const auto x = solve_full_rank(A, b, 1e-9);
  if (!x) return std::nullopt;
  return BallisticTrajectory{t0, x->head<3>(), x->tail<3>(), g};
}

std::string format(const char* f, double a = 0, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

void append(std::string& msg, const std::string& s) {
  if (!msg.empty()) msg += "; ";
  msg += s;
}

}  // namespace

const char* to_string(EstimateMethod m) {
  switch (m) {
    case EstimateMethod::kNone:
      return "none";
    case EstimateMethod::kFusion:
      return "fusion";
    case EstimateMethod::kEventOnly:
      return "event-only";
  }
  return "?";
}

const char* to_string(AddResult r) {
  switch (r) {
    case AddResult::kAccepted:
      return "accepted";
    case AddResult::kTooLate:
      return "too late";
    case AddResult::kInvalid:
      return "invalid";
    case AddResult::kIgnored:
      return "ignored";
  }
  return "?";
}

std::string EstimatorOptions::validate() const {
  if (!gravity_W.allFinite()) return "gravity_W must be finite";
  if (!positive_finite(event_sigma_px)) return "event_sigma_px must be > 0";
  if (!positive_finite(event_focal_px))
    return "event_focal_px must be set (> 0): the event camera's fx";
  if (!positive_finite(huber_event) || !positive_finite(huber_depth))
    return "huber thresholds must be > 0";
  if (min_event_observations < 1 || min_depth_observations < 1 || min_residuals < 6)
    return "need min_event_observations >= 1, min_depth_observations >= 1, min_residuals >= 6";
  if (min_event_observations_event_only < 3)
    return "min_event_observations_event_only must be >= 3";
  if (max_lateness_ns < 0) return "max_lateness_ns must be >= 0";
  if (max_observations < min_residuals) return "max_observations must be >= min_residuals";
  if (!(min_depth_in_front_m > 0)) return "min_depth_in_front_m must be > 0";
  if (!(max_range_m > min_depth_in_front_m) || !std::isfinite(max_range_m))
    return "max_range_m must be finite and > min_depth_in_front_m";
  if (!positive_finite(mono_prior_depth_m)) return "mono_prior_depth_m must be > 0";
  if (!(min_reciprocal_condition >= 1e-14 && min_reciprocal_condition < 1))
    return "min_reciprocal_condition must be in [1e-14, 1) (Ceres' covariance needs >= 1e-14)";
  if (!positive_finite(max_position_sigma_m)) return "max_position_sigma_m must be > 0";
  if (!(usable_horizon_s >= 0) || !std::isfinite(usable_horizon_s))
    return "usable_horizon_s must be >= 0";
  if (max_iterations < 1) return "max_iterations must be >= 1";
  if (!positive_finite(function_tolerance) || !positive_finite(parameter_tolerance))
    return "tolerances must be > 0";
  return {};
}

std::optional<Eigen::Matrix3d> TrajectoryEstimate::position_covariance(TimeNs t) const {
  if (!covariance) return std::nullopt;
  Eigen::Matrix<double, 3, 6> J;
  J << Eigen::Matrix3d::Identity(), to_seconds(t - trajectory.t0) * Eigen::Matrix3d::Identity();
  return J * *covariance * J.transpose();
}

std::optional<double> TrajectoryEstimate::observation_mahalanobis2(TimeNs t, const Eigen::Isometry3d& T_W_E,
                                                                  const Eigen::Vector2d& xn, double sigma_n) const {
  const auto cov_W = position_covariance(t);
  if (!cov_W) return std::nullopt;
  const Eigen::Vector3d p = T_W_E.inverse() * trajectory.position(t);
  if (!(p.z() > 0)) return std::nullopt;
  const double iz = 1.0 / p.z();
  Eigen::Matrix<double, 2, 3> J;
  J << iz, 0, -p.x() * iz * iz, 0, iz, -p.y() * iz * iz;
  const Eigen::Matrix3d R_EW = T_W_E.linear().transpose();
  const Eigen::Matrix2d S =
      J * R_EW * *cov_W * R_EW.transpose() * J.transpose() + sigma_n * sigma_n * Eigen::Matrix2d::Identity();
  const Eigen::Vector2d r = xn - p.head<2>() * iz;
  const double m2 = r.dot(S.ldlt().solve(r));
  if (!std::isfinite(m2)) return std::nullopt;
  return m2;
}

std::string TrajectoryEstimate::brief_report() const {
  std::string s = usable ? "usable" : "NOT usable";
  s += std::string(", ") + to_string(method);
  s += format(", %.0f event + %.0f depth obs, %.0f outliers", event_observations,
              depth_observations, outliers);
  s += format(", cost %.4g -> %.4g in %.0f iterations", initial_cost, final_cost, iterations);
  if (method != EstimateMethod::kNone) {
    const auto& p = trajectory.p0_W;
    const auto& v = trajectory.v0_W;
    s += format(", p0 (%.3f %.3f %.3f)", p.x(), p.y(), p.z());
    s += format(" v0 (%.3f %.3f %.3f)", v.x(), v.y(), v.z());
    s += format(", pos sigma %.3g m (%.3g m at the horizon)", position_sigma_m, horizon_sigma_m);
  }
  if (!initialisation.empty()) s += ", init " + initialisation;
  if (!message.empty()) s += " (" + message + ")";
  return s;
}

std::optional<BallisticTrajectory> linear_trajectory_solution(
    const std::vector<EventObservation>& events, const std::vector<DepthMeasurement>& depths,
    TimeNs t0, const Eigen::Vector3d& g, double default_sigma_n) {
  const int ne = static_cast<int>(events.size()), nd = static_cast<int>(depths.size());
  const int rows = 2 * ne + nd;
  if (rows < 6) return std::nullopt;
  // Time scale for the velocity columns, so both column groups have comparable magnitude.
  TimeNs t_max = t0;
  for (const auto& o : events) t_max = std::max(t_max, o.t);
  for (const auto& o : depths) t_max = std::max(t_max, o.t);
  const double T = std::max(1e-3, to_seconds(t_max - t0));

  std::vector<double> z(static_cast<std::size_t>(ne), 1.0);  // per-event depth weights (pass 2)
  std::optional<BallisticTrajectory> result;
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix<double, Eigen::Dynamic, 6> A(rows, 6);
    Eigen::VectorXd b(rows);
    int r = 0;
    for (int k = 0; k < ne; ++k) {
      const auto& o = events[static_cast<std::size_t>(k)];
      const double tau = to_seconds(o.t - t0);
      const Eigen::Matrix3d R = o.T_W_E.linear().transpose();  // R_C_W
      const Eigen::Vector3d a = 0.5 * tau * tau * g - o.T_W_E.translation();
      // Algebraic bearing residuals ᶜx - x·ᶜz, ᶜy - y·ᶜz: ᶜz times the reprojection error.
      const double w = 1.0 / (event_sigma(o, default_sigma_n) * z[static_cast<std::size_t>(k)]);
      for (int axis = 0; axis < 2; ++axis) {
        const Eigen::RowVector3d m = R.row(axis) - o.xn(axis) * R.row(2);
        A.block<1, 3>(r, 0) = w * m;
        A.block<1, 3>(r, 3) = w * tau / T * m;
        b(r) = -w * m.dot(a);
        ++r;
      }
    }
    for (int i = 0; i < nd; ++i) {
      const auto& o = depths[static_cast<std::size_t>(i)];
      const double tau = to_seconds(o.t - t0);
      const Eigen::RowVector3d m = o.T_W_C.linear().col(2).transpose();
      const Eigen::Vector3d a = 0.5 * tau * tau * g - o.T_W_C.translation();
      const double w = 1.0 / o.sigma_m;
      A.block<1, 3>(r, 0) = w * m;
      A.block<1, 3>(r, 3) = w * tau / T * m;
      b(r) = w * (o.depth_m - m.dot(a));
      ++r;
    }
    const auto x = solve_full_rank(A, b, 1e-10);
    if (!x) return std::nullopt;
    result = BallisticTrajectory{t0, x->head<3>(), x->tail<3>() / T, g};
    for (int k = 0; k < ne; ++k) {
      const auto& o = events[static_cast<std::size_t>(k)];
      z[static_cast<std::size_t>(k)] = std::max(0.1, depth_in_camera(*result, o.T_W_E, o.t));
    }
  }
  return result;
}

TrajectoryEstimator::TrajectoryEstimator(EstimatorOptions options) : options_(std::move(options)) {
  if (auto e = options_.validate(); !e.empty()) throw ConfigError("EstimatorOptions: " + e);
}

bool TrajectoryEstimator::admit(TimeNs t) {
  if (any_ && t < newest_t_ - options_.max_lateness_ns) {
    ++refused_;
    return false;
  }
  newest_t_ = any_ ? std::max(newest_t_, t) : t;
  any_ = true;
  return true;
}

AddResult TrajectoryEstimator::add(const EventObservation& o) {
  if (!o.xn.allFinite() || !finite_pose(o.T_W_E) || !(o.sigma_n >= 0) ||
      !std::isfinite(o.sigma_n)) {
    ++refused_;
    return AddResult::kInvalid;
  }
  if (!admit(o.t)) return AddResult::kTooLate;
  events_.push_back(o);
  drop_oldest_beyond_limit();
  return AddResult::kAccepted;
}

AddResult TrajectoryEstimator::add(const DepthMeasurement& o) {
  if (options_.mode == EstimatorMode::kMonocular) return AddResult::kIgnored;
  if (!positive_finite(o.depth_m) || !positive_finite(o.sigma_m) || !finite_pose(o.T_W_C)) {
    ++refused_;
    return AddResult::kInvalid;
  }
  if (!admit(o.t)) return AddResult::kTooLate;
  depths_.push_back(o);
  drop_oldest_beyond_limit();
  return AddResult::kAccepted;
}

void TrajectoryEstimator::drop_oldest_beyond_limit() {
  while (static_cast<int>(events_.size() + depths_.size()) > options_.max_observations) {
    auto e = std::min_element(events_.begin(), events_.end(),
                              [](auto& a, auto& b) { return a.t < b.t; });
    auto d = std::min_element(depths_.begin(), depths_.end(),
                              [](auto& a, auto& b) { return a.t < b.t; });
    if (d == depths_.end() || (e != events_.end() && e->t <= d->t))
      events_.erase(e);
    else
      depths_.erase(d);
  }
}

const TrajectoryEstimate& TrajectoryEstimator::solve() {
  TrajectoryEstimate e;
  const bool use_depth = options_.mode == EstimatorMode::kFusion && !depths_.empty();
  const int ne = static_cast<int>(events_.size());
  const int nd = use_depth ? static_cast<int>(depths_.size()) : 0;
  e.event_observations = ne;
  e.depth_observations = nd;
  e.position_sigma_m = std::numeric_limits<double>::infinity();
  e.horizon_sigma_m = std::numeric_limits<double>::infinity();
  if (options_.mode == EstimatorMode::kFusion && !use_depth)
    e.message = "no depth observation: event-only fit, range observable only through gravity";

  const bool enough =
      use_depth ? (ne >= options_.min_event_observations && nd >= options_.min_depth_observations &&
                   2 * ne + nd >= options_.min_residuals)
                : ne >= options_.min_event_observations_event_only;
  if (!enough) {
    append(e.message,
           use_depth
               ? format("waiting for observations: %.0f event + %.0f depth, need >= %.0f + %.0f",
                        ne, nd, options_.min_event_observations, options_.min_depth_observations) +
                     format(" and >= %.0f residuals", options_.min_residuals)
               : format("waiting for observations: %.0f event, need >= %.0f", ne,
                        options_.min_event_observations_event_only));
    latest_ = e;
    return latest_;
  }
  e.method = use_depth ? EstimateMethod::kFusion : EstimateMethod::kEventOnly;
  static const std::vector<DepthMeasurement> kNoDepth;
  const std::vector<DepthMeasurement>& depths = use_depth ? depths_ : kNoDepth;
  TimeNs t0 = std::numeric_limits<TimeNs>::max(), t1 = std::numeric_limits<TimeNs>::min();
  for (const auto& o : events_) t0 = std::min(t0, o.t), t1 = std::max(t1, o.t);
  for (const auto& o : depths) t0 = std::min(t0, o.t), t1 = std::max(t1, o.t);
  e.t_first = t0;
  e.t_last = t1;
  const Eigen::Vector3d& g = options_.gravity_W;
  const double sigma_n = options_.event_sigma_px / options_.event_focal_px;

  // The problem: one 6-vector block, whitened residuals, Huber losses owned here.
  double x[6];
  ceres::HuberLoss huber_event(options_.huber_event), huber_depth(options_.huber_depth);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (const auto& o : events_)
    problem.AddResidualBlock(
        EventResidual::create(to_seconds(o.t - t0), o.T_W_E, g, o.xn, event_sigma(o, sigma_n),
                              options_.min_depth_in_front_m),
        &huber_event, x);
  for (const auto& o : depths)
    problem.AddResidualBlock(
        DepthResidual::create(to_seconds(o.t - t0), o.T_W_C, g, o.depth_m, o.sigma_m), &huber_depth,
        x);

  auto set_x = [&x](const BallisticTrajectory& tr) {
    for (int i = 0; i < 3; ++i) x[i] = tr.p0_W[i], x[3 + i] = tr.v0_W[i];
  };
  // The farthest the object is from the event camera at any observation [m].
  auto largest_range = [&](const BallisticTrajectory& tr) {
    double z = 0;
    for (const auto& o : events_) z = std::max(z, depth_in_camera(tr, o.T_W_E, o.t));
    return z;
  };
  auto feasible_cost = [&](const BallisticTrajectory& tr) -> std::optional<double> {
    if (!tr.p0_W.allFinite() || !tr.v0_W.allFinite()) return std::nullopt;
    if (!(largest_range(tr) <= options_.max_range_m)) return std::nullopt;
    for (const auto& o : depths)
      if (!(depth_in_camera(tr, o.T_W_C, o.t) > options_.min_depth_in_front_m)) return std::nullopt;
    set_x(tr);
    double cost = 0;
    if (!problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr))
      return std::nullopt;
    return cost;  // events behind the camera make Evaluate fail
  };

  // Initial point: the lower-cost feasible one of {previous estimate, linear solution}; else the
  // prior-depth heuristic.
  std::optional<BallisticTrajectory> start;
  double best = std::numeric_limits<double>::infinity();
  auto consider = [&](const std::optional<BallisticTrajectory>& tr, const char* name) {
    if (!tr) return;
    const auto c = feasible_cost(*tr);
    if (c && *c < best) best = *c, start = tr, e.initialisation = name;
  };
  if (previous_) consider(previous_->anchored_at(t0), "previous");
  consider(linear_trajectory_solution(events_, depths, t0, g, sigma_n), "linear");
  if (!start) {
    double z_prior = options_.mono_prior_depth_m;
    if (use_depth) {
      std::vector<double> d;
      for (const auto& o : depths) d.push_back(o.depth_m);
      std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
      z_prior = d[d.size() / 2];
    }
    consider(prior_depth_solution(events_, t0, g, z_prior), "prior-depth");
  }
  if (!start) {
    append(e.message,
           "initialisation failed: no feasible starting point (object behind a camera, or beyond "
           "max_range_m?)");
    latest_ = e;
    return latest_;
  }
  set_x(*start);

  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options_.max_iterations;
  so.function_tolerance = options_.function_tolerance;
  so.parameter_tolerance = options_.parameter_tolerance;
  so.gradient_tolerance = 1e-14;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  e.initial_cost = summary.initial_cost;
  e.final_cost = summary.final_cost;
  e.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  e.trajectory = BallisticTrajectory{t0, Eigen::Vector3d(x[0], x[1], x[2]),
                                     Eigen::Vector3d(x[3], x[4], x[5]), g};
  if (!summary.IsSolutionUsable() || !feasible_cost(e.trajectory)) {
    if (const double z = largest_range(e.trajectory); summary.IsSolutionUsable() && z > options_.max_range_m)
      append(e.message, format("diverged: the fit puts the object %.3g m away (max_range_m %.0f m)", z, options_.max_range_m));
    else
      append(e.message, "solver failed: " + summary.message);
    latest_ = e;
    return latest_;
  }
  previous_ = e.trajectory;  // warm start for the next solve
  bool usable = summary.termination_type == ceres::CONVERGENCE;
  e.converged = usable;
  if (!usable) append(e.message, "not converged: " + summary.message);

  // Outliers: whitened residual blocks beyond their Huber threshold (residual order = block order).
  {
    ceres::Problem::EvaluateOptions eo;
    eo.apply_loss_function = false;
    std::vector<double> res;
    problem.Evaluate(eo, nullptr, &res, nullptr, nullptr);
    std::size_t r = 0;
    for (int k = 0; k < ne; ++k, r += 2)
      if (std::hypot(res[r], res[r + 1]) > options_.huber_event) ++e.outliers;
    for (int i = 0; i < nd; ++i, ++r)
      if (std::abs(res[r]) > options_.huber_depth) ++e.outliers;
  }

  // Rank test on the robustified Jacobian, then the covariance of (p0, v0).
  ceres::CRSMatrix crs;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, nullptr, nullptr, &crs);
  Eigen::Matrix<double, 6, 6> JtJ = Eigen::Matrix<double, 6, 6>::Zero();
  for (int row = 0; row < crs.num_rows; ++row) {
    Eigen::Matrix<double, 6, 1> j = Eigen::Matrix<double, 6, 1>::Zero();
    for (int k = crs.rows[static_cast<std::size_t>(row)];
         k < crs.rows[static_cast<std::size_t>(row) + 1]; ++k)
      j(crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
    JtJ += j * j.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(JtJ, Eigen::EigenvaluesOnly);
  const double lmax = eig.eigenvalues()(5), lmin = eig.eigenvalues()(0);
  const bool full_rank = lmax > 0 && lmin > options_.min_reciprocal_condition * lmax;
  if (!full_rank) {
    usable = false;
    append(e.message,
           format("degenerate geometry: trajectory not observable (JtJ reciprocal condition %.2g)",
                  lmax > 0 ? lmin / lmax : 0.0));
  } else if (options_.compute_covariance) {
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::DENSE_SVD;
    co.num_threads = 1;
    co.apply_loss_function = true;
    ceres::Covariance covariance(co);
    const std::vector<std::pair<const double*, const double*>> blocks = {{x, x}};
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> C;
    if (covariance.Compute(blocks, &problem) && covariance.GetCovarianceBlock(x, x, C.data())) {
      e.covariance = C;
      auto largest_sigma_at = [&e](TimeNs t) {
        const Eigen::Matrix3d P = *e.position_covariance(t);
        return std::sqrt(
            std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(P).eigenvalues()(2)));
      };
      e.position_sigma_m = largest_sigma_at(t1);
      e.horizon_sigma_m =
          largest_sigma_at(t1 + from_seconds(options_.usable_horizon_s));
      if (e.horizon_sigma_m > options_.max_position_sigma_m) {
        usable = false;
        append(e.message, format("poorly constrained: position sigma %.2f m %.2f s ahead > %.2f m",
                                 e.horizon_sigma_m, options_.usable_horizon_s,
                                 options_.max_position_sigma_m));
      }
    } else {
      usable = false;
      append(e.message, "covariance could not be computed");
    }
  }
  e.usable = usable;
  latest_ = e;
  return latest_;
}

}  // namespace fdv
