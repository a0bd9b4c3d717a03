#pragma once
/// The random throws of the dodge evaluation: one throw at the vehicle per seed, every parameter
/// drawn from the seed (docs/SIMULATOR.md, "random_throw", states the distribution).
///
///   RandomThrowParameters p = sample_random_throw(17);   // what seed 17 draws
///   ScenarioConfig c = make_preset("random_throw", 17);  // the same throw, ready to simulate
///   nlohmann::json row = to_json(p);                      // e.g. for a results table
///   auto q = read_random_throw(dataset_dir);              // back from a simulated dataset
///
/// `miss_distance_m` is the closest approach of the ball's centre to the body origin on its
/// scripted path (vibration and wander included), with no manoeuvre: the ball is released so
/// that this holds exactly (to solver precision, < 1 mm), gravity and the vehicle's motion
/// included. Pure functions of the seed; thread-safe.
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "fdv/sim/scenario_config.h"

namespace fdv::sim {

struct RandomThrowParameters {
  std::uint64_t seed = 1;
  // --- the throw
  double speed_m_s = 0;        ///< [m/s] chord speed: straight-line flight distance / flight time
  double distance_m = 0;       ///< [m] release point to the body origin at release
  double miss_distance_m = 0;  ///< [m] drawn closest approach without a manoeuvre
  bool threat = false;         ///< the Bernoulli draw: miss drawn in [0, 0.5) m, else [0.5, 1.5)
  /// [deg] direction of the miss about the relative velocity at the pass: 0 left, 90 above
  double offset_direction_deg = 0;
  double release_azimuth_deg = 0;    ///< [deg] release direction from the body, left of the heading
  double release_elevation_deg = 0;  ///< [deg] idem, above the horizon
  double release_t_s = 0.2;          ///< [s]
  double closest_approach_t_s = 0;   ///< [s] when the ball is nearest the body origin
  /// share of the time from release to closest approach with the ball's centre in the image
  double in_view_fraction = 0;
  /// speed / distance / direction draws it took to get a throw in view (1: the first; see docs)
  int draws = 1;
  Eigen::Vector3d origin_W_m = Eigen::Vector3d::Zero();      ///< release position
  Eigen::Vector3d velocity_W_m_s = Eigen::Vector3d::Zero();  ///< release velocity
  double diameter_m = 0;                                     ///< [m] ball diameter
  // --- the vehicle
  std::string vehicle_motion = "hover";  ///< "hover" or "forward"
  double vehicle_speed_m_s = 0;          ///< [m/s] forward speed (0 when hovering)
  // --- the scene and the sensor
  std::string lighting = "bright";     ///< "bright" or "dim"
  double illuminance_lux = 500;        ///< [lux]
  std::string texture = "panels";      ///< "panels" (the presets' layout) or "bare" (room only)
  std::string resolution = "640x480";  ///< event sensor WxH, the preset set's field of view
  int width = 640, height = 480;       ///< [px] the same
  /// [s] when the ball's surface first comes within 0.1 m of the event camera's centre (it hits
  /// the vehicle's front; the scene ends there); 0 for a ball that does not
  double contact_t_s = 0;
  /// [s] closest approach + 0.3 s rounded up to 50 ms, or contact_t_s rounded down to 5 ms
  double duration_s = 0;
};

/// The parameters seed `seed` draws (the same ones make_preset("random_throw", seed) uses).
RandomThrowParameters sample_random_throw(std::uint64_t seed);
/// The scenario of those parameters (make_preset("random_throw", seed) returns
/// random_throw_config(sample_random_throw(seed))).
ScenarioConfig random_throw_config(const RandomThrowParameters& p);

/// Every field, by name (units in the names), vectors as [x, y, z].
nlohmann::json to_json(const RandomThrowParameters& p);
/// The inverse of to_json. Throws InputError(`source`, "key K", reason) for a missing key or a
/// value of the wrong type.
RandomThrowParameters random_throw_from_json(const nlohmann::json& j, const std::string& source);

/// The same fields as a YAML mapping (numbers as their shortest exact text).
YAML::Node random_throw_yaml(const RandomThrowParameters& p);
/// The `random_throw` section of dataset.yaml for a simulation of `config` (Simulator::
/// manifest_yaml writes it): the seed's parameters when `config` is exactly
/// random_throw_config(sample_random_throw(config.seed)) (thread count aside), else nullopt
/// (another scenario, or one changed by --config, --resolution, --duration...).
std::optional<YAML::Node> random_throw_manifest(const ScenarioConfig& config);
/// The `random_throw` section of `dataset_dir`/dataset.yaml. nullopt when there is none (another
/// scenario); InputError naming the file (and key) for an unreadable dataset.yaml or a malformed
/// section.
std::optional<RandomThrowParameters> read_random_throw(const std::string& dataset_dir);

}  // namespace fdv::sim
