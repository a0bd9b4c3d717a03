#include "fdv/sim/scenario_config.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <set>

#include "fdv/core/error.h"
#include "fdv/core/numeric.h"
#include "fdv/core/time.h"
#include "fdv/sim/geometry.h"

namespace fdv::sim {

const char* to_string(MotionKind kind) {
  switch (kind) {
    case MotionKind::kHover:
      return "hover";
    case MotionKind::kForward:
      return "forward";
    case MotionKind::kSwing:
      return "swing";
    case MotionKind::kConstant:
      return "constant";
  }
  return "?";
}

namespace {

using Problem = std::optional<std::pair<std::string, std::string>>;

/// Collects the first failed check.
class Checker {
 public:
  void need(bool ok, const std::string& key, const std::string& reason) {
    if (!ok && !problem_) problem_ = std::make_pair(key, reason);
  }
  void positive(double v, const std::string& key) {
    need(positive_finite(v), key, fmt::format("must be a positive number, got {}", v));
  }
  void non_negative(double v, const std::string& key) {
    need(std::isfinite(v) && v >= 0, key, fmt::format("must be a number >= 0, got {}", v));
  }
  void in_range(double v, double lo, double hi, const std::string& key) {
    need(std::isfinite(v) && v >= lo && v <= hi, key,
         fmt::format("must be in [{}, {}], got {}", lo, hi, v));
  }
  void finite(const Eigen::Vector3d& v, const std::string& key) {
    need(v.allFinite(), key, "must be finite numbers");
  }
  const Problem& problem() const { return problem_; }

 private:
  Problem problem_;
};

void check_camera(Checker& c, const PinholeCamera& cam, const std::string& key) {
  const std::string why = cam.validate();
  c.need(why.empty(), key, why);
}

}  // namespace

Problem ScenarioConfig::find_problem() const {
  Checker c;
  c.positive(duration_s, "duration_s");
  c.need(duration_s <= 3600, "duration_s", "longer than an hour");
  c.finite(gravity_W_m_s2, "gravity_W_m_s2");
  c.in_range(threads, 0, 256, "threads");

  const auto& e = event_camera;
  const std::string ek = "event_camera.";
  c.in_range(e.width, 8, 8192, ek + "width");
  c.in_range(e.height, 8, 8192, ek + "height");
  const Calibration calib = calibration();
  check_camera(c, calib.event_camera, "event_camera");
  c.need(lens_is_usable(calib.event_camera), ek + "distortion",
         "the lens model folds back inside the image's inscribed circle (radial map not "
         "monotonic)");
  c.finite(e.position_B_m, ek + "position_B_m");
  c.finite(e.mount_rpy_deg, ek + "mount_rpy_deg");
  c.positive(e.contrast_threshold_mean, ek + "contrast_threshold_mean");
  c.non_negative(e.contrast_threshold_spread, ek + "contrast_threshold_spread");
  c.positive(e.contrast_threshold_min, ek + "contrast_threshold_min");
  c.need(e.contrast_threshold_min <= e.contrast_threshold_mean, ek + "contrast_threshold_min",
         "must not exceed contrast_threshold_mean");
  c.in_range(e.refractory_s, 0, 0.1, ek + "refractory_s");
  c.non_negative(e.dark_current_lux, ek + "dark_current_lux");
  c.in_range(e.timestamp_resolution_s, 1e-9, 1e-3, ek + "timestamp_resolution_s");
  c.in_range(e.chunk_s, 1e-4, 0.1, ek + "chunk_s");
  c.in_range(e.timestamp_jitter_s, 0, e.chunk_s / 4, ek + "timestamp_jitter_s");
  {
    const TimeNs res = from_seconds(e.timestamp_resolution_s), chunk = from_seconds(e.chunk_s);
    c.need(res > 0 && chunk % res == 0, ek + "chunk_s",
           "must be a whole multiple of timestamp_resolution_s");
  }
  c.in_range(e.background_rate_hz, 0, 1e4, ek + "background_rate_hz");
  c.in_range(e.background_rate_spread_decades, 0, 2, ek + "background_rate_spread_decades");
  c.in_range(e.background_on_fraction, 0, 1, ek + "background_on_fraction");
  c.in_range(e.hot_pixel_fraction, 0, 0.1, ek + "hot_pixel_fraction");
  c.in_range(e.hot_pixel_rate_median_hz, 1e-3, 1e5, ek + "hot_pixel_rate_median_hz");
  c.in_range(e.hot_pixel_rate_spread_decades, 0, 3, ek + "hot_pixel_rate_spread_decades");
  c.in_range(e.hot_pixel_rate_min_hz, 0, 1e5, ek + "hot_pixel_rate_min_hz");
  c.in_range(e.max_motion_px, 0.01, 10, ek + "max_motion_px");
  c.in_range(e.tile_px, 4, 256, ek + "tile_px");
  c.in_range(e.max_steps_per_chunk, 1, 1e6, ek + "max_steps_per_chunk");

  const auto& d = depth_camera;
  const std::string dk = "depth_camera.";
  if (d.enabled) {
    c.in_range(d.width, 8, 8192, dk + "width");
    c.in_range(d.height, 8, 8192, dk + "height");
    if (calib.depth_camera) check_camera(c, *calib.depth_camera, "depth_camera");
    c.finite(d.position_B_m, dk + "position_B_m");
    c.finite(d.mount_rpy_deg, dk + "mount_rpy_deg");
    c.in_range(d.rate_hz, 1e-3, 1000, dk + "rate_hz");
    c.non_negative(d.subpixel_px, dk + "subpixel_px");
    c.positive(d.baseline_m, dk + "baseline_m");
    c.positive(d.min_range_m, dk + "min_range_m");
    c.need(d.max_range_m > d.min_range_m, dk + "max_range_m", "must exceed min_range_m");
    c.need(d.max_range_m <= 65.0, dk + "max_range_m", "16-bit millimetres end at 65.535 m");
    c.in_range(d.hole_fraction, 0, 1, dk + "hole_fraction");
    c.in_range(d.edge_hole_probability, 0, 1, dk + "edge_hole_probability");
    c.positive(d.edge_jump_fraction, dk + "edge_jump_fraction");
    c.need(d.noise_correlation_px >= 1 && d.noise_correlation_px <= 31 &&
               d.noise_correlation_px % 2 == 1,
           dk + "noise_correlation_px", "must be odd, in [1, 31]");
  }

  const std::string ik = "imu.";
  c.in_range(imu.rate_hz, 1, 1e5, ik + "rate_hz");
  c.finite(imu.R_B_I_rpy_deg, ik + "R_B_I_rpy_deg");
  c.non_negative(imu.gyro_noise_density, ik + "gyro_noise_density");
  c.non_negative(imu.accel_noise_density, ik + "accel_noise_density");
  c.non_negative(imu.gyro_random_walk, ik + "gyro_random_walk");
  c.non_negative(imu.accel_random_walk, ik + "accel_random_walk");
  c.non_negative(imu.gyro_bias_sigma, ik + "gyro_bias_sigma");
  c.non_negative(imu.accel_bias_sigma, ik + "accel_bias_sigma");

  const std::string ok = "odometry.";
  c.in_range(odometry.rate_hz, 1e-3, 1e4, ok + "rate_hz");
  c.non_negative(odometry.velocity_sigma_m_s, ok + "velocity_sigma_m_s");
  c.positive(odometry.velocity_correlation_s, ok + "velocity_correlation_s");
  c.in_range(odometry.drift_fraction, 0, 1, ok + "drift_fraction");
  c.non_negative(odometry.position_sigma_m, ok + "position_sigma_m");
  c.in_range(odometry.attitude_sigma_deg, 0, 45, ok + "attitude_sigma_deg");
  c.positive(odometry.attitude_correlation_s, ok + "attitude_correlation_s");
  c.non_negative(odometry.angular_velocity_sigma_rad_s, ok + "angular_velocity_sigma_rad_s");

  c.in_range(truth.rate_hz, 1, 1e6, "truth.rate_hz");

  const auto& v = vehicle;
  const std::string vk = "vehicle.";
  c.finite(v.start_W_m, vk + "start_W_m");
  c.need(std::isfinite(v.heading_deg), vk + "heading_deg", "must be finite");
  c.in_range(v.speed_m_s, 0, 100, vk + "speed_m_s");
  c.in_range(v.nose_down_deg, -60, 60, vk + "nose_down_deg");
  c.in_range(v.vibration_angle_deg, 0, 10, vk + "vibration_angle_deg");
  c.in_range(v.vibration_position_m, 0, 1, vk + "vibration_position_m");
  c.positive(v.vibration_frequency_hz, vk + "vibration_frequency_hz");
  c.in_range(v.wander_position_m, 0, 10, vk + "wander_position_m");
  c.positive(v.wander_frequency_hz, vk + "wander_frequency_hz");
  c.in_range(v.swing_roll_deg, 0, 60, vk + "swing_roll_deg");
  c.in_range(v.swing_yaw_deg, 0, 90, vk + "swing_yaw_deg");
  c.positive(v.swing_frequency_hz, vk + "swing_frequency_hz");
  c.finite(v.velocity_W_m_s, vk + "velocity_W_m_s");
  c.finite(v.acceleration_W_m_s2, vk + "acceleration_W_m_s2");
  c.finite(v.omega_B_rad_s, vk + "omega_B_rad_s");
  c.finite(v.rpy0_deg, vk + "rpy0_deg");
  const std::string rk = vk + "response.";
  c.in_range(v.response.attitude_time_constant_s, 1e-3, 10, rk + "attitude_time_constant_s");
  c.in_range(v.response.max_body_rate_rad_s, 0.1, 100, rk + "max_body_rate_rad_s");
  c.in_range(v.response.max_tilt_deg, 1, 80, rk + "max_tilt_deg");
  c.need(std::isfinite(v.response.min_height_m), rk + "min_height_m", "must be finite");
  c.need(
      std::isfinite(v.response.max_height_m) && v.response.max_height_m > v.response.min_height_m,
      rk + "max_height_m",
      fmt::format("must be a number above min_height_m ({}), got {}", v.response.min_height_m,
                  v.response.max_height_m));
  // Above the room's ceiling the hold would never act, and a climbing dodge would leave the room.
  c.need(v.response.max_height_m <= scene.room_max_W_m.z(), rk + "max_height_m",
         fmt::format("must not be above the room's ceiling (scene.room_max_W_m z = {}), got {}",
                     scene.room_max_W_m.z(), v.response.max_height_m));
  c.in_range(v.response.wall_margin_m, 0, 10, rk + "wall_margin_m");
  // Walls that met or crossed would brake every sideways motion both ways at once.
  const double narrowest = (scene.room_max_W_m - scene.room_min_W_m).head<2>().minCoeff();
  c.need(2 * v.response.wall_margin_m < narrowest, rk + "wall_margin_m",
         fmt::format("must leave the walls apart: twice it below the room's narrowest side in x and y "
                     "({} m), got {}",
                     narrowest, v.response.wall_margin_m));
  c.in_range(v.response.step_s, 1e-5, 1e-2, rk + "step_s");

  const auto& s = scene;
  const std::string sk = "scene.";
  c.finite(s.room_min_W_m, sk + "room_min_W_m");
  c.finite(s.room_max_W_m, sk + "room_max_W_m");
  c.need((s.room_max_W_m - s.room_min_W_m).minCoeff() > 0.5, sk + "room_max_W_m",
         "the room must be larger than 0.5 m along every axis (room_max - room_min)");
  c.positive(s.illuminance_lux, sk + "illuminance_lux");
  c.in_range(s.ambient_fraction, 0, 1, sk + "ambient_fraction");
  c.need(s.light_direction_W.allFinite() && s.light_direction_W.norm() > 1e-9,
         sk + "light_direction_W", "must be a non-zero vector");
  c.in_range(s.floor_albedo, 1e-3, 1, sk + "floor_albedo");
  c.in_range(s.wall_albedo, 1e-3, 1, sk + "wall_albedo");
  c.in_range(s.ceiling_albedo, 1e-3, 1, sk + "ceiling_albedo");
  c.in_range(s.surface_contrast, 0, 3, sk + "surface_contrast");
  c.positive(s.surface_scale_m, sk + "surface_scale_m");
  c.need(s.panels.size() <= 64, sk + "panels", "at most 64 panels");
  for (std::size_t i = 0; i < s.panels.size(); ++i) {
    const auto& p = s.panels[i];
    const std::string pk = fmt::format("{}panels[{}].", sk, i);
    c.need(p.axis == "x" || p.axis == "y" || p.axis == "z", pk + "axis", "must be x, y or z");
    c.need(std::isfinite(p.position_m), pk + "position_m", "must be finite");
    c.need(p.min_m.allFinite() && p.max_m.allFinite() && (p.max_m - p.min_m).minCoeff() > 0,
           pk + "max_m", "must exceed min_m in both coordinates");
    c.in_range(p.albedo, 1e-3, 1, pk + "albedo");
    c.in_range(p.contrast, 0, 3, pk + "contrast");
    c.positive(p.scale_m, pk + "scale_m");
  }

  c.need(balls.size() <= 8, "balls", "at most 8 balls");
  std::set<int> ids;
  for (std::size_t i = 0; i < balls.size(); ++i) {
    const auto& b = balls[i];
    const std::string bk = fmt::format("balls[{}].", i);
    c.in_range(b.id, 1, 32767, bk + "id");
    c.need(ids.insert(b.id).second, bk + "id", fmt::format("id {} used twice", b.id));
    c.in_range(b.radius_m, 1e-3, 5, bk + "radius_m");
    c.need(b.mode == "aimed" || b.mode == "explicit", bk + "mode", "must be aimed or explicit");
    c.non_negative(b.release_t_s, bk + "release_t_s");
    c.finite(b.from_m, bk + "from_m");
    c.finite(b.to_m, bk + "to_m");
    if (b.mode == "aimed") c.in_range(b.speed_m_s, 0.1, 200, bk + "speed_m_s");
    c.finite(b.origin_W_m, bk + "origin_W_m");
    c.finite(b.velocity_W_m_s, bk + "velocity_W_m_s");
    c.finite(b.spin_W_rad_s, bk + "spin_W_rad_s");
    c.in_range(b.albedo, 1e-3, 1, bk + "albedo");
    c.in_range(b.contrast, 0, 3, bk + "contrast");
    c.in_range(b.texture_frequency, 0, 100, bk + "texture_frequency");
    c.in_range(b.drag_coefficient, 0, 5, bk + "drag_coefficient");
    c.positive(b.mass_kg, bk + "mass_kg");
    c.non_negative(b.air_density_kg_m3, bk + "air_density_kg_m3");
  }
  return c.problem();
}

std::string ScenarioConfig::validate() const {
  const auto p = find_problem();
  return p ? p->first + ": " + p->second : std::string();
}

Calibration ScenarioConfig::calibration() const {
  Calibration c;
  const auto& e = event_camera;
  c.event_camera = PinholeCamera{
      e.width,
      e.height,
      e.fx,
      e.fy,
      e.cx,
      e.cy,
      {e.distortion[0], e.distortion[1], e.distortion[2], e.distortion[3], e.distortion[4]}};
  c.T_B_E.linear() = rotation_from_rpy_deg(e.mount_rpy_deg) * forward_camera_rotation();
  c.T_B_E.translation() = e.position_B_m;
  const auto& d = depth_camera;
  if (d.enabled) {
    c.depth_camera = PinholeCamera{d.width, d.height, d.fx, d.fy, d.cx, d.cy, {}};
    c.T_B_D.linear() = rotation_from_rpy_deg(d.mount_rpy_deg) * forward_camera_rotation();
    c.T_B_D.translation() = d.position_B_m;
  }
  c.R_B_I = rotation_from_rpy_deg(imu.R_B_I_rpy_deg);
  return c;
}

void set_event_resolution(ScenarioConfig& config, int width, int height) {
  if (width <= 0 || height <= 0)
    throw ConfigError(fmt::format("resolution must be positive, got {}x{}", width, height));
  auto& e = config.event_camera;
  const double sx = static_cast<double>(width) / e.width,
               sy = static_cast<double>(height) / e.height;
  e.fx *= sx;
  e.fy *= sy;
  e.cx = (e.cx + 0.5) * sx - 0.5;
  e.cy = (e.cy + 0.5) * sy - 0.5;
  e.width = width;
  e.height = height;
}

void set_event_camera(ScenarioConfig& config, const PinholeCamera& camera) {
  auto& e = config.event_camera;
  e.width = camera.width;
  e.height = camera.height;
  e.fx = camera.fx;
  e.fy = camera.fy;
  e.cx = camera.cx;
  e.cy = camera.cy;
  const auto& d = camera.distortion;
  e.distortion = {d.k1, d.k2, d.p1, d.p2, d.k3};
}

void load_event_camera(ScenarioConfig& config, const std::string& path) {
  ScenarioConfig with = config;
  set_event_camera(with, load_calibration(path).event_camera);
  if (const auto p = with.find_problem(); p && p->first.starts_with("event_camera"))
    throw InputError(path, "event camera", "cannot be simulated: " + p->first + ": " + p->second);
  config = std::move(with);
}

}  // namespace fdv::sim
