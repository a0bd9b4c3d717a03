#pragma once
/// 3D trajectory of one tracked object from its event detections and depth observations
/// (paper §IV-C.3, eqs. 11-16), and the monocular baseline (Su & Shen: events only).
///
///   EstimatorOptions o;  o.event_focal_px = calib.event_camera.fx;
///   TrajectoryEstimator est(o);                             // one per track
///   est.add(EventObservation{t, xn, *camera_pose_at(odom, t, calib.T_B_E)});
///   est.add(DepthMeasurement{t_d, obs.depth_m, obs.sigma_m,
///                            *camera_pose_at(odom, t_d, calib.T_B_E)});
///   const TrajectoryEstimate& e = est.solve();              // after each new observation
///   if (e.usable) predict(e.trajectory);
///
/// Model: p(t) = p0 + v0 (t - t0) + ½ g (t - t0)² in W, t0 = the earliest observation held.
/// Unknowns (p0, v0) minimise Σ ρ_E(|r_E/σ_n|²) + Σ ρ_D((r_D/σ_d)²) with Huber ρ (eq. 16, each
/// residual whitened by its own noise). Each solve starts from the better (lower robust cost) of
/// the previous estimate and a fresh linear least-squares solution (docs/ESTIMATION.md); Ceres
/// Levenberg-Marquardt refines. Observations may arrive in any order within max_lateness_ns of the
/// newest one. Each observation carries the pose of its camera at its own time.
///
/// Pitfalls: event observations are the detections' measured centres in undistorted normalised
/// coordinates (not the Kalman-filtered positions, whose errors are correlated); the depth is the
/// object centre's z in the frame whose pose is given (E for registered depth images).
/// Not thread-safe; one estimator per track.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "fdv/core/time.h"
#include "fdv/estimation/ballistic.h"

namespace fdv {

/// One detection of the object by the event camera.
struct EventObservation {
  TimeNs t = 0;
  Eigen::Vector2d xn =
      Eigen::Vector2d::Zero();  ///< undistorted normalised (x/z, y/z) of the centre
  Eigen::Isometry3d T_W_E = Eigen::Isometry3d::Identity();  ///< event camera pose at t
  double sigma_n =
      0;  ///< noise std [normalised units]; 0 = options' event_sigma_px / event_focal_px
  /// Held only until the next event observation, which replaces it: the pipeline's detection from
  /// a window that shares its events with the next one kept (overlapping windows), so that the
  /// estimate is fresh without counting the same events twice.
  bool provisional = false;
};

/// One depth of the object's centre, z along the optical axis of camera C at time t.
struct DepthMeasurement {
  TimeNs t = 0;
  double depth_m = 0;
  double sigma_m =
      0;  ///< noise std [m] (DepthObservation::sigma_m: σ(z) = z² s / (f B) ⊕ radius term)
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();  ///< pose at t of the depth's frame
};

enum class EstimatorMode {
  kFusion,     ///< events and depth (paper); event-only while no depth has been accepted
  kMonocular,  ///< the Su & Shen baseline: events only, depth ignored
};

/// What the estimate was fitted to.
enum class EstimateMethod { kNone, kFusion, kEventOnly };
const char* to_string(EstimateMethod m);

struct EstimatorOptions {
  EstimatorMode mode = EstimatorMode::kFusion;
  /// Gravity in W [m/s²] (paper: known to the drone). W's z axis up.
  Eigen::Vector3d gravity_W = Eigen::Vector3d(0, 0, -9.81);
  /// Detection centre noise [px] and the event camera's focal length [px] (required):
  /// σ_n = event_sigma_px / event_focal_px. 3 px = the measured RMS per axis of the detector's
  /// centre error on training seeds (docs/ESTIMATION.md, section 3).
  double event_sigma_px = 3.0;
  double event_focal_px = 0.0;
  /// A whole detection's centre noise grows with its size D (its box's larger side [px]): the
  /// pipeline sets an observation's σ_n = √(event_sigma_px² + (event_size_noise·D)²) / event_focal_px,
  /// and the same σ in the gate its trajectory lends the tracker (0 = the fixed σ).
  double event_size_noise = 0.0;
  /// Huber thresholds in sigmas of the whitened residual norm: sqrt of the χ² 95 % quantile for
  /// the block's dimension (2-dof event: 2.45; 1-dof depth: 1.96), so ~95 % of inlier residuals
  /// stay in the quadratic zone.
  double huber_event = 2.45;
  double huber_depth = 1.96;
  /// Minimum observations before a fusion estimate: at least 2 event and 1 depth, and at least
  /// min_residuals scalar residuals (6 unknowns + 1 redundancy: 3 events + 1 depth, or 2 + 3).
  int min_event_observations = 2;
  int min_depth_observations = 1;
  int min_residuals = 7;
  /// Minimum event observations for an event-only estimate (monocular, or fusion without depth).
  int min_event_observations_event_only = 4;
  /// Observations older than the newest one by more than this are refused [ns].
  TimeNs max_lateness_ns = 100 * kNsPerMs;
  /// Most observations held; beyond, the oldest is dropped (a ballistic flight lasts < 1 s).
  int max_observations = 200;
  /// Least depth in front of every camera for a valid trajectory [m].
  double min_depth_in_front_m = 0.05;
  /// Most depth in front of the event camera at any event observation for a valid trajectory [m]:
  /// a thrown ball farther than this is a few pixels at most, so a fit out there is the
  /// monocular range running away (it is weakly observable, through gravity only), not a ball.
  double max_range_m = 50.0;
  /// Monocular initialisation fallback: depth assumed along the bearings [m] (docs/ESTIMATION.md).
  double mono_prior_depth_m = 5.0;
  /// Rank test on the whitened, robustified Jacobian: λ_min/λ_max of JᵀJ below this = degenerate
  /// (no covariance). Above Ceres' own 1e-14, so ceres::Covariance never fails afterwards.
  double min_reciprocal_condition = 1e-12;
  /// usable requires the largest position std, propagated from the newest observation to
  /// usable_horizon_s beyond it, below this [m]. The horizon matters: a short arc pins the
  /// position at its end but not the velocity, and a dodge acts on the position ~0.5 s ahead.
  double max_position_sigma_m = 1.0;
  double usable_horizon_s = 0.5;
  bool compute_covariance = true;
  /// Ceres Levenberg-Marquardt limits.
  int max_iterations = 50;
  double function_tolerance = 1e-10;
  double parameter_tolerance = 1e-10;

  std::string validate() const;
};

/// σ_n [normalised units] of a whole detection whose box's larger side is `size_px`:
/// √(event_sigma_px² + (event_size_noise · size_px)²) / event_focal_px.
double detection_sigma_n(const EstimatorOptions& o, double size_px);

/// The field list (fdv/core/field_list.h): YAML section `estimation`. `mode` is not a key: the
/// pipeline runs fusion, and the monocular baseline beside it (PerceptionOptions).
template <class V>
void describe(V& v, EstimatorOptions& o) {
  v.removed("mode", "not configurable: the pipeline runs fusion, and the monocular baseline beside it when "
                    "monocular_baseline is true");
  v("gravity", o.gravity_W, "m/s²", "gravity in W, [x, y, z] (W's z axis up)");
  v("event_sigma_px", o.event_sigma_px, "px", "detection centre noise (σ_n = event_sigma_px / event_focal_px)");
  v("event_focal_px", o.event_focal_px, "px", "the event camera's focal length; 0 = from the calibration");
  v("event_size_noise", o.event_size_noise, "-",
    "a whole detection's centre noise grows by this × its size (in quadrature); 0 = fixed");
  v("huber_event", o.huber_event, "σ", "Huber threshold of an event residual (whitened norm)");
  v("huber_depth", o.huber_depth, "σ", "Huber threshold of a depth residual");
  v("min_event_observations", o.min_event_observations, "-", "fusion needs at least this many event observations");
  v("min_depth_observations", o.min_depth_observations, "-", "... and this many depth observations");
  v("min_residuals", o.min_residuals, "-", "... and this many scalar residuals");
  v("min_event_observations_event_only", o.min_event_observations_event_only, "-",
    "event observations for an event-only estimate");
  v.ms("max_lateness_ms", o.max_lateness_ns, "observations older than the newest by more are refused");
  v("max_observations", o.max_observations, "-", "most observations held (the oldest dropped beyond)");
  v("min_depth_in_front_m", o.min_depth_in_front_m, "m", "least depth in front of every camera");
  v("max_range_m", o.max_range_m, "m", "most depth in front of the event camera at any observation");
  v("mono_prior_depth_m", o.mono_prior_depth_m, "m", "monocular initialisation: depth assumed along the bearings");
  v("min_reciprocal_condition", o.min_reciprocal_condition, "-", "λ_min/λ_max of JᵀJ below this = degenerate");
  v("max_position_sigma_m", o.max_position_sigma_m, "m", "usable: largest position std at the horizon below this");
  v("usable_horizon_s", o.usable_horizon_s, "s", "... propagated this far beyond the newest observation");
  v("compute_covariance", o.compute_covariance, "-", "compute the (p0, v0) covariance");
  v("max_iterations", o.max_iterations, "-", "Ceres Levenberg-Marquardt iterations");
  v("function_tolerance", o.function_tolerance, "-", "Ceres function tolerance");
  v("parameter_tolerance", o.parameter_tolerance, "-", "Ceres parameter tolerance");
}

/// Result of one solve, in the spirit of ceres::Solver::Summary.
struct TrajectoryEstimate {
  bool usable = false;  ///< converged, well constrained, in front of the cameras
  /// Ceres converged to a trajectory in front of the cameras (usable may still be false: rank
  /// or covariance tests). The in-sample fit the paper's Table II scores.
  bool converged = false;
  EstimateMethod method = EstimateMethod::kNone;
  BallisticTrajectory trajectory;
  /// Covariance of (p0_W, v0_W) at trajectory.t0 [m², m²/s²], when the problem has full rank.
  std::optional<Eigen::Matrix<double, 6, 6>> covariance;
  double position_sigma_m = 0;  ///< sqrt of the largest eigenvalue of cov(p(t_last)); inf if none
  /// The same at t_last + usable_horizon_s (the usable test); inf if none.
  double horizon_sigma_m = 0;
  int event_observations = 0;   ///< used in this solve
  int depth_observations = 0;
  int outliers = 0;                ///< residual blocks beyond their Huber threshold at the solution
  TimeNs t_first = 0, t_last = 0;  ///< observed interval
  double initial_cost = 0, final_cost = 0;  ///< Ceres cost ½Σρ of the whitened residuals
  int iterations = 0;
  std::string initialisation;  ///< "linear", "previous", "prior-depth"
  std::string message;         ///< why not usable, or warnings (e.g. no depth)

  /// Covariance of the position at t (propagated from the (p0, v0) covariance), if any.
  std::optional<Eigen::Matrix3d> position_covariance(TimeNs t) const;
  /// χ²₂ statistic of an event observation (normalised centre `xn` seen at time t by the camera
  /// at pose T_W_E) against this trajectory: r = xn − π(T_W_E⁻¹ p(t)) as eq. 13, covariance
  /// J Σ_E Jᵀ + σ_n² I with Σ_E the position covariance in the camera and J = ∂π/∂p_E. Nothing
  /// without a covariance or when p(t) is not in front of the camera.
  std::optional<double> observation_mahalanobis2(TimeNs t, const Eigen::Isometry3d& T_W_E, const Eigen::Vector2d& xn,
                                                 double sigma_n) const;
  /// One line: usable, method, counts, cost, iterations, p0, v0, sigma, message.
  std::string brief_report() const;
};

enum class AddResult { kAccepted, kTooLate, kInvalid, kIgnored };
const char* to_string(AddResult r);

class TrajectoryEstimator {
 public:
  /// Throws ConfigError when the options are invalid.
  explicit TrajectoryEstimator(EstimatorOptions options);

  /// Stores an observation (no solve). kTooLate: older than the newest by > max_lateness_ns;
  /// kInvalid: non-finite values, sigma <= 0, depth <= 0; kIgnored: depth in monocular mode.
  AddResult add(const EventObservation& obs);
  AddResult add(const DepthMeasurement& obs);

  /// Re-solves over all held observations; returns (and keeps) the estimate. When there are too
  /// few observations the estimate is not usable and its message says what is missing.
  const TrajectoryEstimate& solve();
  const TrajectoryEstimate& latest() const { return latest_; }

  int event_count() const { return static_cast<int>(events_.size()); }
  int depth_count() const { return static_cast<int>(depths_.size()); }
  int refused_count() const { return refused_; }
  const EstimatorOptions& options() const { return options_; }

 private:
  /// Lateness check shared by both observation kinds; updates the newest time when admitted.
  bool admit(TimeNs t);
  void drop_oldest_beyond_limit();
  EstimatorOptions options_;
  std::vector<EventObservation> events_;
  std::vector<DepthMeasurement> depths_;
  TimeNs newest_t_ = 0;
  bool any_ = false;
  int refused_ = 0;
  std::optional<BallisticTrajectory> previous_;
  TrajectoryEstimate latest_;
};

/// Linear least-squares solution of the bearing and depth equations (docs/ESTIMATION.md): the
/// constraints (r1 - x r3)·ᶜp = 0, (r2 - y r3)·ᶜp = 0, r3·ᶜp = d are linear in (p0, v0). Weighted
/// by 1/σ and, in a second pass, by the first pass's 1/ᶜz. Nothing when rank-deficient. Exposed
/// for tests and for callers that want an initial guess.
std::optional<BallisticTrajectory> linear_trajectory_solution(
    const std::vector<EventObservation>& events, const std::vector<DepthMeasurement>& depths,
    TimeNs t0, const Eigen::Vector3d& gravity_W, double default_sigma_n);

}  // namespace fdv
