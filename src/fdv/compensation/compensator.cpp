#include "fdv/compensation/compensator.h"

#include <bit>
#include <cmath>
#include <sstream>

#include "fdv/compensation/contrast_max.h"
#include "fdv/compensation/warp_compensator.h"
#include "fdv/core/error.h"

namespace fdv {

std::string_view to_string(CompensationMethod m) {
  switch (m) {
    case CompensationMethod::kNone: return "none";
    case CompensationMethod::kRotation: return "rotation";
    case CompensationMethod::kRotationTranslation: return "rotation_translation";
    case CompensationMethod::kContrastMax: return "contrast_max";
  }
  return "?";
}

std::optional<CompensationMethod> parse_compensation_method(std::string_view name) {
  for (const CompensationMethod m : all_values(CompensationMethod{}))
    if (name == to_string(m)) return m;
  return std::nullopt;
}

std::string_view to_string(MissingDepthPolicy p) {
  switch (p) {
    case MissingDepthPolicy::kMedianDepth: return "median_depth";
    case MissingDepthPolicy::kRotationOnly: return "rotation_only";
    case MissingDepthPolicy::kBeyondRange: return "beyond_range";
  }
  return "?";
}

std::optional<MissingDepthPolicy> parse_missing_depth_policy(std::string_view name) {
  for (const MissingDepthPolicy p : all_values(MissingDepthPolicy{}))
    if (name == to_string(p)) return p;
  return std::nullopt;
}

std::string ContrastMaxOptions::validate() const {
  std::ostringstream why;
  if (max_fit_events < 10) why << "max_fit_events must be at least 10, got " << max_fit_events;
  else if (!(blur_sigma_px >= 0.3 && blur_sigma_px <= 10)) why << "blur_sigma_px must be in [0.3, 10], got " << blur_sigma_px;
  else if (max_iterations < 1) why << "max_iterations must be positive, got " << max_iterations;
  else if (!(max_expansion_per_s > 0) || !std::isfinite(max_expansion_per_s))
    why << "max_expansion_per_s must be positive, got " << max_expansion_per_s;
  return why.str();
}

std::string CompensationOptions::validate() const {
  std::ostringstream why;
  if (!parse_compensation_method(to_string(method)))
    why << "method " << static_cast<int>(method) << " is unknown";
  else if (rotation_refresh_ns <= 0) why << "rotation_refresh_ms must be positive, got " << rotation_refresh_ns << " ns";
  else if (max_imu_gap_ns <= 0) why << "max_imu_gap_ms must be positive, got " << max_imu_gap_ns << " ns";
  else if (max_depth_age_ns < 0) why << "max_depth_age_ms must not be negative, got " << max_depth_age_ns << " ns";
  else if (hole_fill_radius_px < 0 || hole_fill_radius_px > 10)
    why << "hole_fill_radius_px must be in [0, 10], got " << hole_fill_radius_px;
  else if (max_events_per_window < 1) why << "max_events_per_window must be positive";
  else if (threads < 1 || threads > 64) why << "threads must be in [1, 64], got " << threads;
  else if (const auto cm = contrast_max.validate(); !cm.empty()) why << "contrast_max." << cm;
  return why.str();
}

std::string CompensationReport::brief() const {
  std::ostringstream s;
  s << to_string(used);
  if (used != requested) s << " (requested " << to_string(requested) << ")";
  s << ": kept " << events_kept << "/" << events_in;
  const std::pair<const char*, std::uint64_t> drops[] = {
      {"outside window", dropped_outside_window}, {"outside sensor", dropped_outside_sensor},
      {"no undistortion", dropped_no_inverse},     {"left image", dropped_left_image},
      {"burst decimation", dropped_burst}, {"far from the regions", skipped_far_from_regions}};
  for (const auto& [what, n] : drops)
    if (n) s << ", " << what << " " << n;
  if (depth_fallback_events) s << ", depth fallback " << depth_fallback_events;
  if (events_out_of_order) s << ", out of time order " << events_out_of_order;
  const std::pair<const char*, bool> flags[] = {{"imu missing", imu_missing},       {"imu gap", imu_gap},
                                                {"odometry missing", odometry_missing}, {"depth missing", depth_missing},
                                                {"depth stale", depth_stale},       {"depth wrong size", depth_wrong_size}};
  for (const auto& [what, on] : flags)
    if (on) s << "; " << what;
  return s.str();
}

void CompensatedWindow::reserve_events(std::size_t n) {
  if (x_.size() >= n) return;
  // Round up to a power of two: a stream whose window sizes wander grows the buffers a few times
  // at most, not at each new largest window (no allocation per window once warmed up).
  const std::size_t size = std::bit_ceil(n);
  x_.resize(size);
  y_.resize(size);
  t_.resize(size);
  pixel_.resize(size);
}

Eigen::Vector3d camera_velocity_E(const Calibration& calibration, const OdometrySample& odometry,
                                  const Eigen::Vector3d& omega_B) {
  const Eigen::Matrix3d R_W_B = odometry.q_W_B.normalized().toRotationMatrix();
  const Eigen::Vector3d v_B = R_W_B.transpose() * odometry.v_W;
  const Eigen::Vector3d v_cam_B = v_B + omega_B.cross(calibration.T_B_E.translation());
  return calibration.T_B_E.linear().transpose() * v_cam_B;
}

std::unique_ptr<Compensator> make_compensator(const Calibration& calibration, const CompensationOptions& options) {
  if (const auto why = options.validate(); !why.empty()) throw ConfigError("compensation: " + why);
  const CompensationMethod m = options.method;
  auto map = std::make_shared<const UndistortionMap>(calibration.event_camera);
  if (m == CompensationMethod::kContrastMax)
    return std::make_unique<internal::ContrastMaxCompensator>(calibration, options, std::move(map));
  return std::make_unique<internal::WarpCompensator>(m, calibration, options, std::move(map));
}

}  // namespace fdv
