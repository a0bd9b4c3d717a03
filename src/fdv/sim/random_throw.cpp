// The random throws of the dodge evaluation (docs/SIMULATOR.md, "random_throw").
#include "fdv/sim/random_throw.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/sim/geometry.h"
#include "fdv/sim/preset_parts.h"
#include "fdv/sim/random.h"
#include "fdv/sim/trajectory.h"

namespace fdv::sim {
namespace {

constexpr double kReleaseT = 0.2;     ///< [s] as hover_headon: the scene settles first
constexpr double kAfterPassS = 0.3;   ///< [s] simulated after the closest approach
constexpr double kThreatMissM = 0.5;  ///< [m] the dodge evaluation's safety radius
constexpr double kHandMinZ = 0.5;  ///< [m] lowest release height above the floor (a thrower's hand)
constexpr double kContactM = 0.1;  ///< [m] ball surface to camera centre that counts as a hit
/// Samples per tile and 5 ms chunk at most (default 2000). Binds only where the ball covers the
/// lens, in the last tens of ms before it passes or hits, where it bounds the cost of a tile.
constexpr int kMaxStepsPerChunk = 400;
constexpr double kMinInViewFraction = 0.5;  ///< "in view for most of its flight"
constexpr int kMaxAttempts = 1000;          ///< draws before giving up (~7 % are redrawn)

struct Resolution {
  int width, height;
  const char* name;
};
/// The preset set: DVXplorer (default), DAVIS346, a 1280x720 sensor; all at the DVXplorer's
/// field of view (set_event_resolution). Drawn with these probabilities: a 1280x720 throw costs
/// ~6x a 640x480 one to simulate, and at 1/3 each 200 throws would not fit `fdv dodge-eval`'s
/// 45 minutes on two cores (docs/SIMULATOR.md, "random_throw").
constexpr Resolution kResolutions[] = {
    {640, 480, "640x480"}, {346, 260, "346x260"}, {1280, 720, "1280x720"}};
constexpr double kResolutionProbability[] = {0.45, 0.45, 0.10};

/// Everything but the ball and the panels: vehicle, camera, lighting.
ScenarioConfig base_config(const RandomThrowParameters& p) {
  ScenarioConfig c;
  c.name = "random_throw";
  c.seed = p.seed;
  auto& v = c.vehicle;
  v.start_W_m = {0.0, 0.0, 1.5};
  if (p.vehicle_motion == "forward") {
    v.motion = MotionKind::kForward;
    v.speed_m_s = p.vehicle_speed_m_s;
    v.nose_down_deg = 1.5 * p.vehicle_speed_m_s;  // fast_forward's 3 deg at 2 m/s
  } else {
    v.motion = MotionKind::kHover;
  }
  set_event_resolution(c, p.width, p.height);
  c.event_camera.max_steps_per_chunk = kMaxStepsPerChunk;
  c.scene.illuminance_lux = p.illuminance_lux;
  if (p.lighting == "dim") c.event_camera.background_rate_hz = 1.0;  // as the `dim` preset
  return c;
}

/// The release state that makes the ball pass the body origin at `miss` in direction `phi`
/// (0 left, π/2 up, about the relative velocity at the pass), thrown from P0 at t_r with chord
/// speed `speed`. At the closest-approach time t_c = t_r + T the ball is at p_B(t_c) + miss·ŵ
/// with ŵ ⟂ (v_ball − v_B)(t_c): then d|p_ball − p_B|²/dt = 0 there. The ballistic path through
/// P0 and that point in time T is v0 = (p_c − P0)/T − ½ g T; T (chord = speed·T) and ŵ (which
/// depends on the arrival velocity) are solved together by fixed-point iteration, which
/// contracts by |v_B| / speed ≤ 0.6 per step.
struct Solved {
  Eigen::Vector3d v0;
  double t_c = 0;
};
Solved solve_release(const VehicleTrajectory& vehicle, const Eigen::Vector3d& g,
                     const Eigen::Vector3d& p0, double t_r, double speed, double miss, double phi) {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d toward = (p0 - vehicle.at(t_r).p_W).normalized();  // from vehicle to ball
  double T = (p0 - vehicle.at(t_r).p_W).norm() / speed;
  Solved s;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d left = up.cross(toward).normalized();
    const Eigen::Vector3d w = std::cos(phi) * left + std::sin(phi) * toward.cross(left);
    const BodyState b = vehicle.at(t_r + T);
    const Eigen::Vector3d p_c = b.p_W + miss * w;
    const double T_next = (p_c - p0).norm() / speed;
    const Eigen::Vector3d v_c = (p_c - p0) / T_next + 0.5 * g * T_next;
    const Eigen::Vector3d toward_next = -(v_c - b.v_W).normalized();
    const bool done = std::abs(T_next - T) < 1e-12 && (toward_next - toward).norm() < 1e-12;
    T = T_next;
    toward = toward_next;
    s.v0 = v_c - g * T;
    s.t_c = t_r + T;
    if (done) break;
  }
  return s;
}

/// Share of [t_r, t_c] during which the ball's centre projects into the image (100 instants).
double in_view_fraction(const ScenarioConfig& c, const VehicleTrajectory& vehicle,
                        const RandomThrowParameters& p) {
  const Calibration calib = c.calibration();
  const double r_max = lens_monotonic_radius(calib.event_camera);
  const int n = 100;
  int in_view = 0;
  for (int i = 0; i < n; ++i) {
    const double tau = (i + 0.5) / n * (p.closest_approach_t_s - p.release_t_s);
    const Eigen::Vector3d ball =
        p.origin_W_m + p.velocity_W_m_s * tau + 0.5 * c.gravity_W_m_s2 * tau * tau;
    const BodyState b = vehicle.at(p.release_t_s + tau);
    const Eigen::Matrix3d R_W_E = b.R_W_B * calib.T_B_E.linear();
    const Eigen::Vector3d X =
        R_W_E.transpose() * (ball - (b.p_W + b.R_W_B * calib.T_B_E.translation()));
    if (X.z() <= 0 || X.head<2>().norm() / X.z() > r_max) continue;
    in_view += calib.event_camera.in_image(calib.event_camera.project(X)) ? 1 : 0;
  }
  return static_cast<double>(in_view) / n;
}

/// First time in [t_r, t_c] at which the ball's surface is within kContactM of the event
/// camera's centre (1 ms steps, then bisection to 0.01 ms); 0 when it never is.
double contact_time(const ScenarioConfig& c, const VehicleTrajectory& vehicle,
                    const RandomThrowParameters& p) {
  const auto clearance = [&](double t) {
    const double tau = t - p.release_t_s;
    const Eigen::Vector3d ball =
        p.origin_W_m + p.velocity_W_m_s * tau + 0.5 * c.gravity_W_m_s2 * tau * tau;
    const BodyState b = vehicle.at(t);
    return (ball - (b.p_W + b.R_W_B * c.event_camera.position_B_m)).norm() - 0.5 * p.diameter_m -
           kContactM;
  };
  for (double t = p.release_t_s; t < p.closest_approach_t_s + 1e-3; t += 1e-3) {
    if (clearance(t) > 0) continue;
    double lo = t - 1e-3, hi = t;
    while (hi - lo > 1e-5) {
      const double mid = 0.5 * (lo + hi);
      (clearance(mid) > 0 ? lo : hi) = mid;
    }
    return hi;
  }
  return 0;
}

/// One field list drives to_json, the JSON reader and the YAML reader.
template <class P, class F>
void visit_fields(P& p, F&& f) {
  f("seed", p.seed);
  f("speed_m_s", p.speed_m_s);
  f("distance_m", p.distance_m);
  f("miss_distance_m", p.miss_distance_m);
  f("threat", p.threat);
  f("offset_direction_deg", p.offset_direction_deg);
  f("release_azimuth_deg", p.release_azimuth_deg);
  f("release_elevation_deg", p.release_elevation_deg);
  f("release_t_s", p.release_t_s);
  f("closest_approach_t_s", p.closest_approach_t_s);
  f("in_view_fraction", p.in_view_fraction);
  f("draws", p.draws);
  f("contact_t_s", p.contact_t_s);
  f("origin_W_m", p.origin_W_m);
  f("velocity_W_m_s", p.velocity_W_m_s);
  f("diameter_m", p.diameter_m);
  f("vehicle_motion", p.vehicle_motion);
  f("vehicle_speed_m_s", p.vehicle_speed_m_s);
  f("lighting", p.lighting);
  f("illuminance_lux", p.illuminance_lux);
  f("texture", p.texture);
  f("resolution", p.resolution);
  f("width", p.width);
  f("height", p.height);
  f("duration_s", p.duration_s);
}

std::string type_name(const std::string&) { return "a string"; }
std::string type_name(bool) { return "true or false"; }
std::string type_name(const Eigen::Vector3d&) { return "a list of 3 numbers"; }
template <class T>
std::string type_name(const T&) {
  return std::is_integral_v<T> ? "an integer" : "a number";
}

}  // namespace

RandomThrowParameters sample_random_throw(std::uint64_t seed) {
  RandomThrowParameters p;
  p.seed = seed;
  Rng rng = Rng::stream(seed, RngStream::kScenario, 1);
  p.threat = rng.bernoulli(0.5);
  p.miss_distance_m = p.threat ? rng.uniform(0.0, kThreatMissM) : rng.uniform(kThreatMissM, 1.5);
  p.offset_direction_deg = rng.uniform(0.0, 360.0);
  p.diameter_m = rng.uniform(0.05, 0.20);
  const bool forward = rng.bernoulli(0.5);
  p.vehicle_motion = forward ? "forward" : "hover";
  p.vehicle_speed_m_s = forward ? rng.uniform(0.0, 3.0) : 0.0;
  const bool dim = rng.bernoulli(0.25);
  p.lighting = dim ? "dim" : "bright";
  p.illuminance_lux = dim ? rng.uniform(8.0, 10.0) : rng.uniform(240.0, 1100.0);
  p.texture = rng.bernoulli(0.5) ? "panels" : "bare";
  const double r = rng.uniform(0.0, 1.0);
  const Resolution& res = kResolutions[r < kResolutionProbability[0] ? 0
                                       : r < kResolutionProbability[0] + kResolutionProbability[1] ? 1
                                                                                                 : 2];
  p.resolution = res.name;
  p.width = res.width;
  p.height = res.height;
  p.release_t_s = kReleaseT;

  const ScenarioConfig c = base_config(p);
  const VehicleTrajectory vehicle(c.vehicle, c.seed, c.gravity_W_m_s2);
  const Eigen::Vector3d body = vehicle.at(p.release_t_s).p_W;
  // A slow throw from far must lob high and comes down on the vehicle from above the view: such
  // (speed, distance) pairs are drawn again (docs/SIMULATOR.md, "random_throw").
  for (int attempt = 0;; ++attempt) {
    if (attempt == kMaxAttempts)
      throw ConfigError(
          fmt::format("random_throw seed {}: no throw in view after {} draws", seed, kMaxAttempts));
    p.speed_m_s = rng.uniform(5.0, 15.0);
    p.distance_m = rng.uniform(4.0, 12.0);
    p.release_azimuth_deg = rng.uniform(-15.0, 15.0);
    const double elevation_jitter_deg = rng.uniform(-2.0, 2.0);
    // Seen from the vehicle, a throw that arrives after T rises in the view by g T² / (2 D) (in
    // tan of elevation) from release to arrival: release it below the axis by half of that, so
    // that the arc is centred, as far as the view (20° down) and the thrower's hand allow.
    const double az = p.release_azimuth_deg * kDegToRad;
    const double T = p.distance_m / (p.speed_m_s + p.vehicle_speed_m_s * std::cos(az));
    const double sweep = 9.81 * T * T / (2.0 * p.distance_m);
    const double lowest = std::max(
        -20.0 * kDegToRad, std::asin(std::max(-1.0, (kHandMinZ - body.z()) / p.distance_m)));
    const double el = std::max(std::atan(-0.5 * sweep) + elevation_jitter_deg * kDegToRad, lowest);
    p.release_elevation_deg = el / kDegToRad;
    const Eigen::Vector3d direction(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                    std::sin(el));
    p.origin_W_m = body + p.distance_m * direction;
    const Solved s =
        solve_release(vehicle, c.gravity_W_m_s2, p.origin_W_m, p.release_t_s, p.speed_m_s,
                      p.miss_distance_m, p.offset_direction_deg * kDegToRad);
    p.velocity_W_m_s = s.v0;
    p.closest_approach_t_s = s.t_c;
    p.in_view_fraction = in_view_fraction(c, vehicle, p);
    p.draws = attempt + 1;
    if (p.in_view_fraction >= kMinInViewFraction) break;
  }
  // A ball that hits the camera would be rendered from inside the lens, at the sampling cap in
  // every tile, for events no camera would give: the scene ends at the hit instead.
  p.contact_t_s = contact_time(c, vehicle, p);
  p.duration_s = p.contact_t_s > 0
                     ? std::floor(p.contact_t_s * 200.0) / 200.0
                     : std::ceil((p.closest_approach_t_s + kAfterPassS) * 20.0) / 20.0;
  return p;
}

ScenarioConfig random_throw_config(const RandomThrowParameters& p) {
  ScenarioConfig c = base_config(p);
  c.duration_s = p.duration_s;
  Rng rng = Rng::stream(p.seed, RngStream::kScenario, 2);
  BallConfig b;
  b.mode = "explicit";
  b.radius_m = 0.5 * p.diameter_m;
  b.release_t_s = p.release_t_s;
  b.speed_m_s = p.speed_m_s;
  b.origin_W_m = p.origin_W_m;
  b.velocity_W_m_s = p.velocity_W_m_s;
  b.spin_W_rad_s = random_spin(rng);
  b.hidden_before_release = false;  // held by the thrower, in view, until release
  c.balls = {b};
  if (p.texture == "panels") {
    const double beyond_thrower = p.origin_W_m.x() + 2.0;  // nothing between thrower and vehicle
    add_panels(c, rng, beyond_thrower, beyond_thrower);
  }
  return c;
}

nlohmann::json to_json(const RandomThrowParameters& p) {
  nlohmann::json j = nlohmann::json::object();
  visit_fields(p, [&](const char* key, const auto& value) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_same_v<T, Eigen::Vector3d>)
      j[key] = {value.x(), value.y(), value.z()};
    else
      j[key] = value;
  });
  return j;
}

RandomThrowParameters random_throw_from_json(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object()) throw InputError(source, "", "expected an object of random-throw parameters");
  RandomThrowParameters p;
  visit_fields(p, [&](const char* key, auto& value) {
    using T = std::decay_t<decltype(value)>;
    const auto it = j.find(key);
    if (it == j.end()) throw InputError(source, fmt::format("key {}", key), "missing");
    const auto wrong = [&] {
      return InputError(source, fmt::format("key {}", key),
                        fmt::format("expected {}, got {}", type_name(value), it->dump()));
    };
    if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      if (!it->is_array() || it->size() != 3) throw wrong();
      for (int i = 0; i < 3; ++i) {
        if (!(*it)[i].is_number()) throw wrong();
        value[i] = (*it)[i].template get<double>();
      }
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!it->is_string()) throw wrong();
      value = it->template get<std::string>();
    } else if constexpr (std::is_same_v<T, bool>) {
      if (!it->is_boolean()) throw wrong();
      value = it->template get<bool>();
    } else if constexpr (std::is_integral_v<T>) {
      if (!it->is_number_integer() || (std::is_unsigned_v<T> && !it->is_number_unsigned()))
        throw wrong();
      value = it->template get<T>();
    } else {
      if (!it->is_number()) throw wrong();
      value = it->template get<double>();
    }
  });
  return p;
}

YAML::Node random_throw_yaml(const RandomThrowParameters& p) {
  YAML::Node node(YAML::NodeType::Map);
  visit_fields(p, [&](const char* key, const auto& value) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      YAML::Node seq(YAML::NodeType::Sequence);
      for (int i = 0; i < 3; ++i) seq.push_back(fmt::format("{}", value[i]));
      seq.SetStyle(YAML::EmitterStyle::Flow);
      node[key] = seq;
    } else if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, bool>) {
      node[key] = value;
    } else {
      node[key] = fmt::format("{}", value);  // shortest text that reads back exactly
    }
  });
  return node;
}

namespace {

/// The inverse of random_throw_yaml; errors name the file and the key `prefix` + field.
RandomThrowParameters random_throw_from_yaml(const YAML::Node& node, const std::string& source,
                                             const std::string& prefix) {
  if (!node.IsMap())
    throw InputError(source, "key " + prefix, "expected a mapping of random-throw parameters");
  RandomThrowParameters p;
  visit_fields(p, [&](const char* key, auto& value) {
    using T = std::decay_t<decltype(value)>;
    const YAML::Node v = node[key];
    const std::string where = fmt::format("key {}.{}", prefix, key);
    if (!v) throw InputError(source, where, "missing");
    try {
      if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
        if (!v.IsSequence() || v.size() != 3) throw YAML::Exception(YAML::Mark(), "");
        for (int i = 0; i < 3; ++i) value[i] = v[i].as<double>();
      } else {
        value = v.as<T>();
      }
    } catch (const YAML::Exception&) {
      throw InputError(source, where, fmt::format("expected {}", type_name(value)));
    }
  });
  return p;
}

}  // namespace

std::optional<YAML::Node> random_throw_manifest(const ScenarioConfig& config) {
  if (config.name != "random_throw") return std::nullopt;
  const RandomThrowParameters p = sample_random_throw(config.seed);
  ScenarioConfig own = random_throw_config(p);
  own.threads = config.threads;  // never changes the output
  if (to_yaml(own) != to_yaml(config)) return std::nullopt;
  return random_throw_yaml(p);
}

std::optional<RandomThrowParameters> read_random_throw(const std::string& dataset_dir) {
  const std::string path = (std::filesystem::path(dataset_dir) / "dataset.yaml").string();
  const YAML::Node root = parse_config_yaml(read_config_file(path), path);
  if (!root.IsMap() || !root["random_throw"]) return std::nullopt;
  return random_throw_from_yaml(root["random_throw"], path, "random_throw");
}

}  // namespace fdv::sim
