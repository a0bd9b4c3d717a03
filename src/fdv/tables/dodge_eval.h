#pragma once
/// `fdv dodge-eval`: one random throw per seed (sim/random_throw.h) simulated, run through the
/// pipeline, decided, and scored kinematically against the simulator's truth, for our system and
/// four baselines on the same throws (docs/AVOIDANCE.md, "Evaluation").
///
///   DodgeEvalOptions o;  o.seeds = parse_seed_list("101-300");  o.out_dir = "out/dodge";
///   const DodgeEval e = run_dodge_eval(o);             // writes out/dodge/dodge_eval.json
///   e.totals.at("ours").escaped;
///
/// Outcome: after each decision the vehicle follows its scripted (true) path plus the commanded
/// set-points, each taking effect after the response delay (avoidance/maneuver_playback.h); the
/// true ball's distance to the body origin is checked every millisecond of the truth, and for
/// 0.3 s past its end (the ball ballistic, the body at its last velocity: random_throw ends a
/// scene when the ball reaches the camera). A throw is
/// a threat when its true miss distance without a manoeuvre is below the safety radius, a
/// non-threat above 1 m, a near miss in between.
///
/// With `closed_loop` (tables/closed_loop.h), every method is also flown through the loop: the
/// scene rendered again as the vehicle model flies the method's decisions, the method deciding on
/// what it sees. `outcomes` then hold the closed-loop figures, `open_loop_outcomes` the kinematic
/// replay's above, and `dynamics_outcomes` the open-loop decisions flown by the vehicle model
/// without rendering again (what the dynamics alone change). One simulation per throw renders the
/// open loop's dataset and, forked at each perception method's first set-point, its flights.
/// Thread safety: run_dodge_eval may be called from any thread; it runs `jobs` throws at once,
/// each on its own thread with its own state.
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fdv/avoidance/dodge_planner.h"
#include "fdv/eval/dataset_truth.h"
#include "fdv/pipeline/perception.h"
#include "fdv/sim/vehicle_dynamics.h"

namespace fdv {

/// The methods compared, in the order reported: ours, then the baselines. The two oracles plan on
/// the true trajectory and vehicle state; `oracle` from our first detection of the ball,
/// `oracle_visible` from the first window in which the ball is plainly in view
/// (first_window_in_view), a bound that does not move with our detector.
inline const std::vector<std::string> kDodgeMethods = {"ours",   "point_estimate", "mono",
                                                       "rotation", "oracle",       "oracle_visible"};
/// The baselines that run a pipeline, each changing one thing of ours (DodgeEvalOptions).
inline const std::vector<std::string> kPerceptionBaselines = {"point_estimate", "mono", "rotation"};

/// `oracle_visible` starts at the end of the first window in which the ball, in flight, looks at
/// least this large (its true apparent diameter, raw pixels) ...
inline constexpr double kInViewMinDiameterPx = 3.0;
/// ... with at least this share of its disc in the image.
inline constexpr double kInViewMinFraction = 0.5;

/// A throw between these true miss distances (no manoeuvre) is a near miss [m]: neither threat nor
/// non-threat, reported apart.
inline constexpr double kNonThreatMissM = 1.0;

struct DodgeEvalOptions {
  std::vector<std::uint64_t> seeds;
  std::string out_dir;
  int jobs = 2;       ///< throws evaluated at once (each single-threaded)
  bool keep = false;  ///< keep DIR/throws/SEED/{dataset,run}
  bool closed_loop = false;  ///< also fly every method through the closed loop (above)
  /// The perception baselines evaluated beside ours (of kPerceptionBaselines; any order). Each
  /// runs its own pipeline and, closed loop, flies its own fork of the simulation, so leaving them
  /// out makes the evaluation of ours faster. The oracles always run: they need no rendering.
  std::vector<std::string> baselines = kPerceptionBaselines;
  /// Ours; the baselines change one thing each: dodge_from (point_estimate, mono), the
  /// compensation method (rotation), or the estimate itself (oracle: the true trajectory).
  PerceptionOptions perception;
};

/// Whether ours' predicted miss distance and its σ (PredictionResult) describe the true miss: a
/// calibrated σ holds it within 1σ in about 68 % of usable estimates and within 2σ in about 95 %
/// (docs/AVOIDANCE.md, "Is the predicted miss's σ believable?"). Counted: the
/// predictions that carry a σ, of the tracks following the ball, made before its true closest
/// approach, that predict an approach (not receding) within the horizon.
struct MissCalibration {
  int predictions = 0, within_1_sigma = 0, within_2_sigma = 0;
  MissCalibration& operator+=(const MissCalibration& o);
};
MissCalibration miss_calibration(std::span<const PredictionResult> predictions, std::span<const int> ball_tracks,
                                 double true_miss_m, TimeNs true_closest_t, double horizon_s);

/// One method on one throw.
struct DodgeOutcome {
  bool maneuvered = false;               ///< a manoeuvre was commanded
  std::optional<TimeNs> decision_t;      ///< the first kDodge decision
  std::optional<DodgeManeuver> maneuver;  ///< the first manoeuvre
  int decisions = 0;                     ///< every decision (re-plans, commits, cancels)
  std::optional<double> predicted_miss_m;  ///< the mean's miss distance at the first kDodge
  std::optional<double> warning_time_s;    ///< true contact − decision (threats)
  double miss_with_maneuver_m = 0;  ///< the true closest approach with the set-points flown
  bool escaped = false;             ///< threat and miss_with_maneuver_m >= the safety radius
  std::string reason;               ///< no decision: why (e.g. "never detected")
  int replans = 0;                  ///< kReplan decisions
  /// A perception method that decided: the ball's eligible windows from the first decision to the
  /// closest approach, those with a detection on it, and whether one track held it (open loop
  /// too, as the reference for what the manoeuvre changes in the closed loop).
  std::optional<std::size_t> eligible_after_decision, found_after_decision;
  std::optional<bool> track_survived;
  std::optional<bool> track_recreated;  ///< ManeuverPerception::track_recreated
};

struct DodgeThrow {
  std::uint64_t seed = 0;
  nlohmann::json parameters;  ///< sim::to_json(RandomThrowParameters)
  double true_miss_m = 0;     ///< without a manoeuvre
  std::optional<double> true_contact_t_s;
  /// Ours' timeline on the ball: the end of the first window with the ball in view
  /// (first_window_in_view), of the first with a detection on it, and when the first usable
  /// fusion estimate of a track following it existed [s].
  std::optional<double> first_in_view_t_s, first_detection_t_s, first_usable_estimate_t_s;
  MissCalibration miss_calibration;  ///< ours', open loop
  bool threat = false, non_threat = false, near_miss = false;
  std::map<std::string, DodgeOutcome> outcomes;  ///< by method (evaluated_methods)
  /// With closed_loop: the kinematic replay's outcomes, and the open-loop decisions flown by the
  /// vehicle model without rendering again.
  std::map<std::string, DodgeOutcome> open_loop_outcomes, dynamics_outcomes;
  /// With closed_loop: ours' pipeline time per window in the loop [ms], and what the vehicle model
  /// changed in ours' commands (clipped tilts, floor holds, late commands).
  std::vector<double> window_total_ms;
  sim::FlightCounters flight;
  /// Each method's decisions and ours' window ends, open loop (the closed loop starts from them).
  std::map<std::string, std::vector<DodgeDecision>> decisions;
  std::vector<TimeNs> window_ends;
  double seconds = 0;  ///< wall time of this throw
  std::string error;   ///< a throw that could not be evaluated (then no outcomes)
};

struct DodgeTotals {
  int threats = 0, escaped = 0, non_threats = 0, false_alarms = 0, near_misses = 0;
  int near_miss_maneuvers = 0;
  std::vector<double> warning_times_s;  ///< threats with a decision
  std::vector<double> miss_errors_m;    ///< |predicted − true miss| at each first decision
  int replans = 0;
  /// The eligible windows after the first decision (pooled over the decided throws) and those with
  /// the ball found; the decided throws whose track was checked, lost (ManeuverPerception's
  /// track_survived false), and re-created (track_recreated).
  std::size_t eligible_after_decision = 0, found_after_decision = 0;
  int tracks_checked = 0, tracks_lost = 0, tracks_recreated = 0;
};

struct DodgeEval {
  std::vector<DodgeThrow> throws;
  std::map<std::string, DodgeTotals> totals;
  double wall_s = 0;
};

/// The end of the first of `window_ends` at which ball `ball` is in flight, its true apparent
/// diameter is at least kInViewMinDiameterPx and at least kInViewMinFraction of its disc is in
/// the image (eval/ground_truth_box.h); nothing when it never is.
std::optional<TimeNs> first_window_in_view(const DatasetTruth& truth, int ball, std::span<const TimeNs> window_ends);

/// The outcome of one method's decisions (in order) on the truth: the kinematic replay, the
/// set-points' motion added to the body (`replay`), or, with replay false, the truth's body as
/// it is (a flown truth already holds the manoeuvre).
DodgeOutcome dodge_outcome(const DatasetTruth& truth, int ball, const std::vector<DodgeDecision>& decisions,
                           double safety_radius_m, bool replay = true);

/// One simulated dataset with one ball: runs every method and scores them (the run of ours into
/// `run_dir` as `fdv run` writes it, unless empty). A ball never detected gives no decision, with
/// that reason. Throws what the dataset reader and the pipeline throw.
DodgeThrow score_dodge_dataset(const std::string& dataset, const DodgeEvalOptions& options,
                               const std::string& run_dir = "");

/// One throw: simulates seed's random_throw into `throw_dir`/dataset (single-threaded) and scores
/// it; the dataset is removed afterwards unless options.keep.
DodgeThrow evaluate_dodge_throw(std::uint64_t seed, const DodgeEvalOptions& options, const std::string& throw_dir);

/// Every seed, `jobs` at a time with a progress line per throw; writes DIR/dodge_eval.json at the
/// end and, as each throw ends, its row (throw_json) as a line of DIR/throws.jsonl, in the order
/// the throws end.
DodgeEval run_dodge_eval(const DodgeEvalOptions& options);

/// Which of a throw's outcomes: the reported ones, the open loop's, the dynamics-only ones.
using OutcomeSet = std::map<std::string, DodgeOutcome> DodgeThrow::*;

/// The methods `options` evaluates, in kDodgeMethods' order. Throws ConfigError naming a baseline
/// that is not one of kPerceptionBaselines.
std::vector<std::string> evaluated_methods(const DodgeEvalOptions& options);

DodgeTotals dodge_totals(const std::vector<DodgeThrow>& throws, const std::string& method,
                         OutcomeSet set = &DodgeThrow::outcomes);
/// One throw's row of dodge_eval.json's `throws`.
nlohmann::json throw_json(const DodgeThrow& row, const DodgeEvalOptions& options);
nlohmann::json to_json(const DodgeEval& e, const DodgeEvalOptions& options);

}  // namespace fdv
