#include "fdv/sim/simulator.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cmath>
#include <optional>

#include "fdv/core/error.h"
#include "fdv/core/thread_pool.h"
#include "fdv/sim/event_camera.h"
#include "fdv/sim/random_throw.h"
#include "fdv/sim/scene.h"
#include "fdv/sim/sensor_models.h"

namespace fdv::sim {
namespace {

void emit_vector(YAML::Emitter& out, const Eigen::Vector3d& v) {
  out << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < 3; ++i) out << fmt::format("{}", v[i]);
  out << YAML::EndSeq;
}

}  // namespace

std::string SimulationSummary::brief() const {
  const double rate = simulated_s > 0 ? static_cast<double>(events) / simulated_s : 0.0;
  return fmt::format(
      "{} events ({:.3g} Mev/s; object {}, scene {}, noise {}, hot {}) over {:.3f} s "
      "simulated in {:.2f} s wall ({:.3f}x real time)",
      events, rate * 1e-6, events_object, events_scene, events_noise, events_hot, simulated_s,
      wall_s, wall_s > 0 ? simulated_s / wall_s : 0.0);
}

Simulator::Simulator(ScenarioConfig config) : config_(std::move(config)) {
  if (const auto why = config_.validate(); !why.empty()) throw ConfigError(why);
  calib_ = config_.calibration();
  vehicle_ =
      std::make_unique<VehicleTrajectory>(config_.vehicle, config_.seed, config_.gravity_W_m_s2);
  for (const auto& b : config_.balls)
    balls_.emplace_back(b, *vehicle_, config_.gravity_W_m_s2, config_.duration_s + 0.1);
  // The renderer casts rays from inside the room: the vehicle and its cameras must stay in it.
  const int n = std::max(2, static_cast<int>(std::ceil(config_.duration_s / 0.005)));
  for (int i = 0; i <= n; ++i) {
    const double t = config_.duration_s * i / n;
    check_in_room(vehicle_->at(t), t);
  }
}

void Simulator::check_in_room(const BodyState& s, double t_s) const {
  const Eigen::Vector3d lo = config_.scene.room_min_W_m, hi = config_.scene.room_max_W_m;
  const Eigen::Vector3d points_B[3] = {Eigen::Vector3d::Zero(), calib_.T_B_E.translation(),
                                       calib_.T_B_D.translation()};
  for (const Eigen::Vector3d& p_B : points_B) {
    const Eigen::Vector3d p = s.p_W + s.R_W_B * p_B;
    if ((p - lo).minCoeff() < 0.05 || (hi - p).minCoeff() < 0.05)
      throw ConfigError(fmt::format(
          "vehicle: leaves the room at t = {:.3f} s (position [{:.2f}, {:.2f}, {:.2f}]); enlarge "
          "scene.room_min_W_m / room_max_W_m, move vehicle.start_W_m or shorten duration_s",
          t_s, p.x(), p.y(), p.z()));
  }
}

std::vector<ResolvedBall> Simulator::resolved_balls() const {
  std::vector<ResolvedBall> out;
  for (const auto& b : balls_)
    out.push_back({b.config().id, b.config().radius_m, b.config().release_t_s, b.origin_W(),
                   b.release_velocity_W()});
  return out;
}

/// Everything a run keeps between steps. Members are declared in the order they depend on one
/// another (the camera and the depth model hold references to the scene, vehicle and pool).
struct Simulator::Running {
  /// Sample times k / rate, k = 0, 1, ... (rounded to the nanosecond).
  struct SampleClock {
    double rate_hz;
    std::uint64_t k = 0;
    TimeNs next() const { return std::llround(static_cast<double>(k) * 1e9 / rate_hz); }
  };

  Running(const ScenarioConfig& config, const Calibration& calib, const VehicleTrajectory& path,
          const std::vector<BallTrajectory>& balls, SimulationSink& out, Flight flown)
      : flight(flown),
        sink(out),
        pool(config.threads),
        scene(config.scene, config.balls, config.seed),
        vehicle(path, config.vehicle.response, config.gravity_W_m_s2, config.scene.room()),
        camera(config, calib, scene, vehicle, balls, pool),
        imu(config.imu, calib.R_B_I, config.gravity_W_m_s2, config.seed),
        odometry(config.odometry, config.seed),
        t_end(from_seconds(config.duration_s)),
        chunk(from_seconds(config.event_camera.chunk_s)),
        imu_clock{config.imu.rate_hz},
        odo_clock{config.odometry.rate_hz},
        truth_clock{config.truth.rate_hz},
        depth_clock{config.depth_camera.rate_hz} {
    if (config.depth_camera.enabled) depth.emplace(config.depth_camera, calib, scene, config.seed, pool);
    for (const auto& b : balls) radii.push_back(b.config().radius_m);
  }

  /// A fork of `state`, reading the forked simulator's own configuration, path and balls.
  Running(const Running& state, const ScenarioConfig& config, const VehicleTrajectory& path,
          const std::vector<BallTrajectory>& balls, SimulationSink& out)
      : flight(state.flight),
        sink(out),
        wall0(state.wall0),
        pool(config.threads),
        scene(state.scene),
        vehicle(state.vehicle, path),
        camera(state.camera, config, scene, vehicle, balls, pool),
        imu(state.imu),
        odometry(state.odometry),
        radii(state.radii),
        summary(state.summary),
        t_end(state.t_end),
        chunk(state.chunk),
        t_done(state.t_done),
        imu_clock(state.imu_clock),
        odo_clock(state.odo_clock),
        truth_clock(state.truth_clock),
        depth_clock(state.depth_clock) {
    if (state.depth) depth.emplace(*state.depth, scene, pool);
  }

  Flight flight;
  SimulationSink& sink;
  std::chrono::steady_clock::time_point wall0 = std::chrono::steady_clock::now();
  ThreadPool pool;
  Scene scene;
  FlownVehicle vehicle;
  EventCameraSim camera;
  ImuModel imu;
  OdometryModel odometry;
  std::optional<DepthModel> depth;
  std::vector<double> radii;
  SimulationSummary summary;
  TimeNs t_end, chunk;
  TimeNs t_done = 0;  ///< every stream is rendered up to here
  SampleClock imu_clock, odo_clock, truth_clock, depth_clock;
  std::vector<Event> events;
  std::vector<std::int16_t> labels;
};

Simulator::Simulator(const Simulator& running, SimulationSink& sink)
    : config_(running.config_),
      calib_(running.calib_),
      vehicle_(std::make_unique<VehicleTrajectory>(*running.vehicle_)),
      balls_(running.balls_) {
  if (!running.running_) throw ConfigError("simulator: a fork needs a run begun with begin()");
  running_ = std::make_unique<Running>(*running.running_, config_, *vehicle_, balls_, sink);
}

Simulator::~Simulator() = default;

SimulationSummary Simulator::run(SimulationSink& sink) {
  begin(sink);
  while (step()) {
  }
  return finish();
}

void Simulator::begin(SimulationSink& sink, Flight flight) {
  if (running_) throw ConfigError("simulator: begin() while a run is going on (finish() it first)");
  running_ = std::make_unique<Running>(config_, calib_, *vehicle_, balls_, sink, flight);
  running_->summary.balls = resolved_balls();
  running_->camera.initialize(0);
  emit_streams_until(0);
}

void Simulator::emit_streams_until(TimeNs t_hi) {
  Running& r = *running_;
  auto& summary = r.summary;
  auto& sink = r.sink;
  const TimeNs t_end = r.t_end;
  for (TimeNs t; (t = r.imu_clock.next()) <= t_hi && t <= t_end; ++r.imu_clock.k, ++summary.imu)
    sink.on_imu(r.imu.sample(t, r.vehicle.at(to_seconds(t))));
  for (TimeNs t; (t = r.odo_clock.next()) <= t_hi && t <= t_end; ++r.odo_clock.k, ++summary.odometry)
    sink.on_odometry(r.odometry.sample(t, r.vehicle.at(to_seconds(t))));
  for (TimeNs t; (t = r.truth_clock.next()) <= t_hi && t <= t_end; ++r.truth_clock.k, ++summary.truth) {
    sink.on_body_truth(to_pose_sample(t, r.vehicle.at(to_seconds(t))));
    if (r.flight == Flight::kCommanded) sink.on_unflown_body_truth(to_pose_sample(t, r.vehicle.unflown_at(to_seconds(t))));
    for (const auto& b : balls_) {
      const BallState bs = b.at(to_seconds(t));
      if (bs.exists) sink.on_object_truth({t, b.config().id, bs.p_W, bs.v_W});
    }
  }
  if (r.depth)
    for (TimeNs t; (t = r.depth_clock.next()) <= t_hi && t <= t_end; ++r.depth_clock.k, ++summary.depth) {
      std::vector<BallState> states;
      for (const auto& b : balls_) states.push_back(b.at(to_seconds(t)));
      sink.on_depth(r.depth->render(t, r.vehicle.at(to_seconds(t)), states, r.radii, r.depth_clock.k));
    }
}

bool Simulator::step() {
  if (!running_) throw ConfigError("simulator: step() before begin()");
  Running& r = *running_;
  if (r.t_done >= r.t_end) return false;
  const TimeNs t0 = r.t_done, t1 = std::min(t0 + r.chunk, r.t_end);
  r.vehicle.advance_to(to_seconds(t1));
  if (r.vehicle.deviates_at(to_seconds(t1))) check_in_room(r.vehicle.at(to_seconds(t1)), to_seconds(t1));
  emit_streams_until(t1);
  r.events.clear();
  r.labels.clear();
  r.camera.run_chunk(t0, t1, r.events, r.labels);
  auto& summary = r.summary;
  for (std::size_t i = 0; i < r.events.size(); ++i) {
    summary.events_on += r.events[i].polarity;
    const std::int16_t l = r.labels[i];
    if (l > 0)
      ++summary.events_object;
    else if (l == kLabelScene)
      ++summary.events_scene;
    else if (l == kLabelNoise)
      ++summary.events_noise;
    else
      ++summary.events_hot;
  }
  summary.events += r.events.size();
  r.sink.on_events(r.events, r.labels);
  r.t_done = t1;
  return true;
}

TimeNs Simulator::simulated_until() const { return running_ ? running_->t_done : 0; }

void Simulator::command(TimeNs t, const Eigen::Vector3d& a_W) {
  if (!running_ || running_->flight != Flight::kCommanded)
    throw ConfigError("simulator: command() needs a run begun with Flight::kCommanded");
  running_->vehicle.command(t, a_W);
}

SimulationSummary Simulator::finish() {
  if (!running_) throw ConfigError("simulator: finish() before begin()");
  Running& r = *running_;
  const auto& st = r.camera.stats();
  SimulationSummary summary = std::move(r.summary);
  summary.simulated_s = to_seconds(r.t_done);
  summary.pixel_samples = st.pixel_samples;
  summary.mean_sample_rate_hz =
      summary.simulated_s > 0
          ? static_cast<double>(st.pixel_samples) / (static_cast<double>(calib_.event_camera.width) *
                                                     calib_.event_camera.height * summary.simulated_s)
          : 0.0;
  summary.max_tile_steps = st.max_tile_steps;
  summary.capped_tiles = st.capped_tiles;
  summary.flight = r.vehicle.counters();
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - r.wall0).count();
  running_.reset();
  return summary;
}

std::string Simulator::manifest_yaml() const {
  const auto& c = config_;
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "scenario" << YAML::Value << c.name;
  out << YAML::Key << "seed" << YAML::Value << c.seed;
  out << YAML::Key << "duration_s" << YAML::Value << fmt::format("{}", c.duration_s);
  out << YAML::Key << "gravity_W" << YAML::Value;
  emit_vector(out, c.gravity_W_m_s2);
  out << YAML::Key << "balls" << YAML::Value << YAML::BeginSeq;
  for (const auto& b : resolved_balls()) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << b.id;
    out << YAML::Key << "radius_m" << YAML::Value << fmt::format("{}", b.radius_m);
    out << YAML::Key << "release_t_s" << YAML::Value << fmt::format("{}", b.release_t_s);
    out << YAML::Key << "origin_W" << YAML::Value;
    emit_vector(out, b.origin_W);
    out << YAML::Key << "velocity_W" << YAML::Value;
    emit_vector(out, b.velocity_W);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "event_labels" << YAML::Value << kLabelsFile;
  if (const auto drawn = random_throw_manifest(c))  // the random throw's drawn parameters
    out << YAML::Key << "random_throw" << YAML::Value << *drawn;
  // The full configuration, less the thread count (which never changes the output).
  YAML::Node full = YAML::Load(to_yaml(c));
  full.remove("threads");
  out << YAML::Key << "simulator_config" << YAML::Value << full;
  out << YAML::EndMap;
  return out.c_str();
}

}  // namespace fdv::sim
