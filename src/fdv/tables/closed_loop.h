#pragma once
/// A throw flown in a closed loop (`fdv dodge-eval --closed-loop`): the scene is simulated chunk
/// by chunk, a method decides on what its sensors see as it is rendered, and each decision is
/// flown by the simulator's vehicle model (sim/vehicle_dynamics.h), so the sensors see the
/// manoeuvre they caused (docs/AVOIDANCE.md, "Closed loop").
///
///   ClosedLoopFlight f = fly_with_perception(config, options);        // ours or a baseline
///   auto flights = fly_with_perceptions(config, {{"ours", a}, {"mono", b}});  // one simulation
///   ClosedLoopFlight o = fly_oracle(config, open_loop_truth, ball, window_ends, start, options);
///   DatasetTruth d = fly_decisions(config, open_loop_truth, open_loop_decisions);  // dynamics
///   only
///
/// A decision made on a window takes effect at the window's end plus the response delay (its
/// manoeuvre's start_t); the loop waits for the pipeline (the simulation does not run on while a
/// window is processed), and reports the pipeline's time per window to compare with that delay.
/// The oracles plan on the true ball and the flown vehicle state: they need the vehicle model
/// only, not the rendering. Several methods share one simulation until each first commands a
/// set-point, where the simulation is forked for it (sim::Simulator's fork): each flies exactly as
/// it would alone, and the part of the scene before the decisions is rendered once. Deterministic
/// for a configuration. Thread safety: each call owns its
/// state; calls may run on different threads.
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fdv/avoidance/dodge_planner.h"
#include "fdv/eval/dataset_truth.h"
#include "fdv/eval/detection_metrics.h"
#include "fdv/pipeline/perception.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/simulator.h"
#include "fdv/sim/vehicle_dynamics.h"

namespace fdv {

struct ClosedLoopFlight {
  std::vector<DodgeDecision> decisions;
  DatasetTruth truth;  ///< as flown: `body` is the flown path, `objects` the ball
  std::vector<WindowDetections> windows;  ///< a perception method's windows
  std::vector<double> window_total_ms;    ///< its pipeline time per window (wall clock)
  sim::FlightCounters flight;             ///< what the vehicle model changed in the commands
};

/// Simulates `config` with a live Perception (`options`) in the loop. `dataset_dir` / `run_dir`:
/// when not empty, the flown dataset and the run's results folder are written there.
ClosedLoopFlight fly_with_perception(const sim::ScenarioConfig& config, const PerceptionOptions& options,
                                     const std::string& dataset_dir = "", const std::string& run_dir = "");

/// Where a method's flight is written; an empty path: not written.
struct FlightOutputs {
  std::string dataset_dir;  ///< the flown dataset
  std::string run_dir;      ///< the run's results folder
};

/// Every method of `methods` (by name) in the loop, each flown exactly as fly_with_perception
/// flies it alone, from one simulation forked at each method's first set-point. `outputs`: where
/// a method's flight is written (a method without an entry: nowhere). `open_loop`, when given,
/// also gets the whole scene flown without any command: the open loop's streams (no unflown path),
/// as sim::Simulator::run gives them. Flights by method name.
std::map<std::string, ClosedLoopFlight> fly_with_perceptions(
    const sim::ScenarioConfig& config, const std::map<std::string, PerceptionOptions>& methods,
    const std::map<std::string, FlightOutputs>& outputs = {},
    sim::SimulationSink* open_loop = nullptr);

/// An oracle in the loop: at each of `window_ends` from `start` on, the planner gets ball `ball`'s
/// true state (from `truth`, which the vehicle does not change) and the flown vehicle state,
/// both exact. Nothing is decided without a start.
ClosedLoopFlight fly_oracle(const sim::ScenarioConfig& config, const DatasetTruth& truth, int ball,
                            std::span<const TimeNs> window_ends, std::optional<TimeNs> start,
                            const PerceptionOptions& options);

/// An oracle's decision at window end `t`: `planner` given ball `ball`'s true state at t (from
/// `truth`) and the vehicle state `body`, both exact (zero covariance); nothing when the ball is
/// unknown then, there is no risk, or the planner decides nothing.
std::optional<DodgeDecision> decide_on_truth(DodgePlanner& planner, const DatasetTruth& truth, int ball, TimeNs t,
                                             const OdometrySample& body, const PredictionOptions& prediction);

/// `decisions` (made open loop) flown through the vehicle model, nothing rendered again: the
/// truth with the flown body, to separate the dynamics' share of a closed-loop result.
DatasetTruth fly_decisions(const sim::ScenarioConfig& config, const DatasetTruth& truth,
                           const std::vector<DodgeDecision>& decisions, sim::FlightCounters* counters = nullptr);

/// What a manoeuvre did to perception: over the windows from the first kDodge decision to the
/// true closest approach in which ball `ball` is eligible (detection_metrics' any-size pairs).
struct ManeuverPerception {
  std::size_t eligible = 0, found = 0;
  /// The same track held the ball in at least 90 % of the eligible windows; nothing without any.
  /// Missed windows count against it as much as a second track does.
  std::optional<bool> track_survived;
  /// The ball's detections in those windows belong to more than one track: its track was lost
  /// (deleted or split) and a new one took the ball, with no 3D history; nothing without any.
  std::optional<bool> track_recreated;
};
ManeuverPerception maneuver_perception(const DatasetTruth& flown, int ball, const std::vector<WindowDetections>& windows,
                                       TimeNs decision_t);

}  // namespace fdv
