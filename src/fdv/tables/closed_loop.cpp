#include "fdv/tables/closed_loop.h"

#include <algorithm>
#include <map>
#include <memory>

#include "fdv/avoidance/maneuver_playback.h"
#include "fdv/estimation/collision_risk.h"
#include "fdv/io/dataset/dataset_writer.h"
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
/// dataset written. The pipeline gets the streams as the dataset stores them (as_stored: rounded
/// text, millimetre depth), written or not, so that a run on the dataset gives the loop's results
/// and the loop's pipeline sees what the open loop's does.
class LoopSink : public sim::SimulationSink {
 public:
  LoopSink(Perception& perception, sim::DatasetSink* dataset) : perception_(perception), dataset_(dataset) {}
  void on_events(std::span<const Event> events, std::span<const std::int16_t> labels) override {
    if (dataset_) dataset_->on_events(events, labels);
    perception_.push_events(events);
  }
  void on_imu(const ImuSample& s) override {
    if (dataset_) dataset_->on_imu(s);
    if (const auto stored = as_stored(s)) perception_.push_imu(*stored);
  }
  void on_depth(const DepthFrame& f) override {
    if (dataset_) dataset_->on_depth(f);
    perception_.push_depth(as_stored(f));
  }
  void on_odometry(const OdometrySample& s) override {
    if (dataset_) dataset_->on_odometry(s);
    if (const auto stored = as_stored(s)) perception_.push_odometry(*stored);
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

/// Forwards every stream to each of the sinks it holds (the methods that ride one simulation), and
/// to `open_loop` all but the unflown path (in the open loop the flown path is the path).
class FanOutSink : public sim::SimulationSink {
 public:
  std::vector<sim::SimulationSink*> sinks;
  sim::SimulationSink* open_loop = nullptr;

  void on_events(std::span<const Event> events, std::span<const std::int16_t> labels) override {
    each([&](sim::SimulationSink& s) { s.on_events(events, labels); });
  }
  void on_imu(const ImuSample& x) override {
    each([&](sim::SimulationSink& s) { s.on_imu(x); });
  }
  void on_depth(const DepthFrame& x) override {
    each([&](sim::SimulationSink& s) { s.on_depth(x); });
  }
  void on_odometry(const OdometrySample& x) override {
    each([&](sim::SimulationSink& s) { s.on_odometry(x); });
  }
  void on_body_truth(const OdometrySample& x) override {
    each([&](sim::SimulationSink& s) { s.on_body_truth(x); });
  }
  void on_unflown_body_truth(const OdometrySample& x) override {
    for (auto* s : sinks) s->on_unflown_body_truth(x);
  }
  void on_object_truth(const ObjectState& x) override {
    each([&](sim::SimulationSink& s) { s.on_object_truth(x); });
  }

 private:
  template <class Call>
  void each(Call call) {
    for (auto* s : sinks) call(*s);
    if (open_loop) call(*open_loop);
  }
};

/// One method in the loop: its pipeline fed by the simulator it rides, the decisions it has made
/// and not yet flown, and what it keeps.
class MethodInLoop {
 public:
  MethodInLoop(const sim::Simulator& simulator, const PerceptionOptions& options,
               const FlightOutputs& outputs)
      : options_(options), outputs_(outputs), recorder_(outputs.run_dir, record_also()) {
    if (!outputs.dataset_dir.empty())
      dataset_.emplace(outputs.dataset_dir, simulator.calibration());
    perception_.emplace(simulator.calibration(), options, recorder_.callbacks());
    sink_.emplace(*perception_, dataset_ ? &*dataset_ : nullptr);
  }

  sim::SimulationSink& sink() { return *sink_; }
  /// Whether a decision not yet flown changes the set-point.
  bool has_setpoints() const {
    return std::any_of(pending_.begin(), pending_.end(),
                       [](const DodgeDecision& d) { return !setpoint_changes(d).empty(); });
  }
  /// The decisions made since the last call, flown by `simulator`.
  void command_pending(sim::Simulator& simulator) {
    for (const DodgeDecision& d : pending_) {
      out_.decisions.push_back(d);
      for (const SetpointChange& c : setpoint_changes(d)) simulator.command(c.t, c.acceleration_W);
    }
    pending_.clear();
  }
  /// The rest of the scene on `simulator`, which this method now flies alone.
  void fly_on(sim::Simulator& simulator) {
    command_pending(simulator);
    while (simulator.step()) command_pending(simulator);
  }
  /// After the scene: the pipeline's last windows, the results written, the flight.
  ClosedLoopFlight finish(const sim::ScenarioConfig& config, sim::Simulator& simulator) {
    perception_->finish();
    // Decisions on the last window come after the scene: nothing is left to fly.
    command_pending(simulator);
    out_.flight = simulator.finish().flight;
    if (dataset_) dataset_->finish(simulator.manifest_yaml());

    RunSummary run;
    run.input = outputs_.dataset_dir.empty() ? "closed loop (not written)" : outputs_.dataset_dir;
    run.format = "fdv_dataset";
    run.width = config.event_camera.width;
    run.height = config.event_camera.height;
    run.calibration = "from the simulation";
    run.method_requested = run.method = to_string(options_.compensation.method);
    run.threads = options_.threads;
    run.counts = perception_->counters();
    run.options = to_json(options_);
    run.detector_in_use = detector_in_use(options_, simulator.calibration().event_camera);
    recorder_.finish(std::move(run));

    out_.truth = truth_frame(config);
    out_.truth.body = std::move(sink_->body);
    out_.truth.objects = std::move(sink_->objects);
    return std::move(out_);
  }

 private:
  PerceptionCallbacks record_also() {
    PerceptionCallbacks also;
    also.on_window = [this](const WindowResult& w) {
      out_.windows.push_back(window_detections(w));
      out_.window_total_ms.push_back(w.timings.total_ms);
    };
    also.on_dodge = [this](const DodgeDecision& d) { pending_.push_back(d); };
    return also;
  }

  PerceptionOptions options_;
  FlightOutputs outputs_;
  ClosedLoopFlight out_;
  std::vector<DodgeDecision> pending_;
  RunRecorder recorder_;
  std::optional<sim::DatasetSink> dataset_;
  std::optional<Perception> perception_;
  std::optional<LoopSink> sink_;
};

}  // namespace

std::map<std::string, ClosedLoopFlight> fly_with_perceptions(
    const sim::ScenarioConfig& config, const std::map<std::string, PerceptionOptions>& methods,
    const std::map<std::string, FlightOutputs>& outputs, sim::SimulationSink* open_loop) {
  sim::Simulator shared(config);
  std::map<std::string, std::unique_ptr<MethodInLoop>> riding;  // the methods on `shared`
  for (const auto& [name, options] : methods) {
    const auto kept = outputs.find(name);
    riding[name] = std::make_unique<MethodInLoop>(
        shared, options, kept == outputs.end() ? FlightOutputs{} : kept->second);
  }
  FanOutSink fan_out;
  fan_out.open_loop = open_loop;
  // With the open loop riding too, the shared simulation is never commanded: every method forks.
  auto alone = [&] { return riding.size() == 1 && !open_loop; };
  auto ride = [&] {
    fan_out.sinks.clear();
    for (auto& [name, method] : riding) fan_out.sinks.push_back(&method->sink());
  };
  ride();

  // The simulation waits for the pipelines: each chunk is processed before the next is rendered,
  // and the decisions made on it are commanded before then. A method's first set-point forks the
  // simulation for it, unless nothing else rides it; the fork flies to the scene's end at once.
  std::map<std::string, ClosedLoopFlight> flights;
  shared.begin(fan_out, sim::Flight::kCommanded);
  while (shared.step()) {
    for (auto it = riding.begin(); it != riding.end();) {
      MethodInLoop& method = *it->second;
      if (!method.has_setpoints() || alone()) {
        method.command_pending(shared);
        ++it;
        continue;
      }
      sim::Simulator own(shared, method.sink());
      method.fly_on(own);
      flights[it->first] = method.finish(config, own);
      it = riding.erase(it);
      ride();
    }
  }
  // The methods that rode to the end: each finishes on a fork at the end (its last decisions
  // may command it), the last on the shared simulation itself unless the open loop rode it.
  while (!riding.empty()) {
    auto it = riding.begin();
    if (alone()) {
      flights[it->first] = it->second->finish(config, shared);
    } else {
      sim::Simulator own(shared, it->second->sink());
      flights[it->first] = it->second->finish(config, own);
    }
    riding.erase(it);
  }
  return flights;
}

ClosedLoopFlight fly_with_perception(const sim::ScenarioConfig& config,
                                     const PerceptionOptions& options,
                                     const std::string& dataset_dir, const std::string& run_dir) {
  return std::move(
      fly_with_perceptions(config, {{"", options}}, {{"", {dataset_dir, run_dir}}}).at(""));
}

ClosedLoopFlight fly_oracle(const sim::ScenarioConfig& config, const DatasetTruth& truth, int ball,
                            std::span<const TimeNs> window_ends, std::optional<TimeNs> start,
                            const PerceptionOptions& options) {
  ClosedLoopFlight out;
  const sim::VehicleTrajectory path(config.vehicle, config.seed, config.gravity_W_m_s2);
  sim::FlownVehicle vehicle(path, config.vehicle.response, config.gravity_W_m_s2, config.scene.room());
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
  sim::FlownVehicle vehicle(path, config.vehicle.response, config.gravity_W_m_s2, config.scene.room());
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
  out.track_recreated = by_track.size() > 1;
  return out;
}

}  // namespace fdv
