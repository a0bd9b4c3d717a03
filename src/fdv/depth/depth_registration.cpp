#include "fdv/depth/depth_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "fdv/core/error.h"

namespace fdv {

std::string DepthRegistrationOptions::validate() const {
  std::ostringstream why;
  if (!(min_depth_m > 0) || !std::isfinite(min_depth_m))
    why << "min_depth_m must be positive, got " << min_depth_m;
  else if (!(max_depth_m > min_depth_m) || !std::isfinite(max_depth_m))
    why << "max_depth_m must be finite and above min_depth_m, got " << max_depth_m;
  return why.str();
}

DepthRegistrar::DepthRegistrar(const Calibration& calibration, const DepthRegistrationOptions& options)
    : options_(options), event_camera_(calibration.event_camera) {
  if (const auto why = options.validate(); !why.empty()) throw ConfigError("depth registration: " + why);
  if (!calibration.depth_camera)
    throw ConfigError("depth registration: the calibration has no depth camera");
  depth_camera_ = *calibration.depth_camera;
  if (const auto why = depth_camera_.validate(); !why.empty())
    throw ConfigError("depth registration: depth camera: " + why);
  if (const auto why = event_camera_.validate(); !why.empty())
    throw ConfigError("depth registration: event camera: " + why);
  const Eigen::Isometry3d T_E_D = calibration.T_B_E.inverse() * calibration.T_B_D;
  R_E_D_ = T_E_D.linear();
  t_E_D_ = T_E_D.translation();
  // The event lens map is trusted out to (a little beyond) the undistorted image border.
  max_radius2_event_ = std::numeric_limits<double>::infinity();
  if (!event_camera_.distortion.is_zero()) {
    double r2 = 0;
    const int w = event_camera_.width, h = event_camera_.height;
    auto visit = [&](int x, int y) {
      const Eigen::Vector2d xn = event_camera_.pixel_to_normalized({x, y});
      if (xn.allFinite()) r2 = std::max(r2, xn.squaredNorm());
    };
    for (int x = 0; x < w; ++x) visit(x, 0), visit(x, h - 1);
    for (int y = 0; y < h; ++y) visit(0, y), visit(w - 1, y);
    max_radius2_event_ = r2 * 1.1 * 1.1;
  }
  // The depth camera's undistortion, once per calibration (Newton per pixel is too slow per frame).
  const std::size_t n = static_cast<std::size_t>(depth_camera_.width) * depth_camera_.height;
  rays_.resize(2 * n);
  for (int v = 0; v < depth_camera_.height; ++v)
    for (int u = 0; u < depth_camera_.width; ++u) {
      const Eigen::Vector2d xn = depth_camera_.pixel_to_normalized({u, v});
      const std::size_t i = static_cast<std::size_t>(v) * depth_camera_.width + u;
      rays_[2 * i] = static_cast<float>(xn.x());
      rays_[2 * i + 1] = static_cast<float>(xn.y());
    }
}

DepthRegistrationResult DepthRegistrar::register_frame(const DepthFrame& frame) const {
  DepthRegistrationResult result;
  const std::size_t n = static_cast<std::size_t>(depth_camera_.width) * depth_camera_.height;
  if (frame.width != depth_camera_.width || frame.height != depth_camera_.height) {
    std::ostringstream why;
    why << "depth frame is " << frame.width << "x" << frame.height << " but the depth camera is calibrated for "
        << depth_camera_.width << "x" << depth_camera_.height;
    result.rejected = why.str();
    return result;
  }
  if (frame.depth_m.size() != n) {
    std::ostringstream why;
    why << "depth frame holds " << frame.depth_m.size() << " values, expected " << n;
    result.rejected = why.str();
    return result;
  }
  RegisteredDepth& out = result.depth;
  out.t = frame.t;
  out.width = event_camera_.width;
  out.height = event_camera_.height;
  out.depth_m.assign(static_cast<std::size_t>(out.width) * out.height, 0.0f);
  const float inf = std::numeric_limits<float>::infinity();
  // z-buffer in place: "no depth yet" is +inf while splatting, 0 afterwards.
  std::fill(out.depth_m.begin(), out.depth_m.end(), inf);
  const double lo = options_.min_depth_m, hi = options_.max_depth_m;
  // Every pixel is carried through the whole projection and classified at the end, without a
  // branch per check: holes and rejects are scattered over a frame, and the mispredicted branches
  // cost more than the arithmetic saved (same operations as one check at a time: same results).
  const float* depth = frame.depth_m.data();
  const float* rays = rays_.data();
  std::uint64_t invalid = 0, no_inverse = 0, behind = 0, outside = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float z_d = depth[i];
    const float xn = rays[2 * i], yn = rays[2 * i + 1];
    const bool valid = z_d >= lo && z_d <= hi;  // also rejects NaN
    const bool has_ray = valid && !std::isnan(xn);
    const Eigen::Vector3d X_D(xn * static_cast<double>(z_d), yn * static_cast<double>(z_d), z_d);
    const Eigen::Vector3d X_E = R_E_D_ * X_D + t_E_D_;
    const bool front = has_ray && X_E.z() > 0;
    const Eigen::Vector2d xn_e = X_E.head<2>() / X_E.z();
    const Eigen::Vector2d px = event_camera_.normalized_to_pixel(xn_e);
    const bool inside = front && !(xn_e.squaredNorm() > max_radius2_event_) && event_camera_.in_image(px);
    invalid += !valid;
    no_inverse += valid && !has_ray;
    behind += has_ray && !front;
    outside += front && !inside;
    if (!inside) continue;
    // Nearest pixel (in_image guarantees px + 0.5 >= 0, so truncation is floor).
    const int x = static_cast<int>(px.x() + 0.5), y = static_cast<int>(px.y() + 0.5);
    float& cell = out.depth_m[static_cast<std::size_t>(y) * out.width + x];
    ++out.registered;
    const float z_e = static_cast<float>(X_E.z());
    if (z_e < cell) {
      if (cell != inf) ++out.occluded;
      cell = z_e;
    } else {
      ++out.occluded;
    }
  }
  out.invalid_input += invalid;
  out.no_inverse += no_inverse;
  out.behind_camera += behind;
  out.outside_image += outside;
  for (float& z : out.depth_m)
    if (z == inf) z = 0.0f;
  return result;
}

}  // namespace fdv
