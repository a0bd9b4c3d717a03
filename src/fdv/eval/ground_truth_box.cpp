#include "fdv/eval/ground_truth_box.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace fdv {
namespace {

constexpr double kPi = 3.141592653589793;

/// The camera plus what the evaluation needs precomputed.
struct Lens {
  const PinholeCamera& cam;
  double r_valid = 0;  ///< normalised radius up to which the lens map is monotonic
  std::vector<Eigen::Vector3d> border_rays;  ///< unit rays through the image border pixels
  std::vector<Eigen::Vector2d> border_px;
  double f = 0;

  explicit Lens(const PinholeCamera& c) : cam(c), f(std::max(c.fx, c.fy)) {
    const auto& d = c.distortion;
    r_valid = 4.0;
    for (int i = 1; i <= 4000; ++i) {
      const double r = i * 1e-3, r2 = r * r;
      if (1 + 3 * d.k1 * r2 + 5 * d.k2 * r2 * r2 + 7 * d.k3 * r2 * r2 * r2 <= 0.05) {
        r_valid = r - 1e-3;
        break;
      }
    }
    auto add = [&](double u, double v) {
      const Eigen::Vector2d xn = c.pixel_to_normalized({u, v});
      if (!xn.allFinite()) return;
      border_rays.push_back(Eigen::Vector3d(xn.x(), xn.y(), 1).normalized());
      border_px.emplace_back(u, v);
    };
    const double u_lo = -0.5, u_hi = c.width - 0.5, v_lo = -0.5, v_hi = c.height - 0.5;
    for (double u = u_lo; u <= u_hi; u += 0.5) add(u, v_lo), add(u, v_hi);
    for (double v = v_lo + 0.5; v < v_hi; v += 0.5) add(u_lo, v), add(u_hi, v);
  }

  /// Projects a ray (any length, camera frame); false where the lens model does not apply.
  bool project(const Eigen::Vector3d& ray, Eigen::Vector2d& px) const {
    if (ray.z() <= 1e-9) return false;
    const Eigen::Vector2d xn = ray.head<2>() / ray.z();
    if (xn.norm() >= r_valid) return false;
    px = cam.normalized_to_pixel(xn);
    return true;
  }
  bool in_image(const Eigen::Vector2d& px) const { return cam.in_image(px); }
};

struct Instant {
  bool any = false;
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;  // clipped box
  double fraction = 0;
  double span = 0;
  /// Area centroid of the in-view part [raw px]; only when asked for and part of it is in view.
  std::optional<Eigen::Vector2d> centroid;
};

void orthonormal_basis(const Eigen::Vector3d& n, Eigen::Vector3d& e1, Eigen::Vector3d& e2) {
  const Eigen::Vector3d a =
      std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  e1 = n.cross(a).normalized();
  e2 = n.cross(e1);
}

Instant evaluate(const Eigen::Vector3d& c, double r, const Lens& lens,
                 const GroundTruthBoxOptions& opt, bool want_centroid = false) {
  Instant in;
  const auto& cam = lens.cam;
  const double L = c.norm();
  if (L <= r) {  // camera inside the ball: it fills the view
    in.any = true;
    in.u0 = -0.5, in.u1 = cam.width - 0.5, in.v0 = -0.5, in.v1 = cam.height - 0.5;
    in.fraction = 1;
    in.span = std::max(cam.width, cam.height);
    return in;
  }
  const Eigen::Vector3d axis = c / L;
  const double alpha = std::asin(r / L);
  const double ca = std::cos(alpha), sa = std::sin(alpha);
  Eigen::Vector3d e1, e2;
  orthonormal_basis(axis, e1, e2);

  // Boundary of the silhouette.
  const double r_px = lens.f * std::tan(std::min(alpha, 1.4)) / std::max(axis.z(), 0.2);
  const int k = std::clamp(
      static_cast<int>(std::ceil(kPi * std::sqrt(std::max(r_px, 1.0) / (2 * opt.max_error_px)))),
      64, 50000);
  double uu0 = 1e300, uu1 = -1e300, vv0 = 1e300, vv1 = -1e300;  // unclipped
  bool all_valid = true, all_inside = true, any_inside = false;
  for (int i = 0; i < k; ++i) {
    const double phi = 2 * kPi * i / k;
    const Eigen::Vector3d ray = ca * axis + sa * (std::cos(phi) * e1 + std::sin(phi) * e2);
    Eigen::Vector2d px;
    if (!lens.project(ray, px)) {
      all_valid = all_inside = false;
      continue;
    }
    uu0 = std::min(uu0, px.x()), uu1 = std::max(uu1, px.x());
    vv0 = std::min(vv0, px.y()), vv1 = std::max(vv1, px.y());
    if (lens.in_image(px)) {
      any_inside = true;
      in.u0 = std::min(in.u0, px.x()), in.u1 = std::max(in.u1, px.x());
      in.v0 = std::min(in.v0, px.y()), in.v1 = std::max(in.v1, px.y());
    } else {
      all_inside = false;
    }
  }
  in.span =
      all_valid ? std::max(uu1 - uu0, vv1 - vv0) : 2 * lens.f * std::tan(std::min(alpha, 1.4));
  if (all_inside && !want_centroid) {  // the whole silhouette is in the image
    in.any = true;
    in.fraction = 1;
    return in;
  }
  // Image border inside the cone bounds the visible part where the silhouette leaves the image.
  bool border_inside = false;
  for (std::size_t i = 0; i < lens.border_rays.size(); ++i)
    if (lens.border_rays[i].dot(axis) >= ca) {
      border_inside = true;
      const auto& px = lens.border_px[i];
      in.u0 = std::min(in.u0, px.x()), in.u1 = std::max(in.u1, px.x());
      in.v0 = std::min(in.v0, px.y()), in.v1 = std::max(in.v1, px.y());
    }
  in.any = all_inside || any_inside || border_inside;
  if (!in.any) return in;
  // Solid-angle fraction in view: a deterministic sunflower pattern over the spherical cap. The
  // centroid weighs each ray by the image area per solid angle there (1 / cos³ of its angle to
  // the optical axis, a pinhole's; distortion ignored).
  int inside = 0;
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  double weight = 0;
  const int n = opt.view_samples;
  for (int i = 0; i < n; ++i) {
    const double cos_t = 1 - (1 - ca) * (i + 0.5) / n;
    const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
    const double phi = i * 2.399963229728653;  // golden angle
    const Eigen::Vector3d ray = cos_t * axis + sin_t * (std::cos(phi) * e1 + std::sin(phi) * e2);
    Eigen::Vector2d px;
    if (!lens.project(ray, px) || !lens.in_image(px)) continue;
    ++inside;
    const double w = 1 / (ray.z() * ray.z() * ray.z());
    weighted += w * px;
    weight += w;
  }
  in.fraction = all_inside ? 1 : static_cast<double>(inside) / n;
  if (want_centroid && weight > 0) in.centroid = weighted / weight;
  return in;
}

/// Ball centre at t by cubic Hermite interpolation of (p, v) between the bracketing samples.
Eigen::Vector3d ball_at(const std::vector<ObjectState>& s, TimeNs t) {
  if (t <= s.front().t) return s.front().p_W;
  if (t >= s.back().t) return s.back().p_W;
  const auto hi = std::lower_bound(s.begin(), s.end(), t,
                                   [](const ObjectState& a, TimeNs tt) { return a.t < tt; });
  const auto lo = hi - 1;
  const double h = to_seconds(hi->t - lo->t);
  if (h <= 0) return hi->p_W;
  const double u = to_seconds(t - lo->t) / h;
  const double h00 = (1 + 2 * u) * (1 - u) * (1 - u), h10 = u * (1 - u) * (1 - u);
  const double h01 = u * u * (3 - 2 * u), h11 = u * u * (u - 1);
  return h00 * lo->p_W + h10 * h * lo->v_W + h01 * hi->p_W + h11 * h * hi->v_W;
}

OdometrySample body_at(std::span<const OdometrySample> body, TimeNs t) {
  if (t <= body.front().t) return body.front();
  if (t >= body.back().t) return body.back();
  const auto hi = std::lower_bound(body.begin(), body.end(), t,
                                   [](const OdometrySample& a, TimeNs tt) { return a.t < tt; });
  return interpolate_between(*(hi - 1), *hi, t);
}

/// The samples of ball `id`, in time order.
std::vector<ObjectState> states_of(std::span<const ObjectState> objects, int id) {
  std::vector<ObjectState> states;
  for (const auto& s : objects)
    if (s.id == id) states.push_back(s);
  return states;
}

/// The ball's centre in the event camera's frame at t, the camera held as `options` says.
Eigen::Vector3d center_in_camera(const std::vector<ObjectState>& states,
                                 std::span<const OdometrySample> body, const Eigen::Isometry3d& T_B_E,
                                 const GroundTruthBoxOptions& options, TimeNs t) {
  Eigen::Isometry3d T_W_E = body_at(body, options.rotation_time.value_or(t)).T_W_B() * T_B_E;
  T_W_E.translation() =
      (body_at(body, options.position_time.value_or(t)).T_W_B() * T_B_E).translation();
  return Eigen::Vector3d(T_W_E.inverse() * ball_at(states, t));
}

}  // namespace

VisibleSilhouette visible_silhouette(std::span<const ObjectState> objects, int id, double radius_m,
                                     std::span<const OdometrySample> body, const Calibration& calib,
                                     TimeNs t, const GroundTruthBoxOptions& options) {
  if (!(radius_m > 0)) throw std::invalid_argument("visible_silhouette: radius must be positive");
  VisibleSilhouette out;
  const std::vector<ObjectState> states = states_of(objects, id);
  if (states.empty() || body.empty() || t < states.front().t || t > states.back().t) return out;
  const Lens lens(calib.event_camera);
  const Eigen::Vector3d c = center_in_camera(states, body, calib.T_B_E, options, t);
  const Instant in = evaluate(c, radius_m, lens, options, /*want_centroid=*/true);
  if (!in.any) return out;
  out.visible = true;
  out.u_min = in.u0, out.v_min = in.v0, out.u_max = in.u1, out.v_max = in.v1;
  out.fraction_in_view = in.fraction;
  if (Eigen::Vector2d px; lens.project(c, px)) out.projected_center_px = px;
  if (in.fraction >= 1 && out.projected_center_px)
    out.visible_center_px = *out.projected_center_px;
  else if (in.centroid)
    out.visible_center_px = *in.centroid;
  else  // the camera inside the ball: all of the image is the ball
    out.visible_center_px = {(in.u0 + in.u1) / 2, (in.v0 + in.v1) / 2};
  return out;
}

GroundTruthBox ground_truth_box(std::span<const ObjectState> objects, int id, double radius_m,
                                std::span<const OdometrySample> body, const Calibration& calib,
                                TimeNs t0, TimeNs t1, const GroundTruthBoxOptions& options) {
  if (t1 < t0) throw std::invalid_argument("ground_truth_box: t1 < t0");
  if (!(radius_m > 0)) throw std::invalid_argument("ground_truth_box: radius must be positive");
  GroundTruthBox box;
  const std::vector<ObjectState> states = states_of(objects, id);
  if (states.empty() || body.empty()) return box;
  const TimeNs lo = std::max(t0, states.front().t), hi = std::min(t1, states.back().t);
  if (hi < lo) return box;

  const Lens lens(calib.event_camera);
  const auto center_at = [&](TimeNs t) {
    return center_in_camera(states, body, calib.T_B_E, options, t);
  };

  // Instants: the interval ends and every truth sample inside, refined by the motion between.
  std::vector<TimeNs> knots{lo};
  for (const auto& s : states)
    if (s.t > lo && s.t < hi) knots.push_back(s.t);
  if (hi > lo) knots.push_back(hi);

  double fraction_sum = 0;
  box.fraction_in_view_min = 1e300;
  box.span_px_min = 1e300;
  box.u_min = box.v_min = 1e300;
  box.u_max = box.v_max = -1e300;
  auto accumulate = [&](const Instant& in) {
    ++box.samples;
    fraction_sum += in.fraction;
    box.fraction_in_view_min = std::min(box.fraction_in_view_min, in.fraction);
    box.fraction_in_view_max = std::max(box.fraction_in_view_max, in.fraction);
    box.span_px_min = std::min(box.span_px_min, in.span);
    box.span_px_max = std::max(box.span_px_max, in.span);
    if (!in.any) return;
    box.visible = true;
    box.u_min = std::min(box.u_min, in.u0), box.u_max = std::max(box.u_max, in.u1);
    box.v_min = std::min(box.v_min, in.v0), box.v_max = std::max(box.v_max, in.v1);
  };
  const double magnification = 1.3;  // bound on the lens's local scale relative to f
  Eigen::Vector3d c_prev = center_at(knots.front());
  accumulate(evaluate(c_prev, radius_m, lens, options));
  for (std::size_t i = 1; i < knots.size(); ++i) {
    const Eigen::Vector3d c_next = center_at(knots[i]);
    const double a0 = std::asin(std::min(1.0, radius_m / c_prev.norm()));
    const double a1 = std::asin(std::min(1.0, radius_m / c_next.norm()));
    const double turn =
        std::atan2(c_prev.cross(c_next).norm(), c_prev.dot(c_next)) + std::abs(a1 - a0);
    const double dz = std::max(0.2, std::min(c_prev.normalized().z(), c_next.normalized().z()));
    const int n = std::max(1, static_cast<int>(std::ceil(turn * lens.f * magnification / (dz * dz) /
                                                         options.max_step_px)));
    for (int j = 1; j <= n; ++j) {
      const TimeNs t = knots[i - 1] + (knots[i] - knots[i - 1]) * j / n;
      accumulate(evaluate(j == n ? c_next : center_at(t), radius_m, lens, options));
    }
    c_prev = c_next;
  }
  box.fraction_in_view_mean = fraction_sum / box.samples;
  if (!box.visible) box.u_min = box.v_min = box.u_max = box.v_max = 0;
  return box;
}

}  // namespace fdv
