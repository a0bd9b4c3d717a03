#include "fdv/tables/closed_loop.h"

#include <algorithm>
#include <map>
#include <memory>

#include "fdv/avoidance/maneuver_playback.h"
#include "fdv/estimation/collision_risk.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/results/run.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/simulator.h"
#include "fdv/tables/experiment.h"

namespace fdv {
namespace {

/// The truth of `config` without its body samples.
DatasetTruth truth_frame(const sim::ScenarioConfig& config) {
  DatasetTruth t;
  t.dir = "closed loop: " + config.name + " seed " + std::to_string(config.seed);
  t.calibration = config.calibration();
  for (const auto& b : config.balls) t.radius_m[b.id] = b.radius_m;
  t.gravity_W = config.gravity_W_m_s2;
  t.scenario = config.name;
  return t;
}

/// The flown body at the truth rate over the scene, as the simulator writes truth/body.csv.
std::vector<OdometrySample> sample_body(const sim::ScenarioConfig& config, sim::FlownVehicle& vehicle) {
  vehicle.advance_to(config.duration_s);
  std::vector<OdometrySample> body;
  const TimeNs end = from_seconds(config.duration_s);
  for (std::uint64_t k = 0;; ++k) {
    const TimeNs t = std::llround(static_cast<double>(k) * 1e9 / config.truth.rate_hz);
    if (t > end) break;
    body.push_back(sim::to_pose_sample(t, vehicle.at(to_seconds(t))));
  }
  return body;
}

/// Every stream of the simulation into a live Perception, the truth kept, and optionally the
/// dataset written.
class LoopSink : public sim::SimulationSink {
 public:
  LoopSink(Perception& perception, sim::DatasetSink* dataset) : perception_(perception), dataset_(dataset) {}
  void on_events(std::span<const Event> events, std::span<const std::int16_t> labels) override {
    if (dataset_) dataset_->on_events(events, labels);
    perception_.push_events(events);
  }
  void on_imu(const ImuSample& s) override {
    if (dataset_) dataset_->on_imu(s);
    perception_.push_imu(s);
  }
  void on_depth(const DepthFrame& f) override {
    if (dataset_) dataset_->on_depth(f);
    perception_.push_depth(f);
  }
  void on_odometry(const OdometrySample& s) override {
    if (dataset_) dataset_->on_odometry(s);
    perception_.push_odometry(s);
  }
  void on_body_truth(const OdometrySample& s) override {
    if (dataset_) dataset_->on_body_truth(s);
    body.push_back(s);
  }
  void on_unflown_body_truth(const OdometrySample& s) override {
    if (dataset_) dataset_->on_unflown_body_truth(s);
  }
  void on_object_truth(const ObjectState& s) override {
    if (dataset_) dataset_->on_object_truth(s);
    objects.push_back(s);
  }
  std::vector<OdometrySample> body;
  std::vector<ObjectState> objects;

 private:
  Perception& perception_;
  sim::DatasetSink* dataset_;
};

}  // namespace

ClosedLoopFlight fly_with_perception(const sim::ScenarioConfig& config, const PerceptionOptions& options,
                                     const std::string& dataset_dir, const std::string& run_dir) {
  ClosedLoopFlight out;
  sim::Simulator simulator(config);
  std::vector<DodgeDecision> pending;
  PerceptionCallbacks also;
  also.on_window = [&](const WindowResult& w) {
    out.windows.push_back(window_detections(w));
    out.window_total_ms.push_back(w.timings.total_ms);
  };
  also.on_dodge = [&](const DodgeDecision& d) { pending.push_back(d); };
  RunRecorder recorder(run_dir, also);
  std::optional<sim::DatasetSink> dataset;
  if (!dataset_dir.empty()) dataset.emplace(dataset_dir, simulator.calibration());
  Perception perception(simulator.calibration(), options, recorder.callbacks());
  LoopSink sink(perception, dataset ? &*dataset : nullptr);

  // The simulation waits for the pipeline: each chunk is processed before the next is rendered,
  // and the decisions it made are commanded before then.
  simulator.begin(sink, sim::Flight::kCommanded);
  auto command_pending = [&] {
    for (const DodgeDecision& d : pending) {
      out.decisions.push_back(d);
      for (const SetpointChange& c : setpoint_changes(d)) simulator.command(c.t, c.acceleration_W);
    }
    pending.clear();
  };
  while (simulator.step()) command_pending();
  perception.finish();
  command_pending();  // decisions on the last window come after the scene: nothing left to fly
  const sim::SimulationSummary summary = simulator.finish();
  out.flight = summary.flight;
  if (dataset) dataset->finish(simulator.manifest_yaml());

  RunSummary run;
  run.input = dataset_dir.empty() ? "closed loop (not written)" : dataset_dir;
  run.format = "fdv_dataset";
  run.width = config.event_camera.width;
  run.height = config.event_camera.height;
  run.calibration = "from the simulation";
  run.method_requested = run.method = to_string(options.compensation.method);
  run.threads = options.threads;
  run.counts = perception.counters();
  run.options = to_json(options);
  run.detector_in_use = detector_in_use(options, simulator.calibration().event_camera);
  recorder.finish(std::move(run));

  out.truth = truth_frame(config);
  out.truth.body = std::move(sink.body);
  out.truth.objects = std::move(sink.objects);
  return out;
}

ClosedLoopFlight fly_oracle(const sim::ScenarioConfig& config, const DatasetTruth& truth, int ball,
                            std::span<const TimeNs> window_ends, std::optional<TimeNs> start,
                            const PerceptionOptions& options) {
  ClosedLoopFlight out;
  const sim::VehicleTrajectory path(config.vehicle, config.seed, config.gravity_W_m_s2);
  sim::FlownVehicle vehicle(path, config.vehicle.response, config.gravity_W_m_s2);
  DodgePlanner planner(options.dodge, options.prediction.safety_radius_m);
  for (TimeNs t : window_ends) {
    if (!start || t < *start) continue;
    vehicle.advance_to(to_seconds(t));
    const OdometrySample body = sim::to_pose_sample(t, vehicle.at(to_seconds(t)));
    if (auto d = decide_on_truth(planner, truth, ball, t, body, options.prediction)) {
      out.decisions.push_back(*d);
      for (const SetpointChange& c : setpoint_changes(*d)) vehicle.command(c.t, c.acceleration_W);
    }
  }
  out.truth = truth_frame(config);
  out.truth.body = sample_body(config, vehicle);
  out.truth.objects = truth.objects;
  out.flight = vehicle.counters();
  return out;
}

std::optional<DodgeDecision> decide_on_truth(DodgePlanner& planner, const DatasetTruth& truth, int ball, TimeNs t,
                                             const OdometrySample& body, const PredictionOptions& prediction) {
  const auto object = truth.object_at(ball, t);
  if (!object) return std::nullopt;
  TrajectoryEstimate exact;
  exact.usable = exact.converged = true;
  exact.method = EstimateMethod::kFusion;
  exact.trajectory = BallisticTrajectory{t, object->p_W, object->v_W, truth.gravity_W};
  exact.covariance = Eigen::Matrix<double, 6, 6>::Zero();
  exact.t_first = exact.t_last = t;
  const VehicleState vehicle{body, Eigen::Matrix<double, 6, 6>::Zero()};
  const RiskAssessment r = assess_collision_risk(exact, vehicle, prediction);
  if (!r.risk) return std::nullopt;
  return planner.update(ball, *r.risk, vehicle);
}

DatasetTruth fly_decisions(const sim::ScenarioConfig& config, const DatasetTruth& truth,
                           const std::vector<DodgeDecision>& decisions, sim::FlightCounters* counters) {
  const sim::VehicleTrajectory path(config.vehicle, config.seed, config.gravity_W_m_s2);
  sim::FlownVehicle vehicle(path, config.vehicle.response, config.gravity_W_m_s2);
  for (const SetpointChange& c : setpoint_schedule(decisions)) vehicle.command(c.t, c.acceleration_W);
  DatasetTruth out = truth_frame(config);
  out.body = sample_body(config, vehicle);
  out.objects = truth.objects;
  if (counters) *counters = vehicle.counters();
  return out;
}

ManeuverPerception maneuver_perception(const DatasetTruth& flown, int ball, const std::vector<WindowDetections>& windows,
                                       TimeNs decision_t) {
  ManeuverPerception out;
  const auto closest = true_closest_approach(flown, ball);
  if (!closest) return out;
  const DetectionMetrics m = detection_metrics(flown, windows);
  std::map<int, std::size_t> by_track;
  for (const PairOutcome& p : m.per_pair) {
    if (p.ball != ball || p.fills_view || p.t_end <= decision_t || p.t_end > closest->t) continue;
    ++out.eligible;
    out.found += p.found;
    if (p.found && p.track >= 0) ++by_track[p.track];
  }
  if (out.eligible == 0) return out;
  std::size_t most = 0;
  for (const auto& [track, n] : by_track) most = std::max(most, n);
  out.track_survived = static_cast<double>(most) >= 0.9 * static_cast<double>(out.eligible);
  return out;
}

}  // namespace fdv
