#include "fdv/tables/dodge_eval.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>

#include "fdv/avoidance/maneuver_playback.h"
#include "fdv/core/error.h"
#include "fdv/core/thread_pool.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/results/run.h"
#include "fdv/sim/dataset_cache.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/random_throw.h"
#include "fdv/tables/closed_loop.h"
#include "fdv/tables/experiment.h"

namespace fdv {
namespace {

using Clock = std::chrono::steady_clock;
constexpr TimeNs kOutcomeStepNs = kNsPerMs;
constexpr TimeNs kPastTheEndNs = 300 * kNsPerMs;

std::optional<double> seconds_of(std::optional<TimeNs> t) { return t ? std::optional(to_seconds(*t)) : std::nullopt; }

/// What one pipeline run gives the evaluation: its decisions, its window ends, the first
/// detection of the ball (the oracle starts there) and the first usable fusion estimate of a
/// track that follows the ball.
struct MethodRun {
  std::vector<DodgeDecision> decisions;
  std::vector<WindowDetections> windows;
  std::vector<TimeNs> window_ends;
  std::optional<TimeNs> first_ball_detection;
  std::optional<TimeNs> first_usable_estimate;
  std::vector<PredictionResult> predictions;
  std::vector<int> ball_tracks;  ///< tracks_following the ball
};

/// One variant's run over the dataset, through the same run as `fdv run` (into `results_dir`
/// when it is not empty).
MethodRun run_method(const DatasetTruth& truth, int ball, const PerceptionOptions& options,
                     const std::string& results_dir) {
  MethodRun run;
  std::vector<WindowDetections>& windows = run.windows;
  std::map<int, TimeNs> first_usable_by_track;
  PerceptionCallbacks also;
  also.on_window = [&](const WindowResult& w) {
    run.window_ends.push_back(w.t_end);
    windows.push_back(window_detections(w));
  };
  also.on_estimate = [&](const EstimateResult& e) {
    if (e.mode != EstimatorMode::kFusion || !e.estimate->usable) return;
    // An estimate solved on a depth frame exists once the windows up to it are done.
    const TimeNs exists_at = std::max(e.t, run.window_ends.empty() ? e.t : run.window_ends.back());
    first_usable_by_track.try_emplace(e.track_id, exists_at);
  };
  also.on_dodge = [&](const DodgeDecision& d) { run.decisions.push_back(d); };
  also.on_prediction = [&](const PredictionResult& p) { run.predictions.push_back(p); };
  RunRequest request;
  request.input = truth.dir;
  request.options = options;
  RecordingRun(std::move(request)).into(results_dir, also);
  if (const auto first = first_ball_detection(truth, windows, ball)) run.first_ball_detection = first->window_end;
  run.ball_tracks = tracks_following(truth, windows, ball);
  for (int track : run.ball_tracks)
    if (const auto it = first_usable_by_track.find(track); it != first_usable_by_track.end())
      if (!run.first_usable_estimate || it->second < *run.first_usable_estimate)
        run.first_usable_estimate = it->second;
  return run;
}

/// An oracle: from `start` on, at each window's end, the planner gets the true trajectory and the
/// true vehicle state, both exact (zero covariance).
std::vector<DodgeDecision> oracle_decisions(const DatasetTruth& truth, int ball, const MethodRun& run,
                                            std::optional<TimeNs> start, const PerceptionOptions& options) {
  std::vector<DodgeDecision> decisions;
  if (!start) return decisions;
  DodgePlanner planner(options.dodge, options.prediction.safety_radius_m);
  for (TimeNs t : run.window_ends)
    if (t >= *start)
      if (auto d = decide_on_truth(planner, truth, ball, t, truth.body_at(t), options.prediction)) decisions.push_back(*d);
  return decisions;
}

bool is_perception_baseline(const std::string& method) {
  return std::find(kPerceptionBaselines.begin(), kPerceptionBaselines.end(), method) != kPerceptionBaselines.end();
}

/// Ours, and the baselines of `options` that change one thing each.
std::map<std::string, PerceptionOptions> perception_variants(const DodgeEvalOptions& options) {
  PerceptionOptions ours = options.perception;
  ours.threads = 1;
  std::map<std::string, PerceptionOptions> variants;
  variants["ours"] = ours;
  for (const std::string& method : evaluated_methods(options)) {
    if (!is_perception_baseline(method)) continue;
    PerceptionOptions& variant = variants[method] = ours;
    if (method == "point_estimate") variant.dodge_from = DodgeSource::kFusionPointEstimate;
    if (method == "mono") variant.dodge_from = DodgeSource::kMonocular, variant.monocular_baseline = true;
    if (method == "rotation") variant.compensation.method = CompensationMethod::kRotation;
  }
  return variants;
}

/// An outcome as the throw reports it: an escape only of a threat, the warning time against the
/// true contact, and why nothing was decided.
DodgeOutcome scored(const DodgeThrow& row, const std::string& method, DodgeOutcome o, std::optional<TimeNs> contact) {
  o.escaped = row.threat && o.escaped;
  if (o.decision_t && contact) o.warning_time_s = to_seconds(*contact - *o.decision_t);
  if (!o.maneuvered) {
    if (method == "oracle_visible") o.reason = row.first_in_view_t_s ? "no manoeuvre decided" : "never in view";
    else o.reason = row.first_detection_t_s ? "no manoeuvre decided" : "never detected";
  }
  return o;
}

void add_maneuver_perception(DodgeOutcome& o, const ManeuverPerception& p) {
  o.eligible_after_decision = p.eligible;
  o.found_after_decision = p.found;
  o.track_survived = p.track_survived;
  o.track_recreated = p.track_recreated;
}

/// Every perception method flown through the closed loop, in one simulation that also writes the
/// open loop's dataset to `open_loop_dataset` (the scene before any decision is the same). `dir`:
/// where flights are kept (empty: nowhere).
std::map<std::string, ClosedLoopFlight> fly_perception_methods(
    const sim::ScenarioConfig& config, const DodgeEvalOptions& options, const std::string& dir,
    const std::string& open_loop_dataset) {
  const std::map<std::string, PerceptionOptions> variants = perception_variants(options);
  std::map<std::string, FlightOutputs> kept;
  if (!dir.empty())
    for (const auto& [method, perception] : variants) {
      const std::string keep = method == "ours" ? dir : dir + "/" + method;
      kept[method] = {keep + "/dataset", keep + "/run"};
    }
  std::filesystem::remove_all(open_loop_dataset);
  sim::DatasetSink open_loop(open_loop_dataset, config.calibration());
  std::map<std::string, ClosedLoopFlight> flights =
      fly_with_perceptions(config, variants, kept, &open_loop);
  open_loop.finish(sim::Simulator(config).manifest_yaml());
  sim::mark_simulated(config, open_loop_dataset);
  return flights;
}

/// The closed loop's outcomes of every method (the perception methods' `flights`, the oracles
/// flown here), and every open-loop decision list through the vehicle model alone (dodge_eval.h).
void score_closed_loop(DodgeThrow& row, const sim::ScenarioConfig& config,
                       const DatasetTruth& truth, const DodgeEvalOptions& options,
                       const std::map<std::string, ClosedLoopFlight>& flights) {
  const int ball = truth.radius_m.begin()->first;
  const double radius = options.perception.prediction.safety_radius_m;
  const std::optional<TimeNs> contact = true_contact_time(truth, ball, radius);
  row.open_loop_outcomes = row.outcomes;
  for (const std::string& method : evaluated_methods(options)) {
    const std::vector<DodgeDecision>& open_loop = row.decisions[method];
    row.dynamics_outcomes[method] =
        scored(row, method, dodge_outcome(fly_decisions(config, truth, open_loop), ball, open_loop, radius, false), contact);
  }
  auto seconds_to_ns = [](std::optional<double> s) { return s ? std::optional(from_seconds(*s)) : std::nullopt; };
  for (const auto& [method, f] : flights) {
    DodgeOutcome o = scored(row, method, dodge_outcome(f.truth, ball, f.decisions, radius, false), contact);
    if (o.decision_t) add_maneuver_perception(o, maneuver_perception(f.truth, ball, f.windows, *o.decision_t));
    row.outcomes[method] = o;
    if (method == "ours") {
      row.window_total_ms = f.window_total_ms;
      row.flight = f.flight;
    }
  }
  const PerceptionOptions& ours = options.perception;
  const ClosedLoopFlight oracle =
      fly_oracle(config, truth, ball, row.window_ends, seconds_to_ns(row.first_detection_t_s), ours);
  row.outcomes["oracle"] = scored(row, "oracle", dodge_outcome(oracle.truth, ball, oracle.decisions, radius, false), contact);
  const ClosedLoopFlight visible =
      fly_oracle(config, truth, ball, row.window_ends, seconds_to_ns(row.first_in_view_t_s), ours);
  row.outcomes["oracle_visible"] =
      scored(row, "oracle_visible", dodge_outcome(visible.truth, ball, visible.decisions, radius, false), contact);
}

}  // namespace

MissCalibration& MissCalibration::operator+=(const MissCalibration& o) {
  predictions += o.predictions;
  within_1_sigma += o.within_1_sigma;
  within_2_sigma += o.within_2_sigma;
  return *this;
}

MissCalibration miss_calibration(std::span<const PredictionResult> predictions, std::span<const int> ball_tracks,
                                 double true_miss_m, TimeNs true_closest_t, double horizon_s) {
  MissCalibration out;
  for (const PredictionResult& p : predictions) {
    const ClosestApproach& c = p.prediction.closest;
    if (!p.miss_distance_sigma_m || p.t >= true_closest_t || c.receding || c.time_from_now_s >= horizon_s ||
        std::find(ball_tracks.begin(), ball_tracks.end(), p.track_id) == ball_tracks.end())
      continue;
    const double error = std::abs(c.miss_distance_m - true_miss_m);
    ++out.predictions;
    out.within_1_sigma += error <= *p.miss_distance_sigma_m;
    out.within_2_sigma += error <= 2 * *p.miss_distance_sigma_m;
  }
  return out;
}

std::vector<std::string> evaluated_methods(const DodgeEvalOptions& options) {
  for (const std::string& name : options.baselines)
    if (!is_perception_baseline(name))
      throw ConfigError(fmt::format("dodge-eval: unknown baseline '{}' (one of {})", name,
                                    fmt::join(kPerceptionBaselines, ", ")));
  std::vector<std::string> methods;
  for (const std::string& method : kDodgeMethods)
    if (!is_perception_baseline(method) ||
        std::find(options.baselines.begin(), options.baselines.end(), method) != options.baselines.end())
      methods.push_back(method);
  return methods;
}

std::optional<TimeNs> first_window_in_view(const DatasetTruth& truth, int ball, std::span<const TimeNs> window_ends) {
  const double radius = truth.radius_m.at(ball);
  for (TimeNs t : window_ends) {
    if (!truth.in_flight(ball, t)) continue;
    const GroundTruthBox b = ground_truth_box(truth.objects, ball, radius, truth.body, truth.calibration, t, t);
    if (b.visible && b.span_px_max >= kInViewMinDiameterPx && b.fraction_in_view_min >= kInViewMinFraction) return t;
  }
  return std::nullopt;
}

DodgeOutcome dodge_outcome(const DatasetTruth& truth, int ball, const std::vector<DodgeDecision>& decisions,
                           double safety_radius_m, bool replay) {
  DodgeOutcome out;
  std::vector<DodgeDecision> flown;
  for (const DodgeDecision& d : decisions) {
    if (d.action == DodgeAction::kRefused) continue;
    flown.push_back(d);
    out.replans += d.action == DodgeAction::kReplan;
    if (d.action == DodgeAction::kDodge && !out.decision_t) {
      out.maneuvered = true;
      out.decision_t = d.t;
      out.maneuver = d.maneuver;
      out.predicted_miss_m = d.miss_distance_m;
    }
  }
  out.decisions = static_cast<int>(decisions.size());
  if (truth.body.empty()) throw InputError(truth.dir, "truth", "no vehicle truth");
  // A scene may end before the ball has passed (random_throw ends when the ball reaches the
  // camera): beyond its end the ball flies on ballistically from its last sample and the body on
  // at its last velocity, for kPastTheEndNs, so that a manoeuvre's closest approach is found.
  const ObjectState* last = nullptr;
  for (const ObjectState& o : truth.objects)
    if (o.id == ball) last = &o;
  if (!last) throw InputError(truth.dir, "truth", "no samples of ball " + std::to_string(ball));
  const OdometrySample& body_end = truth.body.back();
  auto ball_at = [&](TimeNs t) -> std::optional<Eigen::Vector3d> {
    if (t > last->t) {
      const double s = to_seconds(t - last->t);
      return last->p_W + s * last->v_W + 0.5 * s * s * truth.gravity_W;
    }
    const auto object = truth.object_at(ball, t);
    return object ? std::optional(object->p_W) : std::nullopt;
  };
  auto body_at = [&](TimeNs t) -> Eigen::Vector3d {
    return t > body_end.t ? Eigen::Vector3d(body_end.p_W_B + to_seconds(t - body_end.t) * body_end.v_W)
                          : truth.body_at(t).p_W_B;
  };
  double closest = std::numeric_limits<double>::infinity();
  for (TimeNs t = truth.body.front().t; t <= body_end.t + kPastTheEndNs; t += kOutcomeStepNs) {
    const auto object = ball_at(t);
    if (!object) continue;
    const Eigen::Vector3d vehicle = replay ? Eigen::Vector3d(body_at(t) + commanded_offset(flown, t).position_W) : body_at(t);
    closest = std::min(closest, (*object - vehicle).norm());
  }
  out.miss_with_maneuver_m = closest;
  out.escaped = closest >= safety_radius_m;
  return out;
}

DodgeThrow score_dodge_dataset(const std::string& dataset, const DodgeEvalOptions& options,
                               const std::string& run_dir) {
  DodgeThrow row;
  const DatasetTruth truth = load_dataset_truth(dataset);
  if (truth.radius_m.empty()) throw InputError(dataset, "truth", "no ball in the ground truth");
  const int ball = truth.radius_m.begin()->first;
  const double radius = options.perception.prediction.safety_radius_m;

  row.true_miss_m = dodge_outcome(truth, ball, {}, radius).miss_with_maneuver_m;
  row.threat = row.true_miss_m < radius;
  row.non_threat = row.true_miss_m > kNonThreatMissM;
  row.near_miss = !row.threat && !row.non_threat;
  const std::optional<TimeNs> contact = true_contact_time(truth, ball, radius);
  if (contact) row.true_contact_t_s = to_seconds(*contact);

  const std::map<std::string, PerceptionOptions> variants = perception_variants(options);
  const PerceptionOptions& ours = variants.at("ours");
  std::map<std::string, std::vector<DodgeDecision>>& decisions = row.decisions;
  std::optional<TimeNs> first_detection;
  std::map<std::string, std::vector<WindowDetections>> windows;
  for (const auto& [method, perception] : variants) {
    const MethodRun run = run_method(truth, ball, perception, method == "ours" ? run_dir : "");
    decisions[method] = run.decisions;
    windows[method] = run.windows;
    if (method == "ours") {
      row.window_ends = run.window_ends;
      first_detection = run.first_ball_detection;
      const std::optional<TimeNs> in_view = first_window_in_view(truth, ball, run.window_ends);
      decisions["oracle"] = oracle_decisions(truth, ball, run, first_detection, ours);
      decisions["oracle_visible"] = oracle_decisions(truth, ball, run, in_view, ours);
      row.first_in_view_t_s = seconds_of(in_view);
      row.first_detection_t_s = seconds_of(first_detection);
      row.first_usable_estimate_t_s = seconds_of(run.first_usable_estimate);
      if (const auto closest = true_closest_approach(truth, ball))
        row.miss_calibration = miss_calibration(run.predictions, run.ball_tracks, row.true_miss_m, closest->t,
                                                perception.prediction.horizon_s);
    }
  }
  for (const std::string& method : evaluated_methods(options)) {
    DodgeOutcome o = scored(row, method, dodge_outcome(truth, ball, decisions[method], radius), contact);
    if (const auto it = windows.find(method); it != windows.end() && o.decision_t)
      add_maneuver_perception(o, maneuver_perception(truth, ball, it->second, *o.decision_t));
    row.outcomes[method] = o;
  }
  return row;
}

DodgeThrow evaluate_dodge_throw(std::uint64_t seed, const DodgeEvalOptions& options, const std::string& throw_dir) {
  const auto start = Clock::now();
  const sim::RandomThrowParameters parameters = sim::sample_random_throw(seed);
  sim::ScenarioConfig config = sim::random_throw_config(parameters);
  config.threads = 1;
  // Closed loop: ours' flown dataset and run take DIR/throws/SEED/{dataset,run}; the open loop's
  // go under open_loop/.
  const std::string open_dir = options.closed_loop ? throw_dir + "/open_loop" : throw_dir;
  const std::string dataset = open_dir + "/dataset";
  std::map<std::string, ClosedLoopFlight> flights;
  if (options.closed_loop)
    flights = fly_perception_methods(config, options, options.keep ? throw_dir : "", dataset);
  else
    sim::ensure_simulated(config, dataset);
  DodgeThrow row = score_dodge_dataset(dataset, options, options.keep ? open_dir + "/run" : "");
  row.seed = seed;
  row.parameters = sim::to_json(parameters);
  if (options.closed_loop)
    score_closed_loop(row, config, load_dataset_truth(dataset), options, flights);
  if (!options.keep) std::filesystem::remove_all(dataset);
  row.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return row;
}

DodgeTotals dodge_totals(const std::vector<DodgeThrow>& throws, const std::string& method, OutcomeSet set) {
  DodgeTotals t;
  for (const DodgeThrow& row : throws) {
    const auto it = (row.*set).find(method);
    if (it == (row.*set).end()) continue;
    const DodgeOutcome& o = it->second;
    t.replans += o.replans;
    if (o.eligible_after_decision) {
      t.eligible_after_decision += *o.eligible_after_decision;
      t.found_after_decision += o.found_after_decision.value_or(0);
    }
    if (o.track_survived) {
      ++t.tracks_checked;
      t.tracks_lost += !*o.track_survived;
      t.tracks_recreated += o.track_recreated.value_or(false);
    }
    if (row.threat) {
      ++t.threats;
      t.escaped += o.escaped;
      if (o.warning_time_s) t.warning_times_s.push_back(*o.warning_time_s);
    } else if (row.non_threat) {
      ++t.non_threats;
      t.false_alarms += o.maneuvered;
    } else {
      ++t.near_misses;
      t.near_miss_maneuvers += o.maneuvered;
    }
    if (o.predicted_miss_m) t.miss_errors_m.push_back(std::abs(*o.predicted_miss_m - row.true_miss_m));
  }
  return t;
}

namespace {

nlohmann::json totals_json(const DodgeTotals& t) {
  auto rate = [](int n, int of) { return of > 0 ? nlohmann::json(static_cast<double>(n) / of) : nlohmann::json(); };
  return {{"threats", t.threats},
          {"escaped", t.escaped},
          {"escape_rate", rate(t.escaped, t.threats)},
          {"non_threats", t.non_threats},
          {"false_alarms", t.false_alarms},
          {"false_alarm_rate", rate(t.false_alarms, t.non_threats)},
          {"near_misses", t.near_misses},
          {"near_miss_maneuvers", t.near_miss_maneuvers},
          {"warning_time_s", summarize(t.warning_times_s).to_json()},
          {"miss_error_at_decision_m", summarize(t.miss_errors_m).to_json()},
          {"replans", t.replans}};
}

/// What the manoeuvre did to perception (dodge_eval.h), beside totals_json's.
void add_perception_totals(nlohmann::json& j, const DodgeTotals& t) {
  j["eligible_windows_after_decision"] = t.eligible_after_decision;
  j["found_windows_after_decision"] = t.found_after_decision;
  j["recall_after_decision"] = t.eligible_after_decision > 0
                                   ? nlohmann::json(static_cast<double>(t.found_after_decision) /
                                                    static_cast<double>(t.eligible_after_decision))
                                   : nlohmann::json();
  j["tracks_checked"] = t.tracks_checked;
  j["tracks_lost"] = t.tracks_lost;
  j["tracks_recreated"] = t.tracks_recreated;
}

nlohmann::json miss_calibration_json(const MissCalibration& c) {
  auto share = [&](int n) { return c.predictions > 0 ? nlohmann::json(static_cast<double>(n) / c.predictions) : nlohmann::json(); };
  return {{"predictions", c.predictions},
          {"within_1_sigma", c.within_1_sigma},
          {"within_2_sigma", c.within_2_sigma},
          {"within_1_sigma_share", share(c.within_1_sigma)},
          {"within_2_sigma_share", share(c.within_2_sigma)}};
}

nlohmann::json outcome_json(const DodgeOutcome& o) {
  nlohmann::json j = {{"maneuvered", o.maneuvered},
                      {"decisions", o.decisions},
                      {"miss_with_maneuver_m", o.miss_with_maneuver_m},
                      {"escaped", o.escaped}};
  if (o.decision_t) j["decision_t_s"] = to_seconds(*o.decision_t);
  if (o.warning_time_s) j["warning_time_s"] = *o.warning_time_s;
  if (o.predicted_miss_m) j["predicted_miss_m"] = *o.predicted_miss_m;
  if (const auto& m = o.maneuver)
    j["maneuver"] = {{"acceleration_W", {m->acceleration_W.x(), m->acceleration_W.y(), m->acceleration_W.z()}},
                     {"start_t_s", to_seconds(m->start_t)},
                     {"duration_s", m->duration_s}};
  if (!o.reason.empty()) j["reason"] = o.reason;
  j["replans"] = o.replans;
  if (o.eligible_after_decision) {
    j["eligible_windows_after_decision"] = *o.eligible_after_decision;
    j["found_windows_after_decision"] = o.found_after_decision.value_or(0);
  }
  if (o.track_survived) j["track_survived"] = *o.track_survived;
  if (o.track_recreated) j["track_recreated"] = *o.track_recreated;
  return j;
}

/// The totals of one outcome set: ours' (totals_json), ours against the oracles, the baselines'
/// (those of `methods` but ours).
nlohmann::json outcome_set_json(const DodgeEval& e, OutcomeSet set, const std::vector<std::string>& methods) {
  auto totals = [&](const std::string& method) {
    const DodgeTotals t = dodge_totals(e.throws, method, set);
    nlohmann::json j = totals_json(t);
    add_perception_totals(j, t);
    return j;
  };
  nlohmann::json j = totals("ours");
  // Ours among the threats the oracle escapes: the share of what the sensors allow.
  int oracle_escaped = 0, ours_too = 0;
  for (const DodgeThrow& row : e.throws) {
    const auto& outcomes = row.*set;
    if (outcomes.empty() || !outcomes.at("oracle").escaped) continue;
    ++oracle_escaped;
    ours_too += outcomes.at("ours").escaped;
  }
  j["oracle_escaped"] = oracle_escaped;
  j["escaped_where_oracle_escaped"] = ours_too;
  // The same against the detector-independent bound, with the lag of each threat we miss.
  int visible_escaped = 0, ours_too_visible = 0;
  j["late_against_oracle_visible"] = nlohmann::json::array();
  for (const DodgeThrow& row : e.throws) {
    const auto& outcomes = row.*set;
    if (outcomes.empty() || !outcomes.at("oracle_visible").escaped) continue;
    ++visible_escaped;
    const DodgeOutcome& o = outcomes.at("ours");
    ours_too_visible += o.escaped;
    if (o.escaped) continue;
    nlohmann::json lag = {{"seed", row.seed}};
    auto put = [&](const char* key, std::optional<double> t) { lag[key] = t ? nlohmann::json(*t) : nlohmann::json(); };
    put("first_in_view_t_s", row.first_in_view_t_s);
    put("first_detection_t_s", row.first_detection_t_s);
    put("first_usable_estimate_t_s", row.first_usable_estimate_t_s);
    put("decision_t_s", seconds_of(o.decision_t));
    const DodgeOutcome& bound = outcomes.at("oracle_visible");
    put("oracle_visible_decision_t_s", seconds_of(bound.decision_t));
    j["late_against_oracle_visible"].push_back(lag);
  }
  j["oracle_visible_escaped"] = visible_escaped;
  j["escaped_where_oracle_visible_escaped"] = ours_too_visible;

  j["baselines"] = nlohmann::json::object();
  for (const std::string& method : methods)
    if (method != "ours") j["baselines"][method] = totals(method);
  return j;
}

}  // namespace

nlohmann::json throw_json(const DodgeThrow& row, const DodgeEvalOptions& options) {
  nlohmann::json t = {{"seed", row.seed},           {"parameters", row.parameters},
                      {"true_miss_m", row.true_miss_m}, {"threat", row.threat},
                      {"non_threat", row.non_threat},   {"near_miss", row.near_miss},
                      {"seconds", row.seconds}};
  if (row.true_contact_t_s) t["true_contact_t_s"] = *row.true_contact_t_s;
  if (row.first_in_view_t_s) t["first_in_view_t_s"] = *row.first_in_view_t_s;
  if (row.first_detection_t_s) t["first_detection_t_s"] = *row.first_detection_t_s;
  if (row.first_usable_estimate_t_s) t["first_usable_estimate_t_s"] = *row.first_usable_estimate_t_s;
  if (row.error.empty()) (options.closed_loop ? t["open_loop"] : t)["miss_calibration"] = miss_calibration_json(row.miss_calibration);
  if (!row.error.empty()) t["error"] = row.error;
  for (const auto& [method, o] : row.outcomes) t["outcomes"][method] = outcome_json(o);
  if (options.closed_loop && row.error.empty()) {
    for (const auto& [method, o] : row.open_loop_outcomes) t["open_loop"]["outcomes"][method] = outcome_json(o);
    for (const auto& [method, o] : row.dynamics_outcomes) t["dynamics_only"]["outcomes"][method] = outcome_json(o);
    t["window_total_ms"] = summarize(row.window_total_ms).to_json();
    t["flight"] = {{"commands", row.flight.commands},
                   {"tilt_clipped", row.flight.tilt_clipped},
                   {"late", row.flight.late},
                   {"floor_holds", row.flight.floor_holds},
                   {"ceiling_holds", row.flight.ceiling_holds},
                   {"wall_holds", row.flight.wall_holds}};
  }
  return t;
}

nlohmann::json to_json(const DodgeEval& e, const DodgeEvalOptions& options) {
  const std::vector<std::string> methods = evaluated_methods(options);
  nlohmann::json j = outcome_set_json(e, &DodgeThrow::outcomes, methods);
  MissCalibration calibration;  // ours' open-loop run's
  for (const DodgeThrow& row : e.throws) calibration += row.miss_calibration;
  if (!options.closed_loop) j["miss_calibration"] = miss_calibration_json(calibration);
  if (options.closed_loop) {
    j["closed_loop"] = true;
    j["open_loop"] = outcome_set_json(e, &DodgeThrow::open_loop_outcomes, methods);
    j["open_loop"]["miss_calibration"] = miss_calibration_json(calibration);
    j["dynamics_only"] = outcome_set_json(e, &DodgeThrow::dynamics_outcomes, methods);
    std::vector<double> window_ms;
    for (const DodgeThrow& row : e.throws) window_ms.insert(window_ms.end(), row.window_total_ms.begin(), row.window_total_ms.end());
    j["window_total_ms"] = summarize(window_ms).to_json();
    j["response_delay_s"] = options.perception.dodge.limits.response_delay_s;
  }
  j["throws"] = nlohmann::json::array();
  for (const DodgeThrow& row : e.throws) j["throws"].push_back(throw_json(row, options));
  j["safety_radius_m"] = options.perception.prediction.safety_radius_m;
  j["methods"] = methods;
  j["wall_s"] = e.wall_s;
  j["options"] = to_json(options.perception);
  return j;
}

DodgeEval run_dodge_eval(const DodgeEvalOptions& options) {
  if (options.seeds.empty()) throw ConfigError("dodge-eval: no seeds");
  if (options.jobs < 1) throw ConfigError("dodge-eval: --jobs must be >= 1");
  evaluated_methods(options);  // an unknown baseline fails here, before any throw
  if (const auto why = options.perception.validate(); !why.empty()) throw ConfigError(why);
  const auto start = Clock::now();
  DodgeEval eval;
  eval.throws.resize(options.seeds.size());
  std::filesystem::create_directories(options.out_dir);
  // Each throw's row as it ends, so that an interrupted evaluation keeps what it did.
  const std::string lines_path = options.out_dir + "/throws.jsonl";
  std::ofstream lines(lines_path);
  if (!lines) throw InputError(lines_path, "", "cannot create output file");
  std::mutex progress;
  std::size_t done = 0;
  ThreadPool pool(options.jobs);
  pool.parallel_for(options.seeds.size(), [&](std::size_t i) {
    const std::uint64_t seed = options.seeds[i];
    const std::string throw_dir = options.out_dir + "/throws/" + std::to_string(seed);
    DodgeThrow row;
    try {
      row = evaluate_dodge_throw(seed, options, throw_dir);
    } catch (const std::exception& e) {
      row.seed = seed;
      row.error = e.what();
    }
    if (!options.keep) std::filesystem::remove_all(throw_dir);
    const std::lock_guard<std::mutex> lock(progress);
    lines << throw_json(row, options).dump() << std::endl;  // flushed: readable while running
    ++done;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    const double eta = elapsed / static_cast<double>(done) * static_cast<double>(options.seeds.size() - done);
    if (!row.error.empty()) {
      spdlog::error("[{}/{}] seed {}: {}", done, options.seeds.size(), seed, row.error);
    } else {
      auto verdict = [&](const std::string& method) {
        const DodgeOutcome& o = row.outcomes.at(method);
        if (row.threat) return std::string(o.escaped ? "escaped" : "hit");
        return std::string(o.maneuvered ? "manoeuvred" : "held");
      };
      spdlog::info("[{}/{}] seed {}: {} (true miss {:.2f} m); ours {}, oracle {}, oracle_visible {}; {:.1f} s, ~{:.0f} s left",
                   done, options.seeds.size(), seed,
                   row.threat ? "threat" : (row.non_threat ? "non-threat" : "near miss"), row.true_miss_m,
                   verdict("ours"), verdict("oracle"), verdict("oracle_visible"), row.seconds, eta);
    }
    eval.throws[i] = std::move(row);
  });
  for (const std::string& method : evaluated_methods(options)) eval.totals[method] = dodge_totals(eval.throws, method);
  eval.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  const std::string path = options.out_dir + "/dodge_eval.json";
  std::ofstream out(path);
  if (!out) throw InputError(path, "", "cannot create output file");
  out << to_json(eval, options).dump(2) << "\n";
  return eval;
}

}  // namespace fdv
