#pragma once
/// Plain reference of the warp compensators' per-event work ("none", "rotation",
/// "rotation_translation"), for tests and benchmarks only: one event at a time, in double
/// precision, straight from the geometry in compensator.h — no lookup tables, no float, no
/// prefetching, no time slicing, no threads. The optimised WarpCompensator must agree with it
/// (tests/compensation/reference_equivalence_test.cpp states the tolerance and why).
///
///   const CompensatedWindow& fast = comp->compensate(in);
///   ReferenceWarpResult ref = reference_warp(calib.event_camera, reference_motion(fast.report, opt), in);
///
/// What is not per-event work is taken from the optimised compensator's report, and is tested on
/// its own elsewhere: the strategy actually used (fallbacks), ω̄ and v in E, and the depth that
/// the missing-depth policy gives pixels without depth.
///
/// Model (compensator.h): event (x, y, t) -> normalised ray r = undistort(x, y); refresh slot
/// s = ⌊(t − t0) / rotation_refresh⌋ (the last slot ends at t_end); R_s = exp([ω̄]× t_s) at the
/// slot's middle time t_s; inverse depth ρ at the raw pixel (holes: the largest ρ within
/// hole_fill_radius_px, else the missing-depth policy); X = R_s·[r; 1] + ρ·(t − t0)·v;
/// (u, v) = K·(X / X_z). t_s of the output is float(t − t0 [ns]) · 1e-9f (the output's definition).
/// Thread safety: pure functions; may be called from any thread.
#include <cstdint>
#include <vector>

#include "fdv/compensation/compensator.h"

namespace fdv {

/// The motion and depth handling the reference applies (per window, not per event).
struct ReferenceMotion {
  CompensationMethod method = CompensationMethod::kNone;  ///< kNone, kRotation or kRotationTranslation
  Eigen::Vector3d omega_E = Eigen::Vector3d::Zero();     ///< ω̄ in E [rad/s]
  Eigen::Vector3d v_E = Eigen::Vector3d::Zero();         ///< camera velocity in E [m/s]
  TimeNs rotation_refresh_ns = 1 * kNsPerMs;
  int hole_fill_radius_px = 1;
  MissingDepthPolicy missing_depth = MissingDepthPolicy::kBeyondRange;
  double fallback_depth_m = 0;  ///< the depth of pixels without depth (not for kRotationOnly)
};

/// The optimised compensator's per-window decisions, as the reference's input.
ReferenceMotion reference_motion(const CompensationReport& report, const CompensationOptions& options);

struct ReferenceWarpResult {
  // Kept events, in input order.
  std::vector<double> u, v;  ///< warped position on the undistorted grid [px], double precision
  std::vector<float> t_s;
  std::vector<std::int32_t> pixel;  ///< row-major nearest pixel (round half up)
  std::vector<std::size_t> input_index;
  std::uint64_t dropped_outside_window = 0, dropped_outside_sensor = 0, dropped_no_inverse = 0,
                dropped_left_image = 0, depth_fallback_events = 0, events_out_of_order = 0;
};

/// Warps every event of `in` (no decimation: compare with max_events_per_window above the count).
ReferenceWarpResult reference_warp(const PinholeCamera& camera, const ReferenceMotion& motion,
                                   const CompensationInput& in);

}  // namespace fdv
