#include "fdv/compensation/reference_warp.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace fdv {
namespace {

bool valid_depth(float z) { return z > 0 && std::isfinite(z); }

/// ρ at raw pixel (x, y) and whether the missing-depth policy supplied it.
std::pair<double, bool> inverse_depth(const RegisteredDepth& depth, int x, int y, const ReferenceMotion& m) {
  const float z = depth.at(x, y);
  if (valid_depth(z)) return {1.0 / static_cast<double>(z), false};
  // A hole: the nearest surface (largest ρ) among the neighbours within the radius.
  double best = 0;
  const int r = m.hole_fill_radius_px;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (xx < 0 || yy < 0 || xx >= depth.width || yy >= depth.height) continue;
      const float zz = depth.at(xx, yy);
      if (valid_depth(zz)) best = std::max(best, 1.0 / static_cast<double>(zz));
    }
  if (best > 0) return {best, false};
  return {m.missing_depth == MissingDepthPolicy::kRotationOnly ? 0.0 : 1.0 / m.fallback_depth_m, true};
}

}  // namespace

ReferenceMotion reference_motion(const CompensationReport& report, const CompensationOptions& options) {
  ReferenceMotion m;
  m.method = report.used;
  m.omega_E = report.omega_E;
  m.v_E = report.v_E;
  m.rotation_refresh_ns = options.rotation_refresh_ns;
  m.hole_fill_radius_px = options.hole_fill_radius_px;
  m.missing_depth = options.missing_depth;
  m.fallback_depth_m = report.fallback_depth_m;
  return m;
}

ReferenceWarpResult reference_warp(const PinholeCamera& cam, const ReferenceMotion& m, const CompensationInput& in) {
  ReferenceWarpResult out;
  const TimeNs t0 = in.t_start, t1 = in.t_end, duration = t1 - t0;
  TimeNs previous_t = std::numeric_limits<TimeNs>::min();
  for (std::size_t i = 0; i < in.events.size(); ++i) {
    const Event& e = in.events[i];
    out.events_out_of_order += e.t < previous_t;
    previous_t = e.t;
    if (e.t < t0 || e.t >= t1) {
      ++out.dropped_outside_window;
      continue;
    }
    if (e.x >= cam.width || e.y >= cam.height) {
      ++out.dropped_outside_sensor;
      continue;
    }
    const Eigen::Vector2d xn = cam.pixel_to_normalized({e.x, e.y});
    if (!xn.allFinite()) {
      ++out.dropped_no_inverse;
      continue;
    }
    const TimeNs dt_ns = e.t - t0;
    const double dt_s = static_cast<double>(dt_ns) * 1e-9;
    Eigen::Vector3d X(xn.x(), xn.y(), 1.0);
    if (m.method != CompensationMethod::kNone) {
      // The event's refresh slot [a, b) and its middle time; the last slot ends at t_end.
      const TimeNs refresh = m.rotation_refresh_ns;
      const TimeNs a = dt_ns / refresh * refresh, b = std::min(a + refresh, duration);
      const double t_mid = 0.5 * static_cast<double>(a + b) * 1e-9;
      const double angle = m.omega_E.norm() * t_mid;
      const Eigen::Matrix3d R = angle > 0 ? Eigen::AngleAxisd(angle, m.omega_E.normalized()).toRotationMatrix()
                                          : Eigen::Matrix3d::Identity();
      X = R * X;
      if (m.method == CompensationMethod::kRotationTranslation && in.depth) {
        const auto [rho, fallback] = inverse_depth(*in.depth, e.x, e.y, m);
        out.depth_fallback_events += fallback;
        X += rho * dt_s * m.v_E;
      }
    }
    if (!(X.z() > 1e-6)) {
      ++out.dropped_left_image;
      continue;
    }
    const double u = cam.fx * X.x() / X.z() + cam.cx, v = cam.fy * X.y() / X.z() + cam.cy;
    if (!(u >= -0.5 && u < cam.width - 0.5 && v >= -0.5 && v < cam.height - 0.5)) {
      ++out.dropped_left_image;
      continue;
    }
    out.u.push_back(u);
    out.v.push_back(v);
    out.t_s.push_back(static_cast<float>(dt_ns) * 1e-9f);
    out.pixel.push_back(static_cast<std::int32_t>(std::floor(v + 0.5)) * cam.width +
                        static_cast<std::int32_t>(std::floor(u + 0.5)));
    out.input_index.push_back(i);
  }
  return out;
}

}  // namespace fdv
