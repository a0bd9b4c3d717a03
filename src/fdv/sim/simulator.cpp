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

/// Sample times k / rate, k = 0, 1, ... (rounded to the nanosecond).
struct SampleClock {
  double rate_hz;
  std::uint64_t k = 0;
  TimeNs next() const { return std::llround(static_cast<double>(k) * 1e9 / rate_hz); }
};

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
  const Eigen::Vector3d lo = config_.scene.room_min_W_m, hi = config_.scene.room_max_W_m;
  const int n = std::max(2, static_cast<int>(std::ceil(config_.duration_s / 0.005)));
  for (int i = 0; i <= n; ++i) {
    const double t = config_.duration_s * i / n;
    const BodyState s = vehicle_->at(t);
    const Eigen::Vector3d points_B[3] = {Eigen::Vector3d::Zero(), calib_.T_B_E.translation(),
                                         calib_.T_B_D.translation()};
    for (const Eigen::Vector3d& p_B : points_B) {
      const Eigen::Vector3d p = s.p_W + s.R_W_B * p_B;
      if ((p - lo).minCoeff() < 0.05 || (hi - p).minCoeff() < 0.05)
        throw ConfigError(fmt::format(
            "vehicle: leaves the room at t = {:.3f} s (position [{:.2f}, {:.2f}, {:.2f}]); enlarge "
            "scene.room_min_W_m / room_max_W_m, move vehicle.start_W_m or shorten duration_s",
            t, p.x(), p.y(), p.z()));
    }
  }
}

Simulator::~Simulator() = default;

std::vector<ResolvedBall> Simulator::resolved_balls() const {
  std::vector<ResolvedBall> out;
  for (const auto& b : balls_)
    out.push_back({b.config().id, b.config().radius_m, b.config().release_t_s, b.origin_W(),
                   b.release_velocity_W()});
  return out;
}

SimulationSummary Simulator::run(SimulationSink& sink) {
  const auto wall0 = std::chrono::steady_clock::now();
  ThreadPool pool(config_.threads);
  Scene scene(config_.scene, config_.balls, config_.seed);
  EventCameraSim camera(config_, calib_, scene, *vehicle_, balls_, pool);
  ImuModel imu(config_.imu, calib_.R_B_I, config_.gravity_W_m_s2, config_.seed);
  OdometryModel odometry(config_.odometry, config_.seed);
  std::optional<DepthModel> depth;
  if (config_.depth_camera.enabled)
    depth.emplace(config_.depth_camera, calib_, scene, config_.seed, pool);
  std::vector<double> radii;
  for (const auto& b : balls_) radii.push_back(b.config().radius_m);

  SimulationSummary summary;
  summary.balls = resolved_balls();
  const TimeNs t_end = from_seconds(config_.duration_s);
  const TimeNs chunk = from_seconds(config_.event_camera.chunk_s);
  SampleClock imu_clock{config_.imu.rate_hz}, odo_clock{config_.odometry.rate_hz};
  SampleClock truth_clock{config_.truth.rate_hz}, depth_clock{config_.depth_camera.rate_hz};

  auto emit_until = [&](TimeNs t_hi) {
    for (TimeNs t; (t = imu_clock.next()) <= t_hi && t <= t_end; ++imu_clock.k, ++summary.imu)
      sink.on_imu(imu.sample(t, vehicle_->at(to_seconds(t))));
    for (TimeNs t; (t = odo_clock.next()) <= t_hi && t <= t_end; ++odo_clock.k, ++summary.odometry)
      sink.on_odometry(odometry.sample(t, vehicle_->at(to_seconds(t))));
    for (TimeNs t; (t = truth_clock.next()) <= t_hi && t <= t_end;
         ++truth_clock.k, ++summary.truth) {
      const BodyState s = vehicle_->at(to_seconds(t));
      OdometrySample body;
      body.t = t;
      body.p_W_B = s.p_W;
      body.q_W_B = Eigen::Quaterniond(s.R_W_B).normalized();
      body.v_W = s.v_W;
      body.omega_B = s.omega_B;
      sink.on_body_truth(body);
      for (const auto& b : balls_) {
        const BallState bs = b.at(to_seconds(t));
        if (bs.exists) sink.on_object_truth({t, b.config().id, bs.p_W, bs.v_W});
      }
    }
    if (depth)
      for (TimeNs t; (t = depth_clock.next()) <= t_hi && t <= t_end;
           ++depth_clock.k, ++summary.depth) {
        std::vector<BallState> states;
        for (const auto& b : balls_) states.push_back(b.at(to_seconds(t)));
        sink.on_depth(depth->render(t, vehicle_->at(to_seconds(t)), states, radii, depth_clock.k));
      }
  };

  camera.initialize(0);
  emit_until(0);
  std::vector<Event> events;
  std::vector<std::int16_t> labels;
  for (TimeNs t0 = 0; t0 < t_end; t0 += chunk) {
    const TimeNs t1 = std::min(t0 + chunk, t_end);
    emit_until(t1);
    events.clear();
    labels.clear();
    camera.run_chunk(t0, t1, events, labels);
    for (std::size_t i = 0; i < events.size(); ++i) {
      summary.events_on += events[i].polarity;
      const std::int16_t l = labels[i];
      if (l > 0)
        ++summary.events_object;
      else if (l == kLabelScene)
        ++summary.events_scene;
      else if (l == kLabelNoise)
        ++summary.events_noise;
      else
        ++summary.events_hot;
    }
    summary.events += events.size();
    sink.on_events(events, labels);
  }

  const auto& st = camera.stats();
  summary.simulated_s = to_seconds(t_end);
  summary.pixel_samples = st.pixel_samples;
  summary.mean_sample_rate_hz =
      static_cast<double>(st.pixel_samples) / (static_cast<double>(calib_.event_camera.width) *
                                               calib_.event_camera.height * summary.simulated_s);
  summary.max_tile_steps = st.max_tile_steps;
  summary.capped_tiles = st.capped_tiles;
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
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
