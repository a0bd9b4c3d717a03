#pragma once
/// Everything that defines a simulated scene: one options struct with a sub-struct per sensor
/// and per part of the world. Every field has an in-class default; the comment gives its unit
/// and where the default comes from (docs/SIMULATOR.md has the same list with the reasoning).
///
///   ScenarioConfig c = make_preset("fast_forward", /*seed=*/7);   // a named, randomised preset
///   apply_scenario_yaml(c, "override.yaml");                       // any field from a YAML file
///   load_event_camera(c, "davis346.xml");                          // a real sensor's lens
///   set_event_resolution(c, 346, 260);                             // same field of view
///   if (auto why = c.validate(); !why.empty()) ...                 // "key: reason"
///   Simulator sim(c);
///
/// Frames: W world (z up, gravity -z), B body (x forward, y left, z up), E event camera and
/// D depth camera (x right, y down, z along the optical axis), I IMU. Times are seconds in the
/// configuration and int64 nanoseconds (TimeNs) everywhere else.
/// Thread safety: value types; const access from any thread.
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fdv/core/calibration.h"

namespace fdv::sim {

/// The event camera: geometry, pixel model, noise, and the simulator's sampling controls.
struct EventCameraConfig {
  // --- geometry: the paper's iniVation DVXplorer
  int width = 640;    ///< [px] DVXplorer
  int height = 480;   ///< [px] DVXplorer
  double fx = 536.3;  ///< [px] paper release's DVXplorer intrinsics
  double fy = 536.3;  ///< [px] idem
  double cx = 320.9;  ///< [px] idem
  double cy = 234.0;  ///< [px] idem
  /// k1 k2 p1 p2 k3 (OpenCV radial-tangential). Chosen: mild barrel distortion of a ~4 mm
  /// S-mount lens on the 1/2.5" DVXplorer sensor (~4 % at the image corner), invertible over the
  /// whole image (docs/SIMULATOR.md).
  std::array<double, 5> distortion{-0.10, 0.06, 4.0e-4, -6.0e-4, 0.0};
  /// [m] camera centre in B. Chosen: 12 cm ahead of the body origin, 2 cm above.
  Eigen::Vector3d position_B_m{0.12, 0.0, 0.02};
  /// [deg] roll, pitch, yaw of a mounting error on top of the forward-looking mounting (E z = B x).
  Eigen::Vector3d mount_rpy_deg{0.0, 0.0, 0.0};

  // --- pixel model
  double contrast_threshold_mean = 0.25;  ///< [log intensity] DESIGN (C 0.2-0.3; v2e default 0.2)
  double contrast_threshold_spread =
      0.03;  ///< [log intensity] σ_C per pixel, DESIGN; v2e sigma_thres
  double contrast_threshold_min = 0.05;  ///< [log intensity] floor of a drawn threshold (chosen)
  double refractory_s = 5.0e-4;          ///< [s] v2e's default refractory period (0.5 ms)
  /// [lux] dark-current equivalent illuminance added before the log (chosen: compresses the log
  /// contrast in dim light, as the paper's 8-10 lux runs show).
  double dark_current_lux = 1.0;
  double timestamp_resolution_s = 1.0e-6;  ///< [s] DVXplorer / AEDAT timestamps are microseconds
  double timestamp_jitter_s = 0.0;         ///< [s] σ of Gaussian timestamp jitter; optional, off

  // --- noise (measured on the real DVXplorer noise recording, docs/SIMULATOR.md)
  double background_rate_hz = 0.43;             ///< [events/s/pixel] background activity
  double background_rate_spread_decades = 0.1;  ///< σ of log10(per-pixel rate); v2e default
  double background_on_fraction = 0.54;         ///< fraction of noise events that are ON (measured)
  double hot_pixel_fraction = 0.0015;      ///< fraction of pixels that are hot (≥ 5 Hz, measured)
  double hot_pixel_rate_median_hz = 18.5;  ///< [Hz] median hot-pixel rate (measured)
  double hot_pixel_rate_spread_decades = 0.56;  ///< σ of log10(hot rate) (measured)
  double hot_pixel_rate_min_hz = 5.0;           ///< [Hz] floor of a hot pixel's rate (measured cut)

  // --- sampling (simulator controls, not sensor properties)
  double max_motion_px = 0.5;  ///< [px] most image motion of any point between two samples
  double chunk_s = 0.005;      ///< [s] events are produced and handed out in chunks this long
  int tile_px = 16;            ///< [px] side of the square tiles that choose their own sample rate
  int max_steps_per_chunk = 2000;  ///< cap on samples per tile and chunk (ball right at the lens)
};

/// The depth camera (Intel RealSense D435-like).
struct DepthCameraConfig {
  bool enabled = true;
  int width = 640;    ///< [px] D435 depth stream
  int height = 480;   ///< [px]
  double fx = 385.7;  ///< [px] DESIGN: the paper release's depth intrinsics
  double fy = 385.7;  ///< [px] idem
  double cx = 320.0;  ///< [px] chosen: image centre (a rectified stream)
  double cy = 240.0;  ///< [px] idem
  Eigen::Vector3d position_B_m{0.11, -0.015, -0.05};  ///< [m] chosen: below and beside the DVS
  Eigen::Vector3d mount_rpy_deg{0.0, 0.0, 0.0};       ///< [deg] on top of forward-looking
  double rate_hz = 30.0;                              ///< [Hz] D435 at 640x480
  double subpixel_px = 0.08;           ///< [px] DESIGN: Intel's RMS formula σ = z² s / (f B)
  double baseline_m = 0.05;            ///< [m] D435 stereo baseline (DESIGN)
  double min_range_m = 0.3;            ///< [m] D435 operating range (DESIGN)
  double max_range_m = 10.0;           ///< [m] idem
  double hole_fraction = 0.02;         ///< random invalid pixels ("a few %", DESIGN)
  double edge_hole_probability = 0.5;  ///< chance a depth-edge pixel is invalid (chosen)
  double edge_jump_fraction = 0.05;    ///< a 4-neighbour this much nearer/farther marks an edge
  /// Side c of the square over which the depth noise is correlated [px], odd; 1 = independent
  /// per pixel. Chosen: stereo matching aggregates over a window (docs/SIMULATOR.md).
  int noise_correlation_px = 5;
};

/// The IMU (flight-controller MEMS unit).
struct ImuConfig {
  double rate_hz = 1000.0;                         ///< [Hz] a flight controller's IMU
  Eigen::Vector3d R_B_I_rpy_deg{180.0, 0.0, 0.0};  ///< [deg] FRD IMU on an FLU body (PX4 style)
  double gyro_noise_density = 1.0e-4;              ///< [rad/s/√Hz] DESIGN
  double accel_noise_density = 1.5e-3;             ///< [m/s²/√Hz] DESIGN
  double gyro_random_walk = 2.0e-5;   ///< [rad/s²/√Hz] EuRoC ADIS16448 Kalibr value (1.9e-5)
  double accel_random_walk = 3.0e-3;  ///< [m/s³/√Hz] EuRoC ADIS16448 Kalibr value
  double gyro_bias_sigma = 5.0e-3;    ///< [rad/s] initial bias σ (chosen, ~0.3 deg/s)
  double accel_bias_sigma = 0.05;     ///< [m/s²] initial bias σ (chosen)
};

/// Odometry as a VIO gives it.
struct OdometryConfig {
  double rate_hz = 100.0;                      ///< [Hz] DESIGN
  double velocity_sigma_m_s = 0.05;            ///< [m/s] DESIGN (stationary σ per axis)
  double velocity_correlation_s = 0.2;         ///< [s] Gauss-Markov time constant (chosen)
  double drift_fraction = 0.01;                ///< position drift per metre travelled (DESIGN, 1 %)
  double position_sigma_m = 0.005;             ///< [m] white position jitter (chosen)
  double attitude_sigma_deg = 0.5;             ///< [deg] Gauss-Markov attitude error σ (chosen)
  double attitude_correlation_s = 1.0;         ///< [s] its time constant (chosen)
  double angular_velocity_sigma_rad_s = 0.01;  ///< [rad/s] white noise on ω (chosen)
};

struct TruthConfig {
  double rate_hz = 1000.0;  ///< [Hz] truth/body.csv and truth/objects.csv (≥ 1 kHz)
};

/// How the vehicle flies a commanded acceleration on top of its path (vehicle_dynamics.h): a
/// quadrotor tilts its thrust towards the command with a first-order lag. The defaults are chosen
/// for an agile research quadrotor (docs/SIMULATOR.md "Flying a manoeuvre"); ArduCopter's, a
/// cautious consumer tune, are a 0.15 s input time constant and a 30° lean limit.
struct VehicleResponseConfig {
  double attitude_time_constant_s = 0.08;  ///< [s] thrust direction's first-order lag (chosen)
  double max_body_rate_rad_s = 6.0;        ///< [rad/s] fastest tilt rate (chosen)
  double max_tilt_deg = 60.0;              ///< [deg] largest thrust tilt from vertical (chosen)
  /// [m] the height controller's floor in W z: below it a downward command is dropped and the
  /// descent braked (chosen: above the depth camera's 0.3 m minimum range from the floor).
  double min_height_m = 0.5;
  /// [m] its ceiling in W z, the same rule for a climb (chosen: 0.5 m below the default room's).
  double max_height_m = 4.5;
  /// [m] the walls, the same rule horizontally: a motion towards a side of the room
  /// (scene.room_min_W_m / room_max_W_m, x and y) is braked to stop this far inside it (chosen: a
  /// sideways stop lags the tilt by about τ, 0.2-0.3 m at the 2-3 m/s of a dodge).
  double wall_margin_m = 0.5;
  double step_s = 2.5e-4;  ///< [s] integration step of the flown deviation
};

enum class MotionKind { kHover, kForward, kSwing, kConstant };
const char* to_string(MotionKind kind);

/// Vehicle motion: a nominal path plus vibration. Attitude as ZYX Euler angles (yaw ψ about W z,
/// then pitch θ, then roll φ); positive pitch is nose down in this FLU convention.
struct VehicleConfig {
  MotionKind motion = MotionKind::kHover;
  Eigen::Vector3d start_W_m{0.0, 0.0, 1.5};  ///< [m] body position at t = 0
  double heading_deg = 0.0;                  ///< [deg] yaw of the nominal path (0 = +x)
  double speed_m_s = 0.0;                    ///< [m/s] forward speed (forward, swing)
  double nose_down_deg = 0.0;                ///< [deg] nominal pitch while flying forward
  // vibration and hover wander, each a sum of three incommensurate sinusoids per axis
  double vibration_angle_deg = 0.1;      ///< [deg] angular vibration amplitude (chosen)
  double vibration_position_m = 0.001;   ///< [m] translational vibration amplitude (chosen)
  double vibration_frequency_hz = 12.0;  ///< [Hz] lowest vibration component (chosen)
  double wander_position_m = 0.03;       ///< [m] slow hover wander amplitude (chosen)
  double wander_frequency_hz = 0.4;      ///< [Hz] its frequency (chosen)
  // swing: roll and yaw oscillation, with the lateral sway a roll of that size produces
  double swing_roll_deg = 12.0;     ///< [deg] roll amplitude (chosen)
  double swing_yaw_deg = 8.0;       ///< [deg] yaw amplitude (chosen)
  double swing_frequency_hz = 1.0;  ///< [Hz] (chosen)
  // constant: exact constant acceleration and constant body rate (tests)
  Eigen::Vector3d velocity_W_m_s{0.0, 0.0, 0.0};       ///< [m/s] at t = 0
  Eigen::Vector3d acceleration_W_m_s2{0.0, 0.0, 0.0};  ///< [m/s²]
  Eigen::Vector3d omega_B_rad_s{0.0, 0.0, 0.0};        ///< [rad/s] body rate
  Eigen::Vector3d rpy0_deg{0.0, 0.0, 0.0};  ///< [deg] attitude at t = 0 (roll, pitch, yaw)
  /// Only when a manoeuvre is commanded (Simulator::command): how the vehicle flies it.
  VehicleResponseConfig response;
};

/// An axis-aligned textured rectangle (a panel or banner). Its plane is `axis` = `position_m`;
/// `min_m`/`max_m` bound the other two coordinates in x, y, z order (x: (y, z); y: (x, z); z: (x,
/// y)).
struct PanelConfig {
  std::string axis = "x";
  double position_m = 10.0;
  Eigen::Vector2d min_m{-1.0, 0.5};
  Eigen::Vector2d max_m{1.0, 2.0};
  double albedo = 0.35;   ///< mean reflectance
  double contrast = 0.7;  ///< texture amplitude in log reflectance
  double scale_m = 0.30;  ///< lattice spacing of the coarsest texture octave [m]
};

/// The static world: an axis-aligned room (floor, ceiling, walls) with panels in it.
struct SceneConfig {
  Eigen::Vector3d room_min_W_m{-10.0, -5.0, 0.0};  ///< [m] floor at z = min
  Eigen::Vector3d room_max_W_m{60.0, 5.0, 5.0};    ///< [m]
  Eigen::AlignedBox3d room() const { return {room_min_W_m, room_max_W_m}; }
  double illuminance_lux = 500.0;  ///< [lux] bright indoor (paper: 240-1100 lux bright runs)
  double ambient_fraction = 0.6;   ///< share of diffuse light; the rest comes from light_direction
  Eigen::Vector3d light_direction_W{0.3, 0.2, 1.0};  ///< towards the light (normalised on use)
  double floor_albedo = 0.25, wall_albedo = 0.40, ceiling_albedo = 0.55;
  double surface_contrast = 0.5;  ///< texture amplitude of floor, walls, ceiling [log reflectance]
  double surface_scale_m = 0.5;   ///< coarsest texture lattice spacing of the room surfaces [m]
  std::vector<PanelConfig> panels;
};

/// One thrown ball. `mode: aimed` (default) throws from a point relative to the vehicle to a
/// point relative to the vehicle at arrival at the given mean speed; `mode: explicit` gives the
/// release position and velocity in W. Before release the ball rests at its origin.
struct BallConfig {
  int id = 1;
  double radius_m = 0.105;  ///< [m] the paper's 21 cm ball
  std::string mode = "aimed";
  double release_t_s = 0.2;  ///< [s]
  Eigen::Vector3d from_m{4.0, 4.0,
                         0.0};  ///< aimed: origin minus vehicle position at release, W axes
  Eigen::Vector3d to_m{3.0, -3.0, 0.0};       ///< aimed: target minus vehicle position at arrival
  double speed_m_s = 12.0;                    ///< aimed: straight-line distance / flight time
  Eigen::Vector3d origin_W_m{5.0, 3.0, 1.5};  ///< explicit: release position
  Eigen::Vector3d velocity_W_m_s{0.0, -12.0, 2.0};  ///< explicit: release velocity
  Eigen::Vector3d spin_W_rad_s{0.0, 0.0, 12.0};     ///< [rad/s] spin after release (texture moves)
  /// true: the ball does not exist before release (thrown from outside the view; no truth, no
  /// rendering until then); false: it rests at its origin, visible (held by a thrower).
  bool hidden_before_release = false;
  double albedo = 0.6;             ///< mean reflectance (chosen: a bright ball)
  double contrast = 0.5;           ///< texture amplitude [log reflectance]
  double texture_frequency = 5.0;  ///< texture wave number over the unit sphere (features ~ 2πr/5)
  double drag_coefficient = 0.0;   ///< quadratic air drag C_d; 0 = pure ballistic (default)
  double mass_kg = 0.43;           ///< [kg] used only with drag (size-5 football)
  double air_density_kg_m3 = 1.2;  ///< [kg/m³] used only with drag
};

struct ScenarioConfig {
  std::string name = "custom";
  std::uint64_t seed = 1;
  double duration_s = 1.0;                          ///< [s]
  Eigen::Vector3d gravity_W_m_s2{0.0, 0.0, -9.81};  ///< [m/s²]
  int threads = 0;                                  ///< worker threads; 0 = all cores
  EventCameraConfig event_camera;
  DepthCameraConfig depth_camera;
  ImuConfig imu;
  OdometryConfig odometry;
  TruthConfig truth;
  VehicleConfig vehicle;
  SceneConfig scene;
  std::vector<BallConfig> balls;

  /// Empty when valid, else "key: reason" for the first problem found.
  std::string validate() const;
  /// The first problem as (key, reason); nullopt when valid.
  std::optional<std::pair<std::string, std::string>> find_problem() const;
  /// The rig calibration this configuration describes (cameras, T_B_E, T_B_D, R_B_I).
  Calibration calibration() const;
};

/// Names of the presets: scene1_no_object, scene2_ball, fast_forward, swing, hover_headon, dim,
/// close_pass, two_balls, random_throw (docs/SIMULATOR.md, "Scenarios").
std::vector<std::string> preset_names();
/// A named preset, randomised by `seed` (panel layout, throw, textures, noise). Throws
/// ConfigError for an unknown name (listing the known ones).
ScenarioConfig make_preset(const std::string& name, std::uint64_t seed);

/// Overrides the fields present in `node` (a mapping with the layout of to_yaml()). Lists
/// (balls, panels) replace the list; element i starts from the current element i when there is
/// one. Throws InputError(file, "key K", reason) for an unknown key or a value of the wrong type.
void apply_scenario_yaml(ScenarioConfig& config, const YAML::Node& node, const std::string& file);
/// Loads `path` and applies it; then validates. Throws InputError naming the file, the key (or
/// line, for a YAML syntax error) and the reason.
void apply_scenario_yaml(ScenarioConfig& config, const std::string& path);
/// Same on YAML text in memory; `file` names it in errors. At most kMaxConfigFileBytes
/// (fdv/core/config_text.h); no yaml-cpp exception escapes.
void apply_scenario_yaml_text(ScenarioConfig& config, std::string_view text, const std::string& file);
/// Parses scenario YAML text (size-checked; a syntax error is InputError naming the file and
/// line), for callers that read keys such as `name` before apply_scenario_yaml.
YAML::Node parse_scenario_yaml(std::string_view text, const std::string& file);
/// Reads `path` (size-checked) and parses it as parse_scenario_yaml does.
YAML::Node load_scenario_yaml(const std::string& path);
/// The complete configuration as YAML (loadable by apply_scenario_yaml).
std::string to_yaml(const ScenarioConfig& config);

/// Changes the event sensor resolution keeping its field of view: intrinsics scale with the
/// size (distortion coefficients are in normalised units and stay). Throws ConfigError for a
/// non-positive size.
void set_event_resolution(ScenarioConfig& config, int width, int height);

/// Takes the event camera's resolution, intrinsics and distortion from `camera` (e.g.
/// load_calibration(path).event_camera, from an OpenCV XML/YAML or the project's YAML file);
/// its mounting, pixel model, the depth camera and everything else stay. Combine with
/// set_event_resolution() afterwards to change the pixel count at that field of view.
void set_event_camera(ScenarioConfig& config, const PinholeCamera& camera);
/// Applies the event camera of the calibration file `path` (load_calibration: OpenCV XML/YAML or
/// the project's YAML). Throws InputError naming the file for a missing or malformed file, or a
/// lens the simulator cannot render (one that folds back inside the image's inscribed circle).
void load_event_camera(ScenarioConfig& config, const std::string& path);

}  // namespace fdv::sim
