#include "fdv/estimation/trajectory_estimator.h"

#include <ceres/covariance.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <utility>

#include "fdv/core/error.h"
#include "fdv/core/numeric.h"
#include "fdv/estimation/residuals.h"

namespace fdv {

namespace {

bool finite_pose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

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
  if (!(event_size_noise >= 0 && std::isfinite(event_size_noise))) return "event_size_noise must be >= 0";
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

double detection_sigma_n(const EstimatorOptions& o, double size_px) {
  return std::hypot(o.event_sigma_px, o.event_size_noise * size_px) / o.event_focal_px;
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
  s += fmt::format(", {} event + {} depth obs, {} outliers", event_observations,
              depth_observations, outliers);
  s += fmt::format(", cost {:.4g} -> {:.4g} in {} iterations", initial_cost, final_cost, iterations);
  if (method != EstimateMethod::kNone) {
    const auto& p = trajectory.p0_W;
    const auto& v = trajectory.v0_W;
    s += fmt::format(", p0 ({:.3f} {:.3f} {:.3f})", p.x(), p.y(), p.z());
    s += fmt::format(" v0 ({:.3f} {:.3f} {:.3f})", v.x(), v.y(), v.z());
    s += fmt::format(", pos sigma {:.3g} m ({:.3g} m at the horizon)", position_sigma_m, horizon_sigma_m);
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
  if (!events_.empty() && events_.back().provisional) events_.pop_back();
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

namespace {

// The phases of TrajectoryEstimator::solve, in the order it calls them.

/// An estimate of ne events and nd depths before any fit: nothing usable, sigmas infinite, and a
/// warning when fusion has no depth yet.
TrajectoryEstimate unfitted_estimate(EstimatorMode mode, int ne, int nd) {
  TrajectoryEstimate e;
  e.event_observations = ne;
  e.depth_observations = nd;
  e.position_sigma_m = e.horizon_sigma_m = std::numeric_limits<double>::infinity();
  if (mode == EstimatorMode::kFusion && nd == 0)
    e.message = "no depth observation: event-only fit, range observable only through gravity";
  return e;
}

/// Why a solve cannot start yet: fusion needs min_event_observations events, min_depth_observations
/// depths and min_residuals scalar residuals (2 per event, 1 per depth); event-only needs
/// min_event_observations_event_only events. Nothing when there are enough.
std::optional<std::string> missing_observations(const EstimatorOptions& o, int ne, int nd,
                                                bool use_depth) {
  const bool enough = use_depth ? (ne >= o.min_event_observations &&
                                   nd >= o.min_depth_observations && 2 * ne + nd >= o.min_residuals)
                                : ne >= o.min_event_observations_event_only;
  if (enough) return std::nullopt;
  return use_depth
             ? fmt::format("waiting for observations: {} event + {} depth, need >= {} + {}", ne,
                      nd, o.min_event_observations, o.min_depth_observations) +
                   fmt::format(" and >= {} residuals", o.min_residuals)
             : fmt::format("waiting for observations: {} event, need >= {}", ne,
                      o.min_event_observations_event_only);
}

/// The earliest and the newest observation time: t0 anchors the model p(t) (eq. 11).
std::pair<TimeNs, TimeNs> observed_interval(const std::vector<EventObservation>& events,
                                            const std::vector<DepthMeasurement>& depths) {
  TimeNs t0 = std::numeric_limits<TimeNs>::max(), t1 = std::numeric_limits<TimeNs>::min();
  for (const auto& o : events) t0 = std::min(t0, o.t), t1 = std::max(t1, o.t);
  for (const auto& o : depths) t0 = std::min(t0, o.t), t1 = std::max(t1, o.t);
  return {t0, t1};
}

/// The objective (16) over one parameter block x = (p0_W, v0_W) of the model (11): a whitened
/// event residual block per event observation (eqs. 12-13, Huber at huber_event σ), then a
/// depth residual block per depth observation (eqs. 14-15, Huber at huber_depth σ), in the order
/// held. Residual order = block order. Holds references to the observations and options.
class TrajectoryProblem {
 public:
  TrajectoryProblem(const EstimatorOptions& options, const std::vector<EventObservation>& events,
                    const std::vector<DepthMeasurement>& depths, TimeNs t0, double sigma_n)
      : options_(options),
        events_(events),
        depths_(depths),
        t0_(t0),
        huber_event_(options.huber_event),
        huber_depth_(options.huber_depth),
        problem_(problem_options()) {
    const Eigen::Vector3d& g = options_.gravity_W;
    for (const auto& o : events_)
      problem_.AddResidualBlock(
          EventResidual::create(to_seconds(o.t - t0), o.T_W_E, g, o.xn, event_sigma(o, sigma_n),
                                options_.min_depth_in_front_m),
          &huber_event_, x_);
    for (const auto& o : depths_)
      problem_.AddResidualBlock(
          DepthResidual::create(to_seconds(o.t - t0), o.T_W_C, g, o.depth_m, o.sigma_m),
          &huber_depth_, x_);
  }
  TrajectoryProblem(const TrajectoryProblem&) = delete;
  TrajectoryProblem& operator=(const TrajectoryProblem&) = delete;

  const std::vector<EventObservation>& events() const { return events_; }
  const std::vector<DepthMeasurement>& depths() const { return depths_; }
  TimeNs t0() const { return t0_; }
  ceres::Problem& problem() { return problem_; }
  double* x() { return x_; }

  void set(const BallisticTrajectory& tr) {
    for (int i = 0; i < 3; ++i) x_[i] = tr.p0_W[i], x_[3 + i] = tr.v0_W[i];
  }
  /// The trajectory x stands for.
  BallisticTrajectory trajectory() const {
    return BallisticTrajectory{t0_, Eigen::Vector3d(x_[0], x_[1], x_[2]),
                               Eigen::Vector3d(x_[3], x_[4], x_[5]), options_.gravity_W};
  }
  /// The farthest the object is from the event camera at any event observation [m].
  double largest_range(const BallisticTrajectory& tr) const {
    double z = 0;
    for (const auto& o : events_) z = std::max(z, depth_in_camera(tr, o.T_W_E, o.t));
    return z;
  }
  /// Robust cost of tr, leaving x = tr; nothing when tr is not finite, beyond max_range_m, less
  /// than min_depth_in_front_m in front of a depth camera or behind an event camera.
  std::optional<double> feasible_cost(const BallisticTrajectory& tr) {
    if (!tr.p0_W.allFinite() || !tr.v0_W.allFinite()) return std::nullopt;
    if (!(largest_range(tr) <= options_.max_range_m)) return std::nullopt;
    for (const auto& o : depths_)
      if (!(depth_in_camera(tr, o.T_W_C, o.t) > options_.min_depth_in_front_m)) return std::nullopt;
    set(tr);
    double cost = 0;
    if (!problem_.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr))
      return std::nullopt;
    return cost;  // events behind the camera make Evaluate fail
  }

 private:
  /// The Huber losses are members: the problem must not delete them.
  static ceres::Problem::Options problem_options() {
    ceres::Problem::Options o;
    o.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    return o;
  }

  const EstimatorOptions& options_;
  const std::vector<EventObservation>& events_;
  const std::vector<DepthMeasurement>& depths_;
  TimeNs t0_;
  double x_[6];
  ceres::HuberLoss huber_event_, huber_depth_;
  ceres::Problem problem_;
};

/// Depth assumed along every bearing by the prior-depth start: the median depth observation, else
/// mono_prior_depth_m.
double prior_depth_m(const std::vector<DepthMeasurement>& depths, double mono_prior_depth_m) {
  if (depths.empty()) return mono_prior_depth_m;
  std::vector<double> d;
  for (const auto& o : depths) d.push_back(o.depth_m);
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

constexpr const char* kNoFeasibleStart =
    "initialisation failed: no feasible starting point (object behind a camera, or beyond "
    "max_range_m?)";

struct InitialGuess {
  BallisticTrajectory trajectory;
  const char* name;  ///< TrajectoryEstimate::initialisation
};

/// The fit's start (docs/ESTIMATION.md, "Initialisation"): the lower-cost feasible one of the
/// previous estimate re-anchored at t0 and the linear solution of (12)-(15); if neither is
/// feasible, the prior-depth heuristic. Nothing when no start is feasible. Leaves x anywhere.
std::optional<InitialGuess> initial_guess(TrajectoryProblem& fit,
                                          const std::optional<BallisticTrajectory>& previous,
                                          const EstimatorOptions& o, double sigma_n) {
  std::optional<InitialGuess> start;
  double best = std::numeric_limits<double>::infinity();
  auto consider = [&](const std::optional<BallisticTrajectory>& tr, const char* name) {
    if (!tr) return;
    const auto c = fit.feasible_cost(*tr);
    if (c && *c < best) best = *c, start = InitialGuess{*tr, name};
  };
  const TimeNs t0 = fit.t0();
  if (previous) consider(previous->anchored_at(t0), "previous");
  consider(linear_trajectory_solution(fit.events(), fit.depths(), t0, o.gravity_W, sigma_n),
           "linear");
  if (!start)
    consider(prior_depth_solution(fit.events(), t0, o.gravity_W,
                                  prior_depth_m(fit.depths(), o.mono_prior_depth_m)),
             "prior-depth");
  return start;
}

/// Levenberg-Marquardt with dense QR from x: single-threaded and silent (library code prints
/// nothing), so that results are reproducible.
ceres::Solver::Summary minimise(ceres::Problem& problem, const EstimatorOptions& o) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = o.function_tolerance;
  so.parameter_tolerance = o.parameter_tolerance;
  so.gradient_tolerance = 1e-14;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return summary;
}

/// Why the solver's result is no estimate: the solver failed, the range ran away beyond
/// max_range_m, or the trajectory is not in front of every camera. Nothing when it is one.
std::optional<std::string> rejected_solution(const ceres::Solver::Summary& summary,
                                             TrajectoryProblem& fit, const BallisticTrajectory& tr,
                                             double max_range_m) {
  if (summary.IsSolutionUsable() && fit.feasible_cost(tr)) return std::nullopt;
  if (const double z = fit.largest_range(tr); summary.IsSolutionUsable() && z > max_range_m)
    return fmt::format("diverged: the fit puts the object {:.3g} m away (max_range_m {:.0f} m)", z,
                  max_range_m);
  return "solver failed: " + summary.message;
}

/// Residual blocks whose whitened, unrobustified residual norm exceeds their Huber threshold.
int count_outliers(ceres::Problem& problem, int ne, int nd, const EstimatorOptions& o) {
  ceres::Problem::EvaluateOptions eo;
  eo.apply_loss_function = false;
  std::vector<double> res;
  problem.Evaluate(eo, nullptr, &res, nullptr, nullptr);
  int outliers = 0;
  std::size_t r = 0;  // residual order = block order: 2 per event, then 1 per depth
  for (int k = 0; k < ne; ++k, r += 2)
    if (std::hypot(res[r], res[r + 1]) > o.huber_event) ++outliers;
  for (int i = 0; i < nd; ++i, ++r)
    if (std::abs(res[r]) > o.huber_depth) ++outliers;
  return outliers;
}

/// Smallest and largest eigenvalue of JᵀJ, J the whitened, robustified Jacobian at x.
std::pair<double, double> jtj_eigenvalue_range(ceres::Problem& problem) {
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
  return {eig.eigenvalues()(0), eig.eigenvalues()(5)};
}

/// cov(p0, v0) at x by ceres::Covariance (dense SVD, robustified); nothing when Ceres cannot.
std::optional<Eigen::Matrix<double, 6, 6>> parameter_covariance(TrajectoryProblem& fit) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.num_threads = 1;
  co.apply_loss_function = true;
  ceres::Covariance covariance(co);
  double* x = fit.x();
  const std::vector<std::pair<const double*, const double*>> blocks = {{x, x}};
  Eigen::Matrix<double, 6, 6, Eigen::RowMajor> C;
  if (!covariance.Compute(blocks, &fit.problem()) || !covariance.GetCovarianceBlock(x, x, C.data()))
    return std::nullopt;
  return C;
}

/// sqrt of the largest eigenvalue of the position covariance at t [m].
double largest_position_sigma_m(const TrajectoryEstimate& e, TimeNs t) {
  const Eigen::Matrix3d P = *e.position_covariance(t);
  return std::sqrt(
      std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(P).eigenvalues()(2)));
}

/// The tests of "Covariance, degeneracy, usable" (docs/ESTIMATION.md) on the solution at x: the
/// rank of JᵀJ, then (when computed) the covariance and the position sigma usable_horizon_s past
/// the newest observation. Fills e's covariance and sigmas; appends to e.message why a test
/// failed. Returns whether all passed.
bool well_constrained(TrajectoryProblem& fit, const EstimatorOptions& o, TrajectoryEstimate& e) {
  const auto [lmin, lmax] = jtj_eigenvalue_range(fit.problem());
  if (!(lmax > 0 && lmin > o.min_reciprocal_condition * lmax)) {
    append(e.message,
           fmt::format("degenerate geometry: trajectory not observable (JtJ reciprocal condition {:.2g})",
                  lmax > 0 ? lmin / lmax : 0.0));
    return false;
  }
  if (!o.compute_covariance) return true;
  e.covariance = parameter_covariance(fit);
  if (!e.covariance) {
    append(e.message, "covariance could not be computed");
    return false;
  }
  e.position_sigma_m = largest_position_sigma_m(e, e.t_last);
  e.horizon_sigma_m = largest_position_sigma_m(e, e.t_last + from_seconds(o.usable_horizon_s));
  if (e.horizon_sigma_m <= o.max_position_sigma_m) return true;
  append(e.message, fmt::format("poorly constrained: position sigma {:.2f} m {:.2f} s ahead > {:.2f} m",
                           e.horizon_sigma_m, o.usable_horizon_s, o.max_position_sigma_m));
  return false;
}

}  // namespace

const TrajectoryEstimate& TrajectoryEstimator::solve() {
  const bool use_depth = options_.mode == EstimatorMode::kFusion && !depths_.empty();
  static const std::vector<DepthMeasurement> kNoDepth;
  const std::vector<DepthMeasurement>& depths = use_depth ? depths_ : kNoDepth;
  TrajectoryEstimate e = unfitted_estimate(options_.mode, static_cast<int>(events_.size()),
                                           static_cast<int>(depths.size()));
  if (auto wait =
          missing_observations(options_, e.event_observations, e.depth_observations, use_depth)) {
    append(e.message, *wait);
    return latest_ = e;
  }
  e.method = use_depth ? EstimateMethod::kFusion : EstimateMethod::kEventOnly;
  std::tie(e.t_first, e.t_last) = observed_interval(events_, depths);
  const double sigma_n = options_.event_sigma_px / options_.event_focal_px;
  TrajectoryProblem fit(options_, events_, depths, e.t_first, sigma_n);
  const auto start = initial_guess(fit, previous_, options_, sigma_n);
  if (!start) {
    append(e.message, kNoFeasibleStart);
    return latest_ = e;
  }
  e.initialisation = start->name;
  fit.set(start->trajectory);
  const ceres::Solver::Summary summary = minimise(fit.problem(), options_);
  e.initial_cost = summary.initial_cost;
  e.final_cost = summary.final_cost;
  e.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  e.trajectory = fit.trajectory();
  if (auto why = rejected_solution(summary, fit, e.trajectory, options_.max_range_m)) {
    append(e.message, *why);
    return latest_ = e;
  }
  previous_ = e.trajectory;  // warm start for the next solve
  e.converged = summary.termination_type == ceres::CONVERGENCE;
  if (!e.converged) append(e.message, "not converged: " + summary.message);
  e.outliers = count_outliers(fit.problem(), e.event_observations, e.depth_observations, options_);
  const bool constrained = well_constrained(fit, options_, e);
  e.usable = e.converged && constrained;
  return latest_ = e;
}

}  // namespace fdv
