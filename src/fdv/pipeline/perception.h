#pragma once
/// The streaming perception pipeline: push events, IMU, depth and odometry as they arrive, get
/// detections, tracks, depth observations, 3D trajectory estimates and collision predictions back
/// through callbacks. The CLI (`fdv run`) drives exactly this class.
///
///   Perception perception(calibration, options, {
///       .on_window = [](const WindowResult& w) { ... },        // one per event window
///       .on_estimate = [](const EstimateResult& e) { ... },    // after each new observation
///       .on_prediction = [](const PredictionResult& p) { ... },
///   });
///   perception.push_imu(imu);  perception.push_events(events);  perception.push_depth(frame); ...
///   perception.finish();                                        // flushes the last window
///
/// Data flow per window (paper Fig. 2): motion compensation -> time images, threshold,
/// Gaussian fitting / region retrieval -> Detection2D -> association + Kalman filter. Per depth
/// frame: registration into the event camera (also feeding the translational compensation) ->
/// segmentation in the ROI of each live track -> DepthObservation. Per track: a fusion estimator
/// (events + depth) and the monocular baseline (events only), re-solved on each new observation.
/// In the code, process_window is these stages as named steps, and each feedback edge from the
/// back end into the front end a named call (detector_priors_from_tracks, the detector's inverse
/// warp through detector_input, vouch_by_trajectory, expected_depth_from_estimate).
///
/// Missing sensors: a Perception does what its options say. To fall back as `fdv run` does when the
/// input lacks IMU, depth, odometry or a calibration (compensation method, no 3D, pixel-only
/// calibration, and a warning each), build it from apply_sensor_policy (fdv/pipeline/sensor_policy.h):
///   const SensorPolicy p = apply_sensor_policy(declared_sensors(reader->info()), options);
///   Perception perception(p.calibration, p.options, callbacks);   // and show p.warnings
///
/// Ordering: each stream must be pushed in its own time order; streams may be interleaved in any
/// order within `max_lateness_ns`: a completed window waits until IMU and odometry have reached its
/// end, or until any stream is that much past it; within that bound the results do not depend on
/// the interleaving. Depth is not waited for (a 30 Hz camera would add up to 33 ms of latency):
/// a window is compensated with the newest depth frame not newer than its end among those that
/// have arrived, and a frame is segmented once the windows up to its time are processed, or on
/// arrival if they already are. A depth frame that arrives late is therefore used late.
/// Callbacks run on the caller's thread, inside the push/finish call; references passed to them are
/// valid only during the call. Not thread-safe: one instance per thread.
#include <array>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fdv/avoidance/dodge_planner.h"
#include "fdv/compensation/compensator.h"
#include "fdv/core/calibration.h"
#include "fdv/depth/depth_registration.h"
#include "fdv/depth/depth_segmentation.h"
#include "fdv/detection/detector.h"
#include "fdv/detection/hot_pixels.h"
#include "fdv/estimation/collision.h"
#include "fdv/estimation/collision_risk.h"
#include "fdv/estimation/trajectory_estimator.h"
#include "fdv/io/read_report.h"
#include "fdv/pipeline/event_windower.h"
#include "fdv/tracking/looming.h"
#include "fdv/tracking/tracker.h"

namespace fdv {

/// Which estimate the dodge decisions are made on (PerceptionOptions::dodge_from).
enum class DodgeSource {
  kFusion,               ///< the fusion estimate and its covariance (the paper's system)
  kMonocular,            ///< the monocular baseline's estimate and its covariance
  kFusionPointEstimate,  ///< the fusion estimate, covariance ignored: a hard threshold on the mean
  kNone,                 ///< no dodge decisions
};
const char* to_string(DodgeSource s);
constexpr std::array<DodgeSource, 4> all_values(DodgeSource) {
  return {DodgeSource::kFusion, DodgeSource::kMonocular, DodgeSource::kFusionPointEstimate, DodgeSource::kNone};
}

struct PerceptionOptions {
  EventWindowerOptions windows;
  /// Overlapping windows (windows.step_ns < window_ns): the windows between anchors look only
  /// where the tracks are. Their compensated events outside every track's gate grown by its own
  /// size on each side are dropped before detection, so a window between anchors costs the
  /// compensation and the gates' neighbourhoods, not a search of the image; a window with no gate
  /// is not searched (status "not searched"). New objects are found at the anchors only, a Δt
  /// apart, and the monocular baseline is solved at the anchors only (unless dodge_from is
  /// monocular) (docs/ESTIMATION.md §1, "Overlapping windows").
  bool gates_only_between_anchors = false;
  CompensationOptions compensation;
  DetectorOptions detection;
  DepthRegistrationOptions depth_registration;
  TrackerOptions tracking;
  /// Each track's apparent size and time to contact (tracking/looming.h), on its trajectory rows.
  LoomingOptions looming;
  DepthSegmentationOptions depth_segmentation;
  /// Fusion estimator options; the monocular baseline runs with the same options in kMonocular.
  /// event_focal_px is filled from the calibration when left 0.
  EstimatorOptions estimation;
  /// false: detection, tracking and depth segmentation only, no 3D estimates or predictions (e.g.
  /// a recording without a real calibration, where the camera's rays are unknown).
  bool estimate_trajectories = true;
  bool monocular_baseline = true;  ///< run Su & Shen's events-only estimator beside the fusion
  /// A confirmed track whose fusion estimate is usable keeps a detection its 3D trajectory predicts
  /// (χ²₂ ≤ tracking.gate_chi2 on the normalised-plane residual, the estimate's position
  /// covariance propagated) even when the image-plane filter's gate rejects it, so that the track
  /// and its 3D history go on instead of a new track starting from nothing (Tracker, ExternalGate).
  bool estimate_aided_association = true;
  /// A confirmed track that missed the last window, and whose fusion estimate is usable, also lends
  /// the detector a gate (its box size) where that 3D trajectory, seen from the camera's pose
  /// (odometry), puts the object, searched before the filter's: the image-plane filter knows nothing
  /// of the vehicle's own translation, and in a dodge's manoeuvre its coasting prediction drifts off
  /// the ball (docs/ESTIMATION.md §1, "Tracks held by their 3D estimate").
  bool trajectory_gates = false;
  /// The image-plane tracker works in the camera's coordinates at each window's end: at each
  /// window its tracks are moved by the image motion the gyro-measured rotation since the last
  /// window causes, and each detection by the rotation from its time to the window's end, so that
  /// the filter sees the object's motion, not the camera's turn (a dodge's tilt at several rad/s
  /// moves the image tens of pixels a window). Without IMU samples nothing moves.
  bool derotate_tracking = true;
  /// A tentative track detected in the last window also lends the detector its gate, for the
  /// dense-motion source and the count-contrast source's sparse search only: the windows before
  /// confirmation are where a fast ball is most often missed (docs/DETECTION.md, "Gates of
  /// tentative tracks").
  bool tentative_track_priors = true;
  /// When a track is confirmed, the depth frames segmented since its first detection (while it
  /// was tentative, and so skipped) are segmented for it then, with its filter's prediction at
  /// each frame's time: the first depth observations of a throw are not lost to the confirmation
  /// delay (docs/ESTIMATION.md §2, "The pipeline's query").
  bool depth_since_first_detection = true;
  /// With it, the frames up to this long before the first detection too [ns] (0 = none): the
  /// filter's velocity, known at confirmation, places the object in a frame taken just before it
  /// was first seen.
  TimeNs depth_before_first_detection_ns = 0;
  PredictionOptions prediction;
  /// Dodge decisions (fdv/avoidance, docs/AVOIDANCE.md) on the collision risk of each usable
  /// estimate of the source's kind, at the time the estimate is made.
  DodgeSource dodge_from = DodgeSource::kFusion;
  DodgeOptions dodge;
  /// How long (stream time) a completed window may wait for IMU and odometry to catch up [ns].
  TimeNs max_lateness_ns = 50 * kNsPerMs;
  /// Odometry extrapolation allowed when a pose is needed beyond the newest sample [ns].
  TimeNs odometry_max_extrapolation_ns = 50 * kNsPerMs;
  /// With no odometry at all, 3D estimation assumes the vehicle is static at the world origin
  /// (W = B) only when this is set; otherwise estimation is skipped and a warning is given.
  bool assume_static_vehicle = false;
  /// Threads per window for the compensation's warp and the detector's time images, segmentation
  /// and pre-processing (Perception sets compensation.threads from it). Results are identical for
  /// any count; 1 = the calling thread only; 2 shortens a window's front end by about a third when
  /// a second core is free (docs/BENCHMARKS.md, Threads).
  int threads = 1;
  std::string validate() const;
};

/// The options a Perception runs with when its windows overlap (windows.step_ns < window_ns):
/// each event then lies in N = Δt / Δs windows, and N consecutive detections of an object share
/// their evidence. So that the same events weigh and confirm as much as with consecutive windows:
/// - the tracker's and the looming fit's measurement σ (and their size terms) grow by √N (N correlated measurements
///   carry the information of one), confirm_hits k becomes 1 + (k − 1)·N and the looming fit's
///   counts scale likewise (the same time span of windows);
/// - the hot-pixel memory is N times as many windows;
/// - the estimators (not scaled here) keep one detection per Δt, from the anchor windows (those
///   whose index is a multiple of N, which do not overlap), plus the newest window's as a
///   provisional observation (EventObservation::provisional): a fresh estimate every Δs, each
///   event counted once; the evidence source sums over the anchor windows only
///   (CompensatedEventsView::new_evidence).
/// Unchanged when the windows do not overlap.
PerceptionOptions overlapping_window_options(PerceptionOptions options);

/// Whether `track` lends the detector its gate (a DetectionPrior) in the next window: when
/// confirmed, or, with PerceptionOptions::tentative_track_priors, when tentative and detected in the
/// last window (DetectionPrior::confirmed false: the dense-motion source and the sparse search only).
bool lends_detector_gate(const Track& track, const PerceptionOptions& options);

/// Whether the dodge planner decides on `estimate` (DodgeOptions::max_horizon_sigma_m): usable, or
/// converged with a covariance and not usable only for its position σ at the usable horizon.
bool dodge_decides_on(const TrajectoryEstimate& estimate, const DodgeOptions& dodge);

/// Whether a track other than `held`, detected in the last window, follows the object that
/// `held`'s 3D trajectory puts at `projected_px` (raw pixels, time t): its prediction within the
/// larger of the two tracks' box sizes and `min_reach_px`. Such a `held` is a duplicate and is not
/// held (TrackerOptions::held_max_gap_ns).
bool followed_by_another(const Track& held, const Eigen::Vector2d& projected_px, std::span<const Track> tracks, TimeNs t,
                         double min_reach_px);

/// An object cut by the frame's border (`found.partial`; docs/DETECTION.md, "Objects cut by the
/// border") as its track's event observation: the whole object's centre where the detector
/// estimated one (`center_full_raw`, mapped through `camera`), else the visible part's already in
/// `obs`, with the centre noise `sigma_n` [normalised units] divided by the visible fraction
/// (floored at 0.1), since the centre's error grows with the part out of view.
void observe_cut_object(const Detection2D& found, const PinholeCamera& camera, double sigma_n, EventObservation& obs);

/// The field list (fdv/core/field_list.h): the top-level keys of `fdv run --config` and one
/// section per stage. YAML in and out: fdv/pipeline/options_yaml.h.
template <class V>
void describe(V& v, PerceptionOptions& o) {
  v.ms("window_ms", o.windows.window_ns, "Δt: length of an event window (paper §III-A), at most 1000");
  v.ms("step_ms", o.windows.step_ns,
       "Δs: a window every Δs (0 = Δt), at least Δt / 25; shorter: overlapping windows, a result every Δs (docs/ESTIMATION.md §1, \"Overlapping windows\")");
  v("gates_only_between_anchors", o.gates_only_between_anchors, "-",
    "with step_ms < window_ms, the windows between anchors search only near the tracks' gates (new objects, and the monocular baseline, at the anchors)");
  v("max_events_per_window", o.windows.max_events_per_window, "events",
    "overload guard: a fuller window is decimated uniformly in time order (counted)");
  v("max_empty_windows", o.windows.max_empty_windows, "-",
    "empty windows reported in a row in a gap; the rest of the gap is skipped");
  v("threads", o.threads, "-", "threads per window (compensation and detection; same results for any count)");
  v("estimate_trajectories", o.estimate_trajectories, "-", "false: detection, tracking and depth only, no 3D");
  v("monocular_baseline", o.monocular_baseline, "-", "run Su & Shen's events-only estimator beside the fusion");
  v("estimate_aided_association", o.estimate_aided_association, "-",
    "a usable fusion estimate keeps a detection it predicts that the image gate rejects");
  v("trajectory_gates", o.trajectory_gates, "-",
    "a confirmed track that missed a window also lends the detector a gate where its usable 3D estimate projects");
  v("derotate_tracking", o.derotate_tracking, "-",
    "the tracker's coordinates follow the camera's gyro-measured turn (tracks and detections moved to the window's end)");
  v("tentative_track_priors", o.tentative_track_priors, "-",
    "a tentative track detected in the last window lends its gate to the detector's dense-motion cue and sparse count search");
  v("depth_since_first_detection", o.depth_since_first_detection, "-",
    "on confirmation, segment the depth frames since the track's first detection");
  v.ms("depth_before_first_detection_ms", o.depth_before_first_detection_ns,
       "with depth_since_first_detection, also the frames up to this long before the first detection (0 = none)");
  v.ms("max_lateness_ms", o.max_lateness_ns, "how long a completed window may wait for IMU and odometry");
  v.ms("odometry_max_extrapolation_ms", o.odometry_max_extrapolation_ns,
       "odometry extrapolation allowed beyond the newest sample");
  v("assume_static_vehicle", o.assume_static_vehicle, "-",
    "with no odometry at all, estimate in 3D with the vehicle static at the origin");
  v.section("compensation", o.compensation, "ego-motion compensation (docs/DETECTION.md)");
  v.section("detector", o.detection, "detection (docs/DETECTION.md)");
  v.section("depth_registration", o.depth_registration, "depth registration into the event camera");
  v.section("tracking", o.tracking, "2D association and Kalman filter");
  v.section("looming", o.looming, "apparent size and time to contact of each track (docs/ESTIMATION.md)");
  v.section("depth_segmentation", o.depth_segmentation, "depth segmentation in the track's ROI (docs/ESTIMATION.md)");
  // event_focal_px 0 means "from the calibration" (Perception fills it in): check the rest.
  v.section("estimation", o.estimation, "ballistic trajectory estimation (docs/ESTIMATION.md)",
            [](EstimatorOptions e) {
              if (e.event_focal_px < 0) return std::string("event_focal_px must be >= 0 (0 = the calibration's)");
              if (e.event_focal_px == 0) e.event_focal_px = 1.0;
              return e.validate();
            });
  v.section("prediction", o.prediction, "collision prediction and risk");
  v("dodge_from", o.dodge_from, "-",
    "estimate the dodge decisions use: fusion, monocular, fusion_point_estimate (covariance ignored), none");
  v.section("dodge", o.dodge, "dodge decision: vehicle limits, trigger policy (docs/AVOIDANCE.md)");
}

/// Wall-clock time of each stage of one window [ms] (steady clock).
struct WindowTimings {
  double compensation_ms = 0;
  DetectionTimings detection;
  double tracking_ms = 0;
  double total_ms = 0;  ///< compensation + detection + tracking (+ estimation triggered by it)
};

/// A window's detection and the track it was assigned to (-1: none, e.g. rejected by the tracker).
struct TrackedDetection {
  Detection2D detection;
  int track_id = -1;
};

struct WindowResult {
  std::uint64_t index = 0;
  TimeNs t_start = 0, t_end = 0;
  std::size_t events = 0;        ///< events in the window (after the windower's decimation)
  std::uint64_t decimated = 0;   ///< dropped by the windower's overload policy
  std::uint64_t skipped_before = 0;  ///< empty windows skipped just before (windower's gap policy)
  /// Events of pixels learned hot, dropped before compensation (DetectorOptions::hot_pixels).
  std::uint64_t hot_pixel_events = 0;
  CompensationReport compensation;
  DetectionStatus status = DetectionStatus::kTooFewEvents;
  std::vector<TrackedDetection> detections;  ///< in the detector's order (DetectionResult::detections)
  double theta = 0;
  WindowTimings timings;
  /// The detector, for its intermediate images (visualisation); valid during the callback only.
  const Detector* detector = nullptr;
  /// Where the tracks expected their objects, the detector's gates (raw pixels, in the camera at
  /// the window's start when the events were warped there); valid during the callback only.
  std::span<const DetectionPrior> priors;
};

struct DepthResult {
  TimeNs t = 0;  ///< depth frame time
  int track_id = -1;
  DepthSegmentation segmentation;
  double ms = 0;
};

struct EstimateResult {
  TimeNs t = 0;  ///< time of the observation that triggered the solve
  int track_id = -1;
  EstimatorMode mode = EstimatorMode::kFusion;
  const TrajectoryEstimate* estimate = nullptr;
  double ms = 0;
  /// The track's apparent size and time to contact at t (tracking/looming.h), when it has a fit.
  std::optional<Looming> looming;
  /// The known object radius (depth_segmentation.object_radius_m) conflicts with this track's
  /// depth frames and no longer gates them (Perception::kRadiusConflictFrames).
  bool radius_conflict = false;
};

struct PredictionResult {
  TimeNs t = 0;  ///< vehicle state time the prediction starts from
  int track_id = -1;
  CollisionPrediction prediction;
  /// σ of the miss distance (CollisionRisk::miss_distance_sigma_m, the planner's), when the risk
  /// could be assessed at t (not for a depth frame's estimate holding events newer than the
  /// frame): what dodge-eval checks the true miss against.
  std::optional<double> miss_distance_sigma_m;
};

struct PerceptionCallbacks {
  std::function<void(const WindowResult&)> on_window;
  std::function<void(const DepthResult&)> on_depth;
  std::function<void(const EstimateResult&)> on_estimate;
  std::function<void(const PredictionResult&)> on_prediction;
  /// Each dodge decision (trigger, re-plan, commit, cancel, refusal) of PerceptionOptions::dodge_from.
  std::function<void(const DodgeDecision&)> on_dodge;
  /// Once-per-cause notices (e.g. "no odometry: 3D estimation skipped").
  std::function<void(const std::string&)> on_warning;
};

/// Counts of what the pipeline received, used and refused (`fdv run` writes them into
/// summary.json's "counts"). The per-window counts are taken as each window's result is complete,
/// just before on_window.
struct PerceptionCounters {
  /// Events pushed. Every one lands in a window: once finish() has run, events =
  /// events_in_windows + the windower's decimated ones.
  std::uint64_t events = 0;
  std::uint64_t events_in_windows = 0;  ///< WindowResult::events summed (after the windower's decimation)
  std::uint64_t windows = 0, detections = 0;
  std::uint64_t windows_skipped = 0;  ///< empty windows of long gaps not emitted (EventWindowerOptions)
  /// Events dropped in the windows, by reason (CompensationReport's dropped_*).
  struct DroppedEvents {
    /// The windower's overload policy (WindowResult::decimated) and the compensation's burst cap.
    std::uint64_t overload = 0;
    std::uint64_t outside_window = 0, outside_sensor = 0, no_inverse = 0, left_image = 0;
    std::uint64_t hot_pixel = 0;  ///< WindowResult::hot_pixel_events
    std::uint64_t total() const { return overload + outside_window + outside_sensor + no_inverse + left_image + hot_pixel; }
  } events_dropped;
  /// Windows whose compensation raised each fallback flag (CompensationReport).
  struct FallbackFlags {
    std::uint64_t imu_missing = 0, imu_gap = 0, odometry_missing = 0;
    std::uint64_t depth_missing = 0, depth_stale = 0, depth_wrong_size = 0;
  } windows_flagged;
  std::map<DetectionStatus, std::uint64_t> windows_by_status;    ///< only statuses that occurred
  std::map<CompensationMethod, std::uint64_t> windows_by_method;  ///< compensation used, as above
  std::uint64_t imu = 0, imu_out_of_order = 0;
  std::uint64_t odometry = 0, odometry_out_of_order = 0;
  std::uint64_t depth_frames = 0, depth_rejected_registration = 0, depth_observations = 0;
  std::uint64_t estimates = 0;
  std::uint64_t dodge_decisions = 0;  ///< every on_dodge decision, refusals included
  /// Counts one processed window (Perception does, before on_window).
  void count_window(const WindowResult& w);
};

class Perception {
 public:
  /// Throws ConfigError for invalid options or a calibration that cannot serve them.
  Perception(const Calibration& calibration, PerceptionOptions options, PerceptionCallbacks callbacks);
  ~Perception();

  /// Samples are checked as the readers check them: an event, IMU sample, pose or depth frame
  /// that why_invalid() (fdv/core/sensor_data.h) refuses, or whose time is not valid_time(), is
  /// dropped and counted in input_report() (and warned about once per reason); a dropped sample
  /// changes nothing else. A pose's quaternion within kUnitQuaternionTolerance is normalised.
  void push_events(std::span<const Event> events);
  void push_imu(const ImuSample& sample);
  void push_odometry(const OdometrySample& sample);
  void push_depth(const DepthFrame& frame);
  /// End of input: processes everything still held.
  void finish();

  const PerceptionCounters& counters() const { return counters_; }
  /// The pushed samples dropped as invalid, by reason, with the first one's stream, index among
  /// the samples of that stream pushed so far (from 0) and time, as a reader reports its drops.
  const ReadReport& input_report() const { return input_report_; }
  const Calibration& calibration() const { return calibration_; }
  const Tracker& tracker() const { return tracker_; }

  /// A known object radius whose size gate rejects this many of a track's depth frames in a row
  /// (and none accepted in between) is taken as wrong for that track: said once in a warning, and
  /// its depth frames are segmented as if the radius were unknown from then on.
  static constexpr int kRadiusConflictFrames = 3;

 private:
  struct PendingWindow {
    TimeNs t_start = 0, t_end = 0;
    std::uint64_t index = 0, decimated = 0, skipped_before = 0;
    std::vector<Event> events;
  };
  struct TrackEstimators {
    TrajectoryEstimator fusion;
    std::optional<TrajectoryEstimator> mono;
    LoomingFit looming;
    /// Depth frames rejected in a row by the known radius's size gate; at kRadiusConflictFrames the
    /// radius is taken as wrong for this track (radius_conflict) and no longer gates its depth.
    int size_rejections_in_a_row = 0;
    bool radius_conflict = false;
    // An observation was accepted since the last solve: only then is the estimator solved again
    // (the same observations give the same estimate).
    bool fusion_new = false, mono_new = false;
  };

  void enqueue(const EventWindow& w);
  void advance_stream_time(TimeNs t);
  void process_ready(bool flush);
  bool window_ready(const PendingWindow& w, bool flush) const;
  struct ExpectedDepth {
    double depth_m = 0;  ///< z of the object's centre in E
    double sigma_m = 0;  ///< its std from the trajectory's position covariance (0 without one)
  };

  /// One window through every stage: the steps below, in this order.
  void process_window(PendingWindow& w);
  std::size_t drop_hot_pixels(PendingWindow& w);  ///< the events erased
  /// near_regions: only the events that may land there are needed (CompensationInput).
  const CompensatedWindow& compensate(const PendingWindow& w,
                                      std::optional<std::span<const Eigen::AlignedBox2d>> near_regions = {});
  /// Fills priors_: the tracks at t, seen by the camera at grid_t (the compensated grid's).
  void detector_priors_from_tracks(TimeNs t, TimeNs grid_t);
  DetectionResult detect(const CompensatedWindow& cw, const PendingWindow& w);
  /// t − t_start [s] of the window's events in the sensor, in their order (kept in sensor_t_s_).
  std::span<const float> sensor_event_times(const PendingWindow& w);
  /// gates_only_between_anchors: fills gate_surrounds_ with priors_' gates, each grown by its size
  /// on every side (what the gate sources read around it), on a grid of width x height.
  void surround_gates(int width, int height);
  /// gates_only_between_anchors: `view` reduced to its events in gate_surrounds_ (kept in
  /// gated_pixel_ and gated_t_s_, in their order).
  void keep_events_near_gates(CompensatedEventsView& view, std::span<const float> window_t_s);
  /// Overlapping windows: every N-th window (index a multiple of N = Δt / Δs) is an anchor; the
  /// anchors do not overlap, and the sums over windows see only them (overlapping_window_options).
  bool is_anchor_window(std::uint64_t index) const {
    return index % static_cast<std::uint64_t>(options_.windows.overlap()) == 0;
  }
  TrackerStep associate(TimeNs t, std::span<const Detection2D> detections);
  void vouch_by_trajectory();  ///< fills vouched_ for tracker_inputs_
  void hold_by_trajectory(TimeNs t);  ///< fills held_: the tracks held at window end t
  std::vector<int> add_event_observations(const TrackerStep& step, std::span<const Detection2D> detections,
                                          std::uint64_t window_index);
  void segment_depth_since_first_detection(std::span<const int> confirmed);
  /// Every depth segmentation of the pending frames starts here: the frames up to `up_to`, for
  /// every confirmed track, each accepted observation then solved.
  void segment_pending_depth(TimeNs up_to);
  /// The depth observation of one track in one registered frame (and its on_depth report); true
  /// when the track's fusion estimator accepted it.
  bool segment_depth(const RegisteredDepth& depth, const Track& track);
  void note_radius_conflict(TrackEstimators& e, int track_id, const DepthSegmentation& s);
  std::optional<ExpectedDepth> expected_depth_from_estimate(int track_id, TimeNs t,
                                                            const Eigen::Isometry3d& T_W_E) const;
  /// Every 3D solve starts here (after a window's event observations, after a depth observation):
  /// nothing unless estimate_trajectories.
  void estimate(int track_id, TimeNs t);
  /// The dodge decision on one track's new estimate (dodge_from's kind), made at stream time
  /// max(t, the last processed window's end): when the result exists. `assessed_at_t`: the
  /// estimate's risk against the vehicle at t with its covariance, already computed, used when
  /// the decision is made at t.
  void decide_dodge(int track_id, const TrajectoryEstimate& estimate, TimeNs t,
                    const RiskAssessment* assessed_at_t);
  std::optional<Eigen::Isometry3d> camera_pose(TimeNs t) const;
  std::optional<OdometrySample> vehicle_state(TimeNs t) const;
  /// How the event camera turned from `from` to `to` as the gyro says: d_E(to) = R d_E(from) for
  /// a fixed direction d; nothing without derotate_tracking or IMU samples (no turn is applied).
  std::optional<Eigen::Matrix3d> camera_turn(TimeNs from, TimeNs to) const;
  /// Where a direction seen at raw pixel `px` is seen after the camera's turn `R_E`; `px` itself
  /// without a turn, or when the turn takes it behind the camera.
  Eigen::Vector2d turned_pixel(const Eigen::Vector2d& px, const std::optional<Eigen::Matrix3d>& R_E) const;
  /// A pixel in the tracker's coordinates, seen by the camera at time t.
  Eigen::Vector2d in_camera_at(const Eigen::Vector2d& tracker_px, TimeNs t) const {
    return tracker_frame_t_ ? turned_pixel(tracker_px, camera_turn(*tracker_frame_t_, t)) : tracker_px;
  }
  TrackEstimators& estimators_for(int track_id);
  /// χ²₂ of detection `d` against the trajectory of `est` at d's time (normalised image plane,
  /// covariance of the predicted position ⊕ the event noise); nothing when `est` is not a usable
  /// fusion estimate, the pose is unknown or the prediction is behind the camera.
  std::optional<double> trajectory_mahalanobis2(const TrajectoryEstimate& est, const TrackerDetection& d) const;
  /// The raw pixel at which the track's usable fusion estimate puts the object at time t, seen by
  /// the camera at time camera_t; nothing without such an estimate, a pose, or with the object
  /// behind the camera or outside the image.
  std::optional<Eigen::Vector2d> trajectory_pixel(int track_id, TimeNs t, TimeNs camera_t) const;
  void warn_once(const std::string& key, const std::string& message);
  /// Counts `n` pushed samples dropped as invalid (input_report_), the first the stream's
  /// `index`-th push, at time t.
  void drop_input(const char* stream, const char* why, std::uint64_t index, TimeNs t, std::uint64_t n = 1);

  Calibration calibration_;
  PerceptionOptions options_;
  PerceptionCallbacks callbacks_;
  EventWindower windower_;
  std::unique_ptr<Compensator> compensator_;
  Detector detector_;
  std::optional<HotPixelFilter> hot_pixels_;  ///< none when detection.hot_pixels is off
  std::optional<DepthRegistrar> registrar_;
  Tracker tracker_;
  /// The time whose camera coordinates the tracker's tracks are in (derotate_tracking).
  std::optional<TimeNs> tracker_frame_t_;
  std::vector<ImuSample> imu_;            ///< recent history; contiguous: the compensator takes a span
  std::vector<OdometrySample> odometry_;  ///< recent history, time-sorted
  std::deque<RegisteredDepth> recent_depth_;     ///< for the translational compensation
  std::deque<RegisteredDepth> pending_depth_;    ///< awaiting segmentation
  std::deque<PendingWindow> pending_windows_;
  std::vector<std::vector<Event>> free_buffers_;
  std::vector<DetectionPrior> priors_;  ///< per window, reused
  std::vector<cv::Rect> gate_surrounds_;  ///< per window, reused (gates_only_between_anchors)
  std::vector<Eigen::AlignedBox2d> gate_regions_;  ///< gate_surrounds_ for the compensation, reused
  std::vector<std::int32_t> gated_pixel_;  ///< per window, reused (gates_only_between_anchors)
  std::vector<float> gated_t_s_;
  std::vector<float> sensor_t_s_;  ///< per window, reused (sensor_event_times)
  std::vector<TrackerDetection> tracker_inputs_;  ///< per window, reused: the tracker's input
  std::vector<int> held_;                ///< per window, reused (tracking.held_max_gap_ns)
  std::vector<ExternalGate> vouched_;   ///< per window, reused (estimate_aided_association)
  std::map<int, TrackEstimators> estimators_;
  std::optional<DodgePlanner> planner_;  ///< none when dodge_from is none
  std::map<int, std::string> refused_;   ///< per track, the last refusal reason reported
  TimeNs stream_time_ = std::numeric_limits<TimeNs>::min();
  TimeNs processed_until_ = std::numeric_limits<TimeNs>::min();  ///< t_end of the last window done
  std::vector<std::string> warned_;
  PerceptionCounters counters_;
  ReadReport input_report_;
  std::uint64_t events_pushed_ = 0, imu_pushed_ = 0, odometry_pushed_ = 0, depth_pushed_ = 0;
  std::vector<Event> valid_events_;  ///< push_events' copy when some events are dropped
};

}  // namespace fdv
