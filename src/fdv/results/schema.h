#pragma once
/// The schema of a `fdv run` results folder: one plain value type per line of each file, with its
/// JSON keys and units. This header owns the format (docs/FORMATS.md "fdv run outputs" points
/// here); writer.h writes it, reader.h reads it back, and nothing else spells its keys.
///
///   RESULTS/detections.jsonl    one WindowRow per event window, in window order
///   RESULTS/depth.jsonl         one DepthRow per (depth frame, live track) segmentation
///   RESULTS/trajectories.jsonl  one TrajectoryRow per estimator solve
///   RESULTS/predictions.jsonl   one PredictionRow per usable fusion estimate with a vehicle state
///   RESULTS/dodge.jsonl         one DodgeRow per dodge decision (trigger, re-plan, commit, cancel, refusal)
///   RESULTS/track_ID_fusion.tum, track_ID_mono.tum   TumPose lines of each track's final usable fit
///   RESULTS/summary.json        RunSummary
///   RESULTS/timing.csv          one WindowTimingRow per event window, in window order
///
/// Times are stream seconds (double) in the files and here; lengths metres; pixels raw sensor
/// pixels unless the key says "undistorted". Enumerations are their to_string() text. Keys are
/// written in alphabetical order (nlohmann::json objects), so equal rows give equal bytes.
/// Optional members are keys written only in some lines. The reader requires the keys evaluation
/// depends on (marked "required") and takes the default for another key a line lacks (results
/// written by an older fdv).
/// Thread safety: value types and pure functions; may be used from any thread.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fdv/eval/statistics.h"
#include "fdv/pipeline/perception.h"

namespace fdv {

inline constexpr const char* kDetectionsFile = "detections.jsonl";
inline constexpr const char* kDepthFile = "depth.jsonl";
inline constexpr const char* kTrajectoriesFile = "trajectories.jsonl";
inline constexpr const char* kPredictionsFile = "predictions.jsonl";
inline constexpr const char* kDodgeFile = "dodge.jsonl";
inline constexpr const char* kSummaryFile = "summary.json";
inline constexpr const char* kTimingFile = "timing.csv";

/// timing.csv's stage columns in order: the stages of summary.json's "timing_ms" that run per event
/// window (depth segmentation and estimation run per frame and per solve: in the summary only).
/// Each registered candidate source is a stage of its name (candidate_source.h), between the
/// detector's own stages and "detection_total".
std::vector<std::string> window_timing_stages();

/// One detection of a window (an element of WindowRow::detections).
struct DetectionRow {
  Box2D box;                                                   ///< "box": [x0, y0, x1, y1] raw px
  Eigen::Vector2d center = Eigen::Vector2d::Zero();            ///< "center": [x, y] raw px (required)
  Box2D box_undistorted;                                       ///< "box_undistorted": compensated grid px
  Eigen::Vector2d center_undistorted = Eigen::Vector2d::Zero();  ///< "center_undistorted" [px]
  double t_s = 0;              ///< "t": mean event time in the box [s] (required)
  int events = 0;              ///< "events": compensated events in the box
  double score = 0;            ///< "score": peak of the pre-processed image in the box
  double event_density = 0;    ///< "event_density": events per box pixel
  bool track_aided = false;    ///< "track_aided"
  std::string source;          ///< "source": DetectionSource text
  int track = -1;              ///< "track": track it was assigned to; -1 none
  bool partial = false;        ///< "partial": cut by the frame's border (box and centre: the visible part)
  double visible_fraction = 1;  ///< "visible_fraction": estimated share of the silhouette in the frame
  /// "center_full": the whole object's centre [raw px], written only for a partial detection whose
  /// uncut side gave the object's size.
  std::optional<Eigen::Vector2d> center_full;
};

/// A line of detections.jsonl: one event window.
struct WindowRow {
  double t_start_s = 0, t_end_s = 0;  ///< "t_start", "t_end" [s] (required)
  std::uint64_t events = 0;           ///< "events": in the window, after the overload decimation
  std::string method;                 ///< "method": compensation used (CompensationMethod text)
  /// "method_requested": written only when the compensation fell back from it.
  std::optional<std::string> method_requested;
  std::string status;                   ///< "status": DetectionStatus text
  std::vector<DetectionRow> detections;  ///< "detections" (required; empty: none)
};

/// A line of depth.jsonl: the segmentation of one track's object in one depth frame.
struct DepthRow {
  double t_s = 0;  ///< "t": depth frame time [s]
  int track = -1;  ///< "track"
  int roi_pixels = 0, valid_pixels = 0;  ///< "roi_pixels", "valid_pixels"
  /// Present when the frame gave an observation ("accepted": true).
  struct Observation {
    double depth_m = 0;          ///< "depth": object centre's z [m]
    double surface_depth_m = 0;  ///< "surface_depth": mean z of the segmented pixels [m]
    double sigma_m = 0;          ///< "sigma" [m]
    int pixels = 0;              ///< "pixels": segmented pixels
    double spread_m = 0;         ///< "spread": std of the segmented depths [m]
    Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< "center": centroid [raw px]
  };
  std::optional<Observation> observation;
  std::string rejection;  ///< "rejection": DepthRejection text (only when not accepted)
  std::string reason;     ///< "reason": every peak tried and why it failed (only when not accepted)
};

/// A line of trajectories.jsonl: one solve of a track's fusion or monocular estimator.
struct TrajectoryRow {
  double t_s = 0;            ///< "t": time of the observation that triggered the solve [s] (required)
  int track = -1;            ///< "track" (required)
  std::string method;        ///< "method": "fusion" or "mono" (required)
  std::string fit;           ///< "fit": EstimateMethod text
  bool usable = false;       ///< "usable" (required)
  bool converged = false;    ///< "converged" (absent in old results: `usable` implied it)
  double t0_s = 0;           ///< "t0": the trajectory's reference time [s] (required)
  Eigen::Vector3d p0_W = Eigen::Vector3d::Zero();  ///< "p0": position at t0, world [m] (required)
  Eigen::Vector3d v0_W = Eigen::Vector3d::Zero();  ///< "v0": velocity at t0 [m/s] (required)
  Eigen::Vector3d gravity_W = Eigen::Vector3d::Zero();  ///< "gravity" [m/s²] (required)
  double t_first_s = 0, t_last_s = 0;  ///< "t_first", "t_last": observed interval [s] (required)
  int event_observations = 0, depth_observations = 0, outliers = 0;  ///< same keys
  double cost = 0;       ///< "cost": final Ceres cost
  int iterations = 0;    ///< "iterations"
  std::string message;   ///< "message"
  /// Present when the fit has a covariance.
  struct Uncertainty {
    Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  ///< "covariance": 36 numbers, row-major, of (p0, v0)
    /// "position_sigma", "horizon_sigma" [m]; JSON has no infinity: written null, read back +inf.
    double position_sigma_m = 0, horizon_sigma_m = 0;
  };
  std::optional<Uncertainty> uncertainty;
  /// The track's looming at t (tracking/looming.h), when it has a fit: "apparent_size_px",
  /// "apparent_size_sigma_px" [raw px]; "tau_s", "tau_sigma_s" [s] (> 0 closing, < 0 receding),
  /// null when the size does not visibly change.
  struct LoomingKeys {
    double size_px = 0, size_sigma_px = 0;
    std::optional<double> tau_s, tau_sigma_s;
  };
  std::optional<LoomingKeys> looming;
  /// "radius_conflict": written (true) only when the known object radius conflicted with this
  /// track's depth and no longer gates it (EstimateResult::radius_conflict).
  bool radius_conflict = false;
};

/// A line of predictions.jsonl: the closest approach predicted from a usable fusion estimate.
struct PredictionRow {
  double t_s = 0;             ///< "t": vehicle state time the prediction starts from [s]
  int track = -1;             ///< "track"
  double closest_t_s = 0;     ///< "closest_t": time of closest approach [s]
  double closest_in_s = 0;    ///< "closest_in_s": closest_t − t [s]
  double miss_distance_m = 0;  ///< "miss_distance": |object − body origin| then [m]
  /// "miss_distance_sigma" [m]: its σ (the planner's linearised one), when the risk was assessed.
  std::optional<double> miss_distance_sigma_m;
  Eigen::Vector3d object_W = Eigen::Vector3d::Zero();   ///< "object_W": object then, world [m]
  Eigen::Vector3d passage_B = Eigen::Vector3d::Zero();  ///< "passage_B": object − vehicle, body [m]
  bool receding = false;                                ///< "receding"
  std::optional<double> time_to_contact_s;  ///< "time_to_contact" [s]: only when it enters the safety sphere
};

/// A line of dodge.jsonl: one decision of the dodge planner (docs/AVOIDANCE.md).
struct DodgeRow {
  double t_s = 0;               ///< "t": the decision's time, the vehicle state's [s] (required)
  double effective_t_s = 0;     ///< "effective_t": t + response delay, when the change takes effect [s]
  int track = -1;               ///< "track"
  std::string action;           ///< "action": DodgeAction text (required)
  double probability = 0;       ///< "probability": of entering the safety sphere within the horizon
  std::optional<double> time_to_contact_s;  ///< "time_to_contact" [s]: only when the mean enters the sphere
  double miss_distance_m = 0;   ///< "miss_distance": the mean's closest approach [m]
  bool committed = false;       ///< "committed"
  std::string reason;           ///< "reason": why, in words
  /// "maneuver": the set-point in force, absent after a cancel or a refusal.
  struct Maneuver {
    Eigen::Vector3d acceleration_W = Eigen::Vector3d::Zero();  ///< "acceleration_W" [m/s²]
    double start_t_s = 0;             ///< "start_t": decision time + response delay [s]
    double duration_s = 0;            ///< "duration" [s]
    double expected_clearance_m = 0;  ///< "expected_clearance" [m]: E|miss| − safety radius
    double probability_after = 0;     ///< "probability_after": of entering the sphere despite it
  };
  std::optional<Maneuver> maneuver;
};

/// A line of track_ID_{fusion,mono}.tum: "t x y z qx qy qz qw" (t as %.9f, position as %.6f;
/// orientation identity, a ball has none), sampled every 5 ms over the observed interval.
struct TumPose {
  double t_s = 0;
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
};

/// A line of timing.csv: one event window's wall-clock time per stage [ms] (steady clock; not
/// deterministic). CSV with the header "window,t_start," then window_timing_stages(); numbers in the
/// shortest form that reads back to the same double. A stage that did not run in the window (a
/// candidate source the detector did not try) is an empty cell.
struct WindowTimingRow {
  std::uint64_t window = 0;  ///< "window": the windower's index (as in window_INDEX.png)
  double t_start_s = 0;      ///< "t_start" [s], as detections.jsonl's line of the window
  std::map<std::string, double> stage_ms;  ///< stage column → ms; absent: did not run
};

/// summary.json. "counts" holds the PerceptionCounters under these keys: events_read (events),
/// events (events_in_windows), windows, windows_skipped_in_gaps (windows_skipped), detections,
/// events_dropped (sum) and events_dropped_by_reason, windows_by_status, windows_by_method,
/// windows_with_fallback_flag, imu, imu_out_of_order, odometry, odometry_out_of_order,
/// depth_frames, depth_frames_rejected (depth_rejected_registration), depth_observations,
/// estimates. The by-reason and by-flag objects are empty before the first window; the by-status
/// and by-method ones name only what occurred.
struct RunSummary {
  std::string input;   ///< "input": the recording as given
  std::string format;  ///< "format": the reader's format name
  int width = 0, height = 0;  ///< "resolution": [width, height] of the event camera
  std::string calibration;    ///< "calibration": where it came from
  std::string method_requested, method;  ///< "method_requested", "method": compensation
  int threads = 1;                       ///< "threads"
  nlohmann::json reader_report = nlohmann::json::object();  ///< "reader_report": ReadReport::to_json()
  PerceptionCounters counts;                                ///< "counts"
  /// "timing_ms": wall-clock time per stage [ms]: count, min, median, p99, max, mean (no rmse).
  std::map<std::string, Summary> timing_ms;
  std::vector<std::string> warnings;  ///< "warnings": every warning of the run, in order
  /// "options": the run's PerceptionOptions as given (config file and flags), one object per
  /// section with the YAML's keys (to_json in fdv/pipeline/options_yaml.h); {} when absent.
  nlohmann::json options = nlohmann::json::object();
  /// "detector_in_use": the detector section as used on this camera (detector_in_use in
  /// fdv/pipeline/options_yaml.h: the event-count gates scaled to its focal length); {} when absent.
  nlohmann::json detector_in_use = nlohmann::json::object();
};

// The JSON form of each row (nlohmann's to_json / from_json, so `nlohmann::json j = row;` and
// `j.get<WindowRow>()` work). from_json throws nlohmann::json::exception for a missing required
// key or a wrong type.
void to_json(nlohmann::json& j, const DetectionRow& r);
void from_json(const nlohmann::json& j, DetectionRow& r);
void to_json(nlohmann::json& j, const WindowRow& r);
void from_json(const nlohmann::json& j, WindowRow& r);
void to_json(nlohmann::json& j, const DepthRow& r);
void from_json(const nlohmann::json& j, DepthRow& r);
void to_json(nlohmann::json& j, const TrajectoryRow& r);
void from_json(const nlohmann::json& j, TrajectoryRow& r);
void to_json(nlohmann::json& j, const PredictionRow& r);
void from_json(const nlohmann::json& j, PredictionRow& r);
void to_json(nlohmann::json& j, const DodgeRow& r);
void from_json(const nlohmann::json& j, DodgeRow& r);
void to_json(nlohmann::json& j, const RunSummary& s);
void from_json(const nlohmann::json& j, RunSummary& s);

/// summary.json's "events_dropped_by_reason" and "windows_with_fallback_flag": counts by the
/// names written (every name once a window was processed; none before).
std::map<std::string, std::uint64_t> dropped_by_reason(const PerceptionCounters& c);
std::map<std::string, std::uint64_t> windows_by_fallback_flag(const PerceptionCounters& c);
/// summary.json's "counts" object (the keys listed at RunSummary); also the ROS node's diagnostics.
nlohmann::json counts_json(const PerceptionCounters& c);

// The rows of Perception's callbacks.
WindowRow window_row(const WindowResult& w);
DepthRow depth_row(const DepthResult& d);
TrajectoryRow trajectory_row(const EstimateResult& e);
PredictionRow prediction_row(const PredictionResult& p);
DodgeRow dodge_row(const DodgeDecision& d);
WindowTimingRow window_timing_row(const WindowResult& w);

}  // namespace fdv
