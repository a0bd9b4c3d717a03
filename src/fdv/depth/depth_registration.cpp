#include "fdv/depth/depth_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/core/lanes.h"

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
  // The same rays in the event camera's orientation, R_E_D·[x; y; 1] (NaN stays NaN): per frame a
  // point is then X_E = z·ray + t_E_D, three products instead of a matrix.
  ray_E_x_.resize(n);
  ray_E_y_.resize(n);
  ray_E_z_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d r = R_E_D_ * Eigen::Vector3d(rays_[2 * i], rays_[2 * i + 1], 1.0);
    ray_E_x_[i] = static_cast<float>(r.x());
    ray_E_y_[i] = static_cast<float>(r.y());
    ray_E_z_[i] = static_cast<float>(r.z());
  }
}

namespace {

using vf8 = float __attribute__((vector_size(32)));
using vi8 = std::int32_t __attribute__((vector_size(32)));
typedef float vf8_u __attribute__((vector_size(32), aligned(4)));

/// Everything the per-pixel loop reads, as plain numbers (single precision: see register_frame()).
struct Projection {
  const float* depth;
  const float *ray_x, *ray_y, *ray_z;  ///< R_E_D·[x_D; 1] per depth pixel
  float lo, hi;
  float t[3];  ///< t_E_D
  float fx, fy, cx, cy, k1, k2, p1, p2, k3;
  float max_r2, u_hi, v_hi;
};

struct Tally {
  std::uint64_t invalid = 0, no_inverse = 0, behind = 0, outside = 0, registered = 0, occluded = 0;
};

/// The z-test of one registered pixel (cells hold +inf where nothing landed yet). One of the two
/// points on a cell is occluded whichever is nearer: a point that lands on a cell already holding
/// one counts as occluded. Without branches: which point is nearer is a coin toss on a textured
/// surface, and the mispredicted branches were a tenth of the registration's samples.
inline void splat(float& cell, float z_e, Tally& c) {
  const float inf = std::numeric_limits<float>::infinity();
  ++c.registered;
  c.occluded += cell != inf;
  cell = z_e < cell ? z_e : cell;
}

/// Pixels [i0, n) one at a time: the same operations, in the same order, as project_all's lanes.
void project_tail(const Projection& p, std::size_t i0, std::size_t n, int out_width, float* cells, Tally& c) {
  for (std::size_t i = i0; i < n; ++i) {
    const float z = p.depth[i], rx = p.ray_x[i], ry = p.ray_y[i], rz = p.ray_z[i];
    const bool valid = z >= p.lo && z <= p.hi;
    const bool has_ray = valid && !std::isnan(rx);
    const float Xe = z * rx + p.t[0], Ye = z * ry + p.t[1], Ze = z * rz + p.t[2];
    const bool front = has_ray && Ze > 0;
    const float x = Xe / Ze, y = Ye / Ze, r2 = x * x + y * y;
    const float radial = 1 + r2 * (p.k1 + r2 * (p.k2 + r2 * p.k3));
    const float xd = (x * radial + 2 * p.p1 * x * y) + p.p2 * (r2 + 2 * x * x);
    const float yd = (y * radial + p.p1 * (r2 + 2 * y * y)) + 2 * p.p2 * x * y;
    const float u = p.fx * xd + p.cx, v = p.fy * yd + p.cy;
    const bool inside = front && !(r2 > p.max_r2) && u >= -0.5f && v >= -0.5f && u < p.u_hi && v < p.v_hi;
    c.invalid += !valid;
    c.no_inverse += valid && !has_ray;
    c.behind += has_ray && !front;
    c.outside += front && !inside;
    if (inside)
      splat(cells[static_cast<std::size_t>(static_cast<int>(v + 0.5f)) * out_width + static_cast<int>(u + 0.5f)], Ze, c);
  }
}

/// All pixels, eight at a time in float lanes (the AVX2 clone holds them in one register, the
/// baseline in two SSE2 ones), then each lane's z-test in pixel order. No FMA (neither clone
/// enables it), so the lanes give project_tail's results to the bit.
FDV_AVX2_CLONES void project_all(const Projection& p, std::size_t n, int out_width,
                                                                     float* cells, Tally& c) {
  const vf8 lo = vf8{} + p.lo, hi = vf8{} + p.hi, zero = vf8{}, one = vf8{} + 1.0f, half = vf8{} + 0.5f;
  const vf8 two_p1 = vf8{} + 2 * p.p1, two_p2 = vf8{} + 2 * p.p2, two = vf8{} + 2.0f;
  const vf8 u_lo = vf8{} - 0.5f, u_hi = vf8{} + p.u_hi, v_hi = vf8{} + p.v_hi, max_r2 = vf8{} + p.max_r2;
  vi8 invalid{}, no_inverse{}, behind{}, outside{};
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const vf8 z = *reinterpret_cast<const vf8_u*>(p.depth + i);
    const vi8 valid = (z >= lo) & (z <= hi);
    invalid -= ~valid;
    // Invalid depth comes in regions (the simulated frames: 26 % invalid, mostly in long runs):
    // skip their arithmetic.
    bool any = false;
    for (int j = 0; j < 8; ++j) any |= valid[j] != 0;
    if (!any) continue;
    const vf8 rx = *reinterpret_cast<const vf8_u*>(p.ray_x + i), ry = *reinterpret_cast<const vf8_u*>(p.ray_y + i),
              rz = *reinterpret_cast<const vf8_u*>(p.ray_z + i);
    const vi8 has_ray = valid & (rx == rx);
    const vf8 Xe = z * rx + p.t[0], Ye = z * ry + p.t[1], Ze = z * rz + p.t[2];
    const vi8 front = has_ray & (Ze > zero);
    const vf8 x = Xe / Ze, y = Ye / Ze, r2 = x * x + y * y;
    const vf8 radial = one + r2 * (p.k1 + r2 * (p.k2 + r2 * p.k3));
    const vf8 xd = (x * radial + two_p1 * x * y) + p.p2 * (r2 + two * x * x);
    const vf8 yd = (y * radial + p.p1 * (r2 + two * y * y)) + two_p2 * x * y;
    const vf8 u = p.fx * xd + p.cx, v = p.fy * yd + p.cy;
    const vi8 inside = front & ~(r2 > max_r2) & (u >= u_lo) & (v >= u_lo) & (u < u_hi) & (v < v_hi);
    no_inverse -= valid & ~has_ray;
    behind -= has_ray & ~front;
    outside -= front & ~inside;
    bool any_inside = false;
    for (int j = 0; j < 8; ++j) any_inside |= inside[j] != 0;
    if (!any_inside) continue;
    // Lanes outside convert 0 (their coordinates may be out of the int range).
    const vi8 iu = __builtin_convertvector(inside ? u + half : zero, vi8);
    const vi8 iv = __builtin_convertvector(inside ? v + half : zero, vi8);
    for (int j = 0; j < 8; ++j)
      if (inside[j]) splat(cells[static_cast<std::size_t>(iv[j]) * out_width + iu[j]], Ze[j], c);
  }
  for (int j = 0; j < 8; ++j) {
    c.invalid += static_cast<std::uint64_t>(invalid[j]);
    c.no_inverse += static_cast<std::uint64_t>(no_inverse[j]);
    c.behind += static_cast<std::uint64_t>(behind[j]);
    c.outside += static_cast<std::uint64_t>(outside[j]);
  }
  project_tail(p, i, n, out_width, cells, c);
}

}  // namespace

std::string DepthRegistrar::check_frame(const DepthFrame& frame) const {
  const std::size_t n = static_cast<std::size_t>(depth_camera_.width) * depth_camera_.height;
  std::ostringstream why;
  if (frame.width != depth_camera_.width || frame.height != depth_camera_.height)
    why << "depth frame is " << frame.width << "x" << frame.height << " but the depth camera is calibrated for "
        << depth_camera_.width << "x" << depth_camera_.height;
  else if (frame.depth_m.size() != n)
    why << "depth frame holds " << frame.depth_m.size() << " values, expected " << n;
  return why.str();
}

bool DepthRegistrar::begin_frame(const DepthFrame& frame, DepthRegistrationResult& result) const {
  if (result.rejected = check_frame(frame); !result.rejected.empty()) return false;
  RegisteredDepth& out = result.depth;
  out.t = frame.t;
  out.width = event_camera_.width;
  out.height = event_camera_.height;
  // z-buffer in place: "no depth yet" is +inf while splatting, 0 afterwards (end_frame).
  out.depth_m.assign(static_cast<std::size_t>(out.width) * out.height, std::numeric_limits<float>::infinity());
  return true;
}

void DepthRegistrar::end_frame(RegisteredDepth& out) {
  // A select, not a branch: holes are scattered (mispredicted branches made this loop a quarter
  // of the frame's time).
  const float inf = std::numeric_limits<float>::infinity();
  for (float& z : out.depth_m) z = z == inf ? 0.0f : z;
}

DepthRegistrationResult DepthRegistrar::register_frame(const DepthFrame& frame) const {
  DepthRegistrationResult result;
  if (!begin_frame(frame, result)) return result;
  RegisteredDepth& out = result.depth;
  const Distortion& d = event_camera_.distortion;
  const auto f = [](double v) { return static_cast<float>(v); };
  const Projection p{.depth = frame.depth_m.data(),
                     .ray_x = ray_E_x_.data(),
                     .ray_y = ray_E_y_.data(),
                     .ray_z = ray_E_z_.data(),
                     .lo = f(options_.min_depth_m),
                     .hi = f(options_.max_depth_m),
                     .t = {f(t_E_D_.x()), f(t_E_D_.y()), f(t_E_D_.z())},
                     .fx = f(event_camera_.fx),
                     .fy = f(event_camera_.fy),
                     .cx = f(event_camera_.cx),
                     .cy = f(event_camera_.cy),
                     .k1 = f(d.k1),
                     .k2 = f(d.k2),
                     .p1 = f(d.p1),
                     .p2 = f(d.p2),
                     .k3 = f(d.k3),
                     .max_r2 = f(max_radius2_event_),
                     .u_hi = f(event_camera_.width - 0.5),
                     .v_hi = f(event_camera_.height - 0.5)};
  Tally c;
  project_all(p, frame.depth_m.size(), out.width, out.depth_m.data(), c);
  out.registered = c.registered;
  out.occluded = c.occluded;
  out.invalid_input = c.invalid;
  out.no_inverse = c.no_inverse;
  out.behind_camera = c.behind;
  out.outside_image = c.outside;
  end_frame(out);
  return result;
}

DepthRegistrationResult DepthRegistrar::register_frame_plain(const DepthFrame& frame) const {
  DepthRegistrationResult result;
  if (!begin_frame(frame, result)) return result;
  RegisteredDepth& out = result.depth;
  const float inf = std::numeric_limits<float>::infinity();
  const std::size_t n = frame.depth_m.size();
  for (std::size_t i = 0; i < n; ++i) {
    const float z_d = frame.depth_m[i];
    if (!(z_d >= options_.min_depth_m && z_d <= options_.max_depth_m)) {
      ++out.invalid_input;
      continue;
    }
    const float xn = rays_[2 * i], yn = rays_[2 * i + 1];
    if (std::isnan(xn)) {
      ++out.no_inverse;
      continue;
    }
    const Eigen::Vector3d X_D(xn * static_cast<double>(z_d), yn * static_cast<double>(z_d), z_d);
    const Eigen::Vector3d X_E = R_E_D_ * X_D + t_E_D_;
    if (!(X_E.z() > 0)) {
      ++out.behind_camera;
      continue;
    }
    const Eigen::Vector2d xn_e = X_E.head<2>() / X_E.z();
    const Eigen::Vector2d px = event_camera_.normalized_to_pixel(xn_e);
    if (xn_e.squaredNorm() > max_radius2_event_ || !event_camera_.in_image(px)) {
      ++out.outside_image;
      continue;
    }
    // Nearest pixel (in_image guarantees px + 0.5 >= 0, so truncation is floor).
    float& cell = out.depth_m[static_cast<std::size_t>(px.y() + 0.5) * out.width + static_cast<std::size_t>(px.x() + 0.5)];
    ++out.registered;
    const float z_e = static_cast<float>(X_E.z());
    if (z_e < cell) {
      if (cell != inf) ++out.occluded;
      cell = z_e;
    } else {
      ++out.occluded;
    }
  }
  end_frame(out);
  return result;
}

}  // namespace fdv
