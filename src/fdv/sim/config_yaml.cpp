// YAML loading and dumping of ScenarioConfig. Every field is named once, in describe(); the
// loader and the dumper are the shared field-list visitors (fdv/core/options_yaml.h), so they
// cannot disagree.
#include <yaml-cpp/yaml.h>

#include <array>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/core/options_yaml.h"
#include "fdv/sim/scenario_config.h"

namespace fdv::sim {

// The text forms of MotionKind for the field-list visitors (to_string is in scenario_config.h).
constexpr std::array<MotionKind, 4> all_values(MotionKind) {
  return {MotionKind::kHover, MotionKind::kForward, MotionKind::kSwing, MotionKind::kConstant};
}

// The describe() functions are in fdv::sim, not an anonymous namespace: the visitors find them
// by argument-dependent lookup.

template <class V>
void describe(V& v, EventCameraConfig& c);
template <class V>
void describe(V& v, DepthCameraConfig& c);
template <class V>
void describe(V& v, ImuConfig& c);
template <class V>
void describe(V& v, OdometryConfig& c);
template <class V>
void describe(V& v, TruthConfig& c);
template <class V>
void describe(V& v, VehicleResponseConfig& c);
template <class V>
void describe(V& v, VehicleConfig& c);
template <class V>
void describe(V& v, PanelConfig& c);
template <class V>
void describe(V& v, SceneConfig& c);
template <class V>
void describe(V& v, BallConfig& c);
template <class V>
void describe(V& v, ScenarioConfig& c);

// ------------------------------------------------------------------------------------ description

template <class V>
void describe(V& v, EventCameraConfig& c) {
  v("width", c.width);
  v("height", c.height);
  v("fx", c.fx);
  v("fy", c.fy);
  v("cx", c.cx);
  v("cy", c.cy);
  v("distortion", c.distortion);
  v("position_B_m", c.position_B_m);
  v("mount_rpy_deg", c.mount_rpy_deg);
  v("contrast_threshold_mean", c.contrast_threshold_mean);
  v("contrast_threshold_spread", c.contrast_threshold_spread);
  v("contrast_threshold_min", c.contrast_threshold_min);
  v("refractory_s", c.refractory_s);
  v("dark_current_lux", c.dark_current_lux);
  v("timestamp_resolution_s", c.timestamp_resolution_s);
  v("timestamp_jitter_s", c.timestamp_jitter_s);
  v("background_rate_hz", c.background_rate_hz);
  v("background_rate_spread_decades", c.background_rate_spread_decades);
  v("background_on_fraction", c.background_on_fraction);
  v("hot_pixel_fraction", c.hot_pixel_fraction);
  v("hot_pixel_rate_median_hz", c.hot_pixel_rate_median_hz);
  v("hot_pixel_rate_spread_decades", c.hot_pixel_rate_spread_decades);
  v("hot_pixel_rate_min_hz", c.hot_pixel_rate_min_hz);
  v("max_motion_px", c.max_motion_px);
  v("chunk_s", c.chunk_s);
  v("tile_px", c.tile_px);
  v("max_steps_per_chunk", c.max_steps_per_chunk);
}

template <class V>
void describe(V& v, DepthCameraConfig& c) {
  v("enabled", c.enabled);
  v("width", c.width);
  v("height", c.height);
  v("fx", c.fx);
  v("fy", c.fy);
  v("cx", c.cx);
  v("cy", c.cy);
  v("position_B_m", c.position_B_m);
  v("mount_rpy_deg", c.mount_rpy_deg);
  v("rate_hz", c.rate_hz);
  v("subpixel_px", c.subpixel_px);
  v("baseline_m", c.baseline_m);
  v("min_range_m", c.min_range_m);
  v("max_range_m", c.max_range_m);
  v("hole_fraction", c.hole_fraction);
  v("edge_hole_probability", c.edge_hole_probability);
  v("edge_jump_fraction", c.edge_jump_fraction);
  v("noise_correlation_px", c.noise_correlation_px);
}

template <class V>
void describe(V& v, ImuConfig& c) {
  v("rate_hz", c.rate_hz);
  v("R_B_I_rpy_deg", c.R_B_I_rpy_deg);
  v("gyro_noise_density", c.gyro_noise_density);
  v("accel_noise_density", c.accel_noise_density);
  v("gyro_random_walk", c.gyro_random_walk);
  v("accel_random_walk", c.accel_random_walk);
  v("gyro_bias_sigma", c.gyro_bias_sigma);
  v("accel_bias_sigma", c.accel_bias_sigma);
}

template <class V>
void describe(V& v, OdometryConfig& c) {
  v("rate_hz", c.rate_hz);
  v("velocity_sigma_m_s", c.velocity_sigma_m_s);
  v("velocity_correlation_s", c.velocity_correlation_s);
  v("drift_fraction", c.drift_fraction);
  v("position_sigma_m", c.position_sigma_m);
  v("attitude_sigma_deg", c.attitude_sigma_deg);
  v("attitude_correlation_s", c.attitude_correlation_s);
  v("angular_velocity_sigma_rad_s", c.angular_velocity_sigma_rad_s);
}

template <class V>
void describe(V& v, TruthConfig& c) {
  v("rate_hz", c.rate_hz);
}

template <class V>
void describe(V& v, VehicleConfig& c) {
  v("motion", c.motion);
  v("start_W_m", c.start_W_m);
  v("heading_deg", c.heading_deg);
  v("speed_m_s", c.speed_m_s);
  v("nose_down_deg", c.nose_down_deg);
  v("vibration_angle_deg", c.vibration_angle_deg);
  v("vibration_position_m", c.vibration_position_m);
  v("vibration_frequency_hz", c.vibration_frequency_hz);
  v("wander_position_m", c.wander_position_m);
  v("wander_frequency_hz", c.wander_frequency_hz);
  v("swing_roll_deg", c.swing_roll_deg);
  v("swing_yaw_deg", c.swing_yaw_deg);
  v("swing_frequency_hz", c.swing_frequency_hz);
  v("velocity_W_m_s", c.velocity_W_m_s);
  v("acceleration_W_m_s2", c.acceleration_W_m_s2);
  v("omega_B_rad_s", c.omega_B_rad_s);
  v("rpy0_deg", c.rpy0_deg);
  v.section("response", c.response);
}

template <class V>
void describe(V& v, VehicleResponseConfig& c) {
  v("attitude_time_constant_s", c.attitude_time_constant_s);
  v("max_body_rate_rad_s", c.max_body_rate_rad_s);
  v("max_tilt_deg", c.max_tilt_deg);
  v("min_height_m", c.min_height_m);
  v("max_height_m", c.max_height_m);
  v("wall_margin_m", c.wall_margin_m);
  v("step_s", c.step_s);
}

template <class V>
void describe(V& v, PanelConfig& c) {
  v("axis", c.axis);
  v("position_m", c.position_m);
  v("min_m", c.min_m);
  v("max_m", c.max_m);
  v("albedo", c.albedo);
  v("contrast", c.contrast);
  v("scale_m", c.scale_m);
}

template <class V>
void describe(V& v, SceneConfig& c) {
  v("room_min_W_m", c.room_min_W_m);
  v("room_max_W_m", c.room_max_W_m);
  v("illuminance_lux", c.illuminance_lux);
  v("ambient_fraction", c.ambient_fraction);
  v("light_direction_W", c.light_direction_W);
  v("floor_albedo", c.floor_albedo);
  v("wall_albedo", c.wall_albedo);
  v("ceiling_albedo", c.ceiling_albedo);
  v("surface_contrast", c.surface_contrast);
  v("surface_scale_m", c.surface_scale_m);
  v.list("panels", c.panels);
}

template <class V>
void describe(V& v, BallConfig& c) {
  v("id", c.id);
  v("radius_m", c.radius_m);
  v("mode", c.mode);
  v("release_t_s", c.release_t_s);
  v("from_m", c.from_m);
  v("to_m", c.to_m);
  v("speed_m_s", c.speed_m_s);
  v("origin_W_m", c.origin_W_m);
  v("velocity_W_m_s", c.velocity_W_m_s);
  v("spin_W_rad_s", c.spin_W_rad_s);
  v("hidden_before_release", c.hidden_before_release);
  v("albedo", c.albedo);
  v("contrast", c.contrast);
  v("texture_frequency", c.texture_frequency);
  v("drag_coefficient", c.drag_coefficient);
  v("mass_kg", c.mass_kg);
  v("air_density_kg_m3", c.air_density_kg_m3);
}

template <class V>
void describe(V& v, ScenarioConfig& c) {
  v("name", c.name);
  v("seed", c.seed);
  v("duration_s", c.duration_s);
  v("gravity_W_m_s2", c.gravity_W_m_s2);
  v("threads", c.threads);
  v.section("event_camera", c.event_camera);
  v.section("depth_camera", c.depth_camera);
  v.section("imu", c.imu);
  v.section("odometry", c.odometry);
  v.section("truth", c.truth);
  v.section("vehicle", c.vehicle);
  v.section("scene", c.scene);
  v.list("balls", c.balls);
}

void apply_scenario_yaml(ScenarioConfig& config, const YAML::Node& node, const std::string& file) {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) throw InputError(file, "", "a scenario file must be a mapping of keys");
  YamlLoader loader(node, file);
  yaml_errors_as_input_errors(file, [&] {
    describe(loader, config);
    loader.check_unknown();
  });
}

YAML::Node parse_scenario_yaml(std::string_view text, const std::string& file) {
  return parse_config_yaml(text, file);
}

YAML::Node load_scenario_yaml(const std::string& path) {
  return parse_config_yaml(read_config_file(path), path);
}

void apply_scenario_yaml_text(ScenarioConfig& config, std::string_view text, const std::string& file) {
  apply_scenario_yaml(config, parse_config_yaml(text, file), file);
  if (const auto problem = config.find_problem())
    throw InputError(file, "key " + problem->first, problem->second);
}

void apply_scenario_yaml(ScenarioConfig& config, const std::string& path) {
  apply_scenario_yaml_text(config, read_config_file(path), path);
}

std::string to_yaml(const ScenarioConfig& config) { return options_to_yaml(config); }

}  // namespace fdv::sim
