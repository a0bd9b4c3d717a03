#pragma once
/// The event-camera scene simulator: exact motion, rendered events, IMU, depth, odometry and
/// ground truth, handed to a sink as they are produced.
///
///   ScenarioConfig config = make_preset("fast_forward", 1);
///   Simulator sim(config);                 // validates; resolves the throws
///   MemorySink sink;                       // or DatasetSink, or your own SimulationSink
///   SimulationSummary summary = sim.run(sink);
///
/// Streams are produced chunk by chunk (event_camera.chunk_s): for each chunk (t0, t1] the
/// sink gets the IMU, odometry, truth and depth samples with t in (t0, t1] (each stream in time
/// order; the samples at t = 0 come before the first chunk), then that chunk's events in one
/// batch, time-sorted, with one label each (event_labels.h). Same configuration (seed
/// included) => identical output for any thread count. run() is not reentrant; the sink is
/// called from the calling thread only.
///
/// Flying a manoeuvre (a closed loop): step chunk by chunk and command the vehicle in between.
///
///   sim.begin(sink, Flight::kCommanded);     // also emits the unflown path's truth
///   while (sim.step()) {                     // one more chunk, up to sim.simulated_until()
///     ... run perception on what the sink got; for a decision:
///     sim.command(effective_t, acceleration_W);   // from effective_t on (vehicle_dynamics.h)
///   }
///   SimulationSummary summary = sim.finish();
///
/// Without any command, a commanded run renders exactly what run() renders.
///
/// Forking a stepwise run: several manoeuvres from one simulated past.
///
///   sim::Simulator fork(sim, fork_sink);     // sim's run as it is now, streaming into fork_sink
///   fork.command(t, a_W);                    // only the fork flies it
///   while (fork.step()) { ... }              // renders what sim would have rendered after
///   fork.finish();                           // the same command; sim runs on untouched
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"
#include "fdv/sim/event_labels.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/trajectory.h"
#include "fdv/sim/vehicle_dynamics.h"

namespace fdv::sim {

/// Revision of what the simulator writes for a given configuration. Bump it with any code change
/// that alters its output (events, depth, IMU, odometry, truth), so that cached datasets
/// (sim::ensure_simulated) are simulated again instead of silently reused.
inline constexpr int kSimulatorRevision = 2;  // 2: spatially correlated depth noise

/// Receives the simulated streams. Every callback has an empty default.
class SimulationSink {
 public:
  virtual ~SimulationSink() = default;
  /// One time-sorted batch; labels[i] belongs to events[i].
  virtual void on_events(std::span<const Event> events, std::span<const std::int16_t> labels) {
    (void)events, (void)labels;
  }
  virtual void on_imu(const ImuSample& s) { (void)s; }
  virtual void on_depth(const DepthFrame& frame) { (void)frame; }
  virtual void on_odometry(const OdometrySample& s) { (void)s; }
  /// Exact vehicle motion (pose, velocity in W, body rate in B).
  virtual void on_body_truth(const OdometrySample& s) { (void)s; }
  /// Only under Flight::kCommanded: the path the vehicle would have flown without commands,
  /// at the same instants as on_body_truth.
  virtual void on_unflown_body_truth(const OdometrySample& s) { (void)s; }
  /// Exact ball centre and velocity in W.
  virtual void on_object_truth(const ObjectState& s) { (void)s; }
};

/// Keeps everything in memory (tests, benchmarks, small scenes).
class MemorySink : public SimulationSink {
 public:
  void on_events(std::span<const Event> batch,
                 std::span<const std::int16_t> batch_labels) override {
    events.insert(events.end(), batch.begin(), batch.end());
    labels.insert(labels.end(), batch_labels.begin(), batch_labels.end());
  }
  void on_imu(const ImuSample& s) override { imu.push_back(s); }
  void on_depth(const DepthFrame& f) override { depth.push_back(f); }
  void on_odometry(const OdometrySample& s) override { odometry.push_back(s); }
  void on_body_truth(const OdometrySample& s) override { body.push_back(s); }
  void on_unflown_body_truth(const OdometrySample& s) override { body_unflown.push_back(s); }
  void on_object_truth(const ObjectState& s) override { objects.push_back(s); }

  std::vector<Event> events;
  std::vector<std::int16_t> labels;
  std::vector<ImuSample> imu;
  std::vector<DepthFrame> depth;
  std::vector<OdometrySample> odometry, body, body_unflown;
  std::vector<ObjectState> objects;
};

struct ResolvedBall {
  int id = 0;
  double radius_m = 0;
  double release_t_s = 0;
  Eigen::Vector3d origin_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_W = Eigen::Vector3d::Zero();
};

struct SimulationSummary {
  std::uint64_t events = 0, events_on = 0;
  std::uint64_t events_scene = 0, events_object = 0, events_noise = 0, events_hot = 0;
  std::uint64_t imu = 0, odometry = 0, depth = 0, truth = 0;
  double simulated_s = 0;
  double wall_s = 0;
  std::uint64_t pixel_samples = 0;  ///< pixel renders of the event camera
  double mean_sample_rate_hz = 0;   ///< pixel renders per pixel per simulated second
  int max_tile_steps = 0;           ///< most samples of one tile in one chunk
  std::uint64_t capped_tiles = 0;   ///< tile-chunks limited by max_steps_per_chunk
  std::vector<ResolvedBall> balls;
  FlightCounters flight;  ///< what the vehicle model changed in the commands (Flight::kCommanded)
  /// One line: events, rate, speed.
  std::string brief() const;
};

/// kPath: the vehicle flies its configured path. kCommanded: it flies the commands given between
/// steps, and the unflown path's truth is emitted too.
enum class Flight { kPath, kCommanded };

class Simulator {
 public:
  /// Throws ConfigError ("key: reason") for an invalid configuration, a throw that cannot be
  /// solved, or a vehicle path that leaves the room.
  explicit Simulator(ScenarioConfig config);
  /// A fork of `running`'s stepwise run at its simulated_until(): a copy of its whole state (the
  /// vehicle's commands, every sensor's random streams, the counts so far), whose next chunks go
  /// to `sink`. The two then run independently; the fork's summary counts the whole run. Throws
  /// ConfigError when `running` has no run begun.
  Simulator(const Simulator& running, SimulationSink& sink);
  ~Simulator();
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  /// The whole scene at once: begin(sink), step() to the end, finish().
  SimulationSummary run(SimulationSink& sink);

  /// Starts a stepwise run: the samples at t = 0 go to `sink`, which must outlive finish().
  void begin(SimulationSink& sink, Flight flight = Flight::kPath);
  /// Renders the next chunk (every stream up to its end); false, rendering nothing, once the
  /// scene is over.
  bool step();
  /// The end of the last chunk rendered.
  TimeNs simulated_until() const;
  /// Under Flight::kCommanded: acceleration `a_W` on top of the path from `t` on (FlownVehicle::
  /// command). A command for a time already rendered takes effect at simulated_until(), counted.
  void command(TimeNs t, const Eigen::Vector3d& a_W);
  /// Ends the run begun by begin().
  SimulationSummary finish();

  const ScenarioConfig& config() const { return config_; }
  const Calibration& calibration() const { return calib_; }
  /// The configured path (what the vehicle flies without commands).
  const VehicleTrajectory& vehicle() const { return *vehicle_; }
  const std::vector<BallTrajectory>& balls() const { return balls_; }
  std::vector<ResolvedBall> resolved_balls() const;
  /// YAML mapping for the dataset manifest: scenario, seed, duration, gravity, balls (id,
  /// radius, release), the noise parameters, and the full configuration.
  std::string manifest_yaml() const;

 private:
  ScenarioConfig config_;
  Calibration calib_;
  std::unique_ptr<VehicleTrajectory> vehicle_;
  std::vector<BallTrajectory> balls_;
  /// Throws ConfigError when the body or a camera at state `s` is not inside the room.
  void check_in_room(const BodyState& s, double t_s) const;
  /// Hands `sink` the IMU, odometry, truth and depth samples up to `t_hi`.
  void emit_streams_until(TimeNs t_hi);
  struct Running;  ///< the state of a run between begin() and finish()
  std::unique_ptr<Running> running_;
};

}  // namespace fdv::sim
