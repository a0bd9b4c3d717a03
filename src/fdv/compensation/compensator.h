#pragma once
/// Ego-motion compensation of one event window (paper §IV-A): every event (x, y, t) of
/// [t_start, t_end) is warped to where the static scene point that caused it was seen at t_start.
///
///   Calibration calib = load_calibration(...);
///   CompensationOptions opt;                         // opt.method = kRotationTranslation
///   std::unique_ptr<Compensator> comp = make_compensator(calib, opt);
///   CompensationInput in{.events = win.events, .t_start = win.t_start, .t_end = win.t_end,
///                        .imu = imu_around_window, .odometry = odo_at_t_start, .depth = &registered};
///   const CompensatedWindow& out = comp->compensate(in);   // valid until the next call
///   // detection view: {t_start, t_end, width, height, pixel(), t_s(), |ω|, |v|,
///   //                  .time_sorted = out.report.events_out_of_order == 0}
///   if (out.report.used != out.report.requested) note(out.report.brief());
///
/// Strategies (CompensationMethod; YAML names): "none" (undistortion only), "rotation" (Falanga et al. 2020: mean IMU
/// rate, Rodrigues rotation refreshed every 1 ms), "rotation_translation" (the paper, eqs. 6-8:
/// rotation plus translation from the odometry velocity and per-event depth), "contrast_max"
/// (BetterFlow-like baseline: a 4-parameter global warp fitted by contrast maximisation).
///
/// Geometry (derived in docs/DETECTION.md): for an event at raw pixel p and time t, with
/// normalised ray x = undistort(p), camera rotation R(t) = exp([ω̄]× (t − t0)) taking E_t
/// coordinates into E_t0, camera displacement v·(t − t0) in E_t0 and inverse depth ρ = 1/Z at p,
///     X_t0 ∝ R(t)·[x; 1] + ρ·v·(t − t0),     warped pixel = K·(X_t0 / z).
/// ρ = 0 is rotation-only. Output coordinates are on the undistorted pixel grid K·xn (same K and
/// size as the event camera); warped positions are rounded to the nearest pixel, and events that
/// land outside the grid are counted and dropped.
///
/// Pitfalls: events must lie in [t_start, t_end) (others are counted and dropped); `imu` is in the
/// IMU frame (rotated into E with calib.R_E_I()); `odometry` carries the body velocity in W and the
/// attitude q_W_B; `depth` must be registered into the event camera (fdv/depth's DepthRegistrar).
/// A compensator keeps its buffers between calls (no allocation once warmed up). Not thread-safe:
/// one per thread.
#include <array>
#include <bit>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"

namespace fdv {

enum class CompensationMethod { kNone, kRotation, kRotationTranslation, kContrastMax };

/// "none", "rotation", "rotation_translation", "contrast_max".
std::string_view to_string(CompensationMethod m);
/// Inverse of to_string(); nothing for an unknown name.
std::optional<CompensationMethod> parse_compensation_method(std::string_view name);
/// Every method, in to_string()'s order (the field list's text form: fdv/core/field_list.h).
constexpr std::array<CompensationMethod, 4> all_values(CompensationMethod) {
  return {CompensationMethod::kNone, CompensationMethod::kRotation, CompensationMethod::kRotationTranslation,
          CompensationMethod::kContrastMax};
}

/// What to do with an event whose pixel has no registered depth (rotation_translation).
enum class MissingDepthPolicy {
  kMedianDepth,   ///< use the median depth of the registered frame
  kRotationOnly,  ///< ρ = 0 for that event: rotation compensated, translation not
  /// The default (DETECTION.md): beyond the depth camera's reach, at twice the frame's farthest
  /// valid depth (ρ half way between 0 and the reach's: the least worst-case error for any farther
  /// surface).
  kBeyondRange,
};
std::string_view to_string(MissingDepthPolicy p);
std::optional<MissingDepthPolicy> parse_missing_depth_policy(std::string_view name);
constexpr std::array<MissingDepthPolicy, 3> all_values(MissingDepthPolicy) {
  return {MissingDepthPolicy::kMedianDepth, MissingDepthPolicy::kRotationOnly, MissingDepthPolicy::kBeyondRange};
}

/// Contrast-maximisation baseline (Gallego et al. 2018 objective, Mitrokhin et al. 2018 model).
struct ContrastMaxOptions {
  /// Events used for the fit (uniformly subsampled above this); all events are warped with the
  /// result. Keeps one objective evaluation near 1 ms (bench/frontend_bench.cpp).
  int max_fit_events = 30'000;
  double blur_sigma_px = 1.0;  ///< Gaussian smoothing of the image of warped events [px] (Gallego 2018 §3)
  int max_iterations = 50;     ///< L-BFGS iterations (ceres::GradientProblemSolver)
  /// Bound on the expansion rate |h_z| [1/s] (tanh reparametrisation): without it the objective's
  /// global maximum collapses all events into a point ("event collapse", Shiba et al. 2022).
  /// 8/s allows a 20 % scale change over 25 ms (approach at 5 m/s to 0.6 m).
  double max_expansion_per_s = 8.0;
  bool warm_start = true;  ///< start from the previous window's parameters (motion is continuous)
  std::string validate() const;
};

struct CompensationOptions {
  CompensationMethod method = CompensationMethod::kRotationTranslation;
  TimeNs rotation_refresh_ns = 1 * kNsPerMs;    ///< R_e (and slot) refresh period, paper §IV-A "every millisecond"
  /// Each slot's rotation from the gyro integrated from the window's start (imu_turn), instead of
  /// the paper's mean rate ω̄·t (§IV-A). The mean rate is exact only for a rate constant over the
  /// window; a dodge's tilt changes it by several rad/s within one.
  bool integrate_gyro = false;
  /// IMU spacing above which a window is flagged as having an IMU gap; with no usable sample
  /// within this distance of the window the IMU counts as missing (fallback to "none").
  /// 20 ms: a healthy 200-1000 Hz IMU never leaves such a gap.
  TimeNs max_imu_gap_ns = 20 * kNsPerMs;
  /// Registered depth older (or newer) than this relative to the window's middle is not used
  /// (rotation only for the window). 100 ms = 3 periods of a 30 Hz depth camera.
  TimeNs max_depth_age_ns = 100 * kNsPerMs;
  MissingDepthPolicy missing_depth = MissingDepthPolicy::kBeyondRange;  ///< DETECTION.md
  /// Holes in the registered depth up to this radius [px] take the nearest surface among their
  /// neighbours (registration leaves pinholes when the depth camera is coarser or offset).
  int hole_fill_radius_px = 1;
  /// Overload guard: above this many events a window is decimated uniformly in time order and the
  /// dropped events are counted. Not a YAML key: fdv::Perception sets it from the top-level
  /// `max_events_per_window`, the event windower's limit, which decimates first (so this guard
  /// acts only for direct callers).
  std::size_t max_events_per_window = kDefaultMaxEventsPerWindow;
  /// Threads for the per-event warp of none / rotation / rotation_translation: the events are split
  /// into this many parts; results are identical for any count. Not a YAML key: fdv::Perception
  /// sets it from PerceptionOptions::threads (YAML `threads`), which the detector uses too.
  int threads = 1;
  ContrastMaxOptions contrast_max;
  std::string validate() const;
};

/// The field lists (fdv/core/field_list.h): YAML section `compensation`.
template <class V>
void describe(V& v, ContrastMaxOptions& o) {
  v("max_fit_events", o.max_fit_events, "events", "events used for the fit (uniformly subsampled above this)");
  v("blur_sigma_px", o.blur_sigma_px, "px", "Gaussian smoothing of the image of warped events");
  v("max_iterations", o.max_iterations, "-", "L-BFGS iterations");
  v("max_expansion_per_s", o.max_expansion_per_s, "1/s", "bound on the expansion rate |h_z| (avoids event collapse)");
  v("warm_start", o.warm_start, "-", "start from the previous window's parameters");
}
template <class V>
void describe(V& v, CompensationOptions& o) {
  v("method", o.method, "-", "strategy: none, rotation, rotation_translation (the paper), contrast_max");
  v.ms("rotation_refresh_ms", o.rotation_refresh_ns, "rotation (and slot) refresh period, paper §IV-A");
  v("integrate_gyro", o.integrate_gyro, "-",
    "each slot's rotation from the gyro integrated since the window's start, not the mean rate (paper §IV-A)");
  v.ms("max_imu_gap_ms", o.max_imu_gap_ns, "IMU spacing flagged as a gap; no sample this close: IMU missing");
  v.ms("max_depth_age_ms", o.max_depth_age_ns, "registered depth farther than this from the window's middle is not used");
  v("missing_depth", o.missing_depth, "-", "an event pixel without depth: median_depth, rotation_only or beyond_range");
  v("hole_fill_radius_px", o.hole_fill_radius_px, "px", "depth holes up to this radius take the nearest surface");
  v.section("contrast_max", o.contrast_max, "the contrast-maximisation baseline");
  v.removed("threads", "moved to the top-level key threads (used by the compensation and the detector)");
  v.removed("max_events_per_window",
            "moved to the top-level key max_events_per_window (the event windower's overload guard, which acts first)");
}

/// The IMU / odometry compensators cut a window to CompensationInput::near_regions from this many
/// events on: below it the whole window's warp, its tables in cache, costs less than carrying the
/// regions through the lens (docs/BENCHMARKS.md, "Overlapping windows: the CPU of a shorter step").
inline constexpr std::size_t kMinEventsToCutNearRegions = 16'384;

/// Everything one window needs. Spans and the depth pointer are borrowed for the call only.
struct CompensationInput {
  std::span<const Event> events = {};  ///< raw sensor pixels, time-ordered, in [t_start, t_end)
  TimeNs t_start = 0;          ///< t0: events are warped to this time
  TimeNs t_end = 0;            ///< exclusive
  std::span<const ImuSample> imu = {};      ///< samples around the window (IMU frame), may be empty
  std::optional<OdometrySample> odometry = {};  ///< vehicle state near t_start (v_W, q_W_B), may be absent
  const RegisteredDepth* depth = nullptr;   ///< latest depth registered into E, may be null or stale
  /// When set, only the events whose warp may land in one of these boxes of the undistorted grid
  /// [px] are needed (an empty list: none), the grid of the camera at t_start (at any time for
  /// "none"). A compensator may leave the others out (kMinEventsToCutNearRegions), counted in
  /// CompensationReport::skipped_far_from_regions, and then gives every event's time in
  /// CompensatedWindow::window_t_s(). Unset: every event.
  std::optional<std::span<const Eigen::AlignedBox2d>> near_regions = {};
};

/// How a window was compensated, what fell back and what was dropped.
struct CompensationReport {
  CompensationMethod requested = CompensationMethod::kNone;
  CompensationMethod used = CompensationMethod::kNone;  ///< after fallbacks
  // Fallback reasons (any may be set; `used` says the outcome).
  bool imu_missing = false;       ///< no usable IMU sample near the window -> "none"
  bool imu_gap = false;           ///< IMU spacing > max_imu_gap_ns; mean computed from what is there
  bool odometry_missing = false;  ///< rotation_translation without velocity -> "rotation"
  bool depth_missing = false;     ///< no depth frame -> "rotation"
  bool depth_stale = false;       ///< depth older than max_depth_age_ns -> "rotation"
  bool depth_wrong_size = false;  ///< registered depth not the event camera's size -> "rotation"
  // Event accounting: events_in = events_kept + all dropped_* + skipped_far_from_regions.
  std::uint64_t events_in = 0;
  std::uint64_t events_kept = 0;
  std::uint64_t dropped_outside_window = 0;  ///< t outside [t_start, t_end)
  std::uint64_t dropped_outside_sensor = 0;  ///< raw pixel outside the calibrated resolution
  std::uint64_t dropped_no_inverse = 0;      ///< raw pixel without undistortion (camera.h)
  std::uint64_t dropped_left_image = 0;      ///< warped outside the undistorted grid (or behind)
  std::uint64_t dropped_burst = 0;           ///< removed by the max_events_per_window decimation
  /// Not compensated: no warp could bring them into CompensationInput::near_regions. Not a loss
  /// (the caller asked for the regions only), so not a `dropped_*`, but in the sum above.
  std::uint64_t skipped_far_from_regions = 0;
  /// With near_regions: how far [grid px] the warp could move an event from where the lens alone
  /// puts it, the margin by which the regions were grown (0 when every event was warped).
  double near_regions_reach_px = 0;
  std::uint64_t depth_fallback_events = 0;   ///< events warped with the missing-depth policy
  /// Events earlier than their predecessor (kept, not reordered). 0 means the output's t_s is
  /// non-decreasing: set CompensatedEventsView::time_sorted from it.
  std::uint64_t events_out_of_order = 0;
  // Motion used (E frame).
  bool has_omega = false;
  Eigen::Vector3d omega_E = Eigen::Vector3d::Zero();  ///< mean angular velocity [rad/s]
  bool has_velocity = false;
  Eigen::Vector3d v_E = Eigen::Vector3d::Zero();  ///< camera velocity in E [m/s]
  int imu_samples = 0;
  TimeNs imu_largest_gap_ns = 0;
  TimeNs depth_age_ns = 0;  ///< |window middle − depth frame time|, when a frame was given
  /// This call prepared the depth frame (inverse depth, hole filling: ~0.9 ms at 640x480); false
  /// when it was prepared before, by an earlier window or by prepare_depth_frame on arrival.
  bool depth_prepared_here = false;
  float fallback_depth_m = 0;  ///< the depth given to pixels without depth (0: none, rotation_only)
  // contrast_max only.
  std::array<double, 4> warp_params{};  ///< h_x, h_y [px/s], h_z [1/s], θ [rad/s]
  int solver_iterations = 0;
  bool solver_converged = false;
  /// One line: method (and fallback), kept/dropped counts, flags.
  std::string brief() const;
};

/// Compensated events on the undistorted grid, structure-of-arrays. The arrays may be longer than
/// size() (buffers are reused); use the span accessors.
class CompensatedWindow {
 public:
  TimeNs t_start = 0;
  TimeNs t_end = 0;
  int width = 0;   ///< undistorted grid size = event camera size
  int height = 0;
  CompensationReport report;

  std::size_t size() const { return size_; }
  std::span<const float> x() const { return {x_.data(), size_}; }  ///< warped u [px], continuous
  std::span<const float> y() const { return {y_.data(), size_}; }  ///< warped v [px], continuous
  std::span<const float> t_s() const { return {t_.data(), size_}; }  ///< t − t_start [s]
  /// Row-major index v·width + u of the nearest grid pixel (round half up).
  std::span<const std::int32_t> pixel() const { return {pixel_.data(), size_}; }
  /// t − t_start [s] of every event of the window in the sensor (before the warp, which may move
  /// some off the grid), in input order, when the events were compensated near
  /// CompensationInput::near_regions only; empty otherwise.
  std::span<const float> window_t_s() const { return {window_t_s_.data(), window_t_size_}; }

  // Writer side (compensators): grow the buffers to hold n events (never shrinks), then fill.
  void reserve_events(std::size_t n);
  float* x_data() { return x_.data(); }
  float* y_data() { return y_.data(); }
  float* t_data() { return t_.data(); }
  std::int32_t* pixel_data() { return pixel_.data(); }
  void set_size(std::size_t n) { size_ = n; }
  /// Room for n window times (never shrinks); set_window_t_s_size() says how many were written.
  float* reserve_window_t_s(std::size_t n) {
    if (window_t_s_.size() < n) window_t_s_.resize(std::bit_ceil(n));
    return window_t_s_.data();
  }
  void set_window_t_s_size(std::size_t n) { window_t_size_ = n; }

 private:
  std::size_t size_ = 0;
  std::vector<float> x_, y_, t_;
  std::vector<std::int32_t> pixel_;
  std::vector<float> window_t_s_;
  std::size_t window_t_size_ = 0;
};

class Compensator {
 public:
  virtual ~Compensator() = default;
  virtual CompensationMethod method() const = 0;
  /// Warps the window's events to t_start. The result is owned by the compensator and stays
  /// valid until the next call. Never throws on bad data: fallbacks and drops are in the report.
  virtual const CompensatedWindow& compensate(const CompensationInput& input) = 0;
  /// Optional: does the per-frame depth work now (on the frame's arrival), so that the window
  /// that uses this frame - passed again as CompensationInput::depth, the same object, alive and
  /// unchanged at the same address - does not pay for it. Results are the same either way. The
  /// strategies that use no depth ignore it; one frame is held prepared at a time.
  virtual void prepare_depth_frame(const RegisteredDepth& depth) { (void)depth; }
  /// The inverse of the last window's warp: where the camera at t_start + t_s saw a point that an
  /// event at t_s was warped to at `px` (compensated grid, undistorted pixels in and out). For
  /// "rotation_translation", with the inverse depth the warp used where the camera saw it. Identity
  /// for "none" (and a window that fell back to it). A detection's centre goes through it: the
  /// events that make it were warped to t_start, but the camera pose paired with it is the one at
  /// the detection's time. Valid until the next compensate() or prepare_depth_frame().
  virtual Eigen::Vector2d observed_position(const Eigen::Vector2d& px, double t_s) const = 0;
};

/// The strategy named by options.method. Throws ConfigError for an unknown name, invalid options
/// or an invalid event camera. The undistortion table is computed here (once per calibration).
std::unique_ptr<Compensator> make_compensator(const Calibration& calibration, const CompensationOptions& options);

/// Velocity of the event camera's origin, in E [m/s]: body velocity v_W rotated into B by q_W_B,
/// plus the lever-arm term ω_B × t_B_E, rotated into E.
Eigen::Vector3d camera_velocity_E(const Calibration& calibration, const OdometrySample& odometry,
                                  const Eigen::Vector3d& omega_B);

}  // namespace fdv
