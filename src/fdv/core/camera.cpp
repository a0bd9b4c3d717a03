#include "fdv/core/camera.h"

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <sstream>

namespace fdv {

std::string PinholeCamera::validate() const {
  std::ostringstream why;
  const double values[] = {fx, fy, cx, cy, distortion.k1, distortion.k2,
                           distortion.p1, distortion.p2, distortion.k3};
  for (double v : values)
    if (!std::isfinite(v)) return "non-finite intrinsic or distortion value";
  if (width <= 0 || height <= 0 || width > kMaxCameraSide || height > kMaxCameraSide) {
    why << "resolution must be 1 to " << kMaxCameraSide << " pixels a side, got " << width << "x" << height;
  } else if (!(fx >= kMinFocalPx && fx <= kMaxFocalPx && fy >= kMinFocalPx && fy <= kMaxFocalPx)) {
    why << "focal lengths must be " << kMinFocalPx << " to " << kMaxFocalPx << " px, got fx=" << fx << " fy=" << fy;
  } else if (cx < -width || cx > 2.0 * width || cy < -height || cy > 2.0 * height) {
    why << "principal point (" << cx << ", " << cy << ") is far outside the " << width << "x"
        << height << " image";
  }
  return why.str();
}

Eigen::Vector2d PinholeCamera::undistort(const Eigen::Vector2d& xd) const {
  if (distortion.is_zero()) return xd;
  // Damped Newton from the distorted point itself (distortion is a perturbation of identity
  // near the centre). The solution must lie where the lens map is locally invertible: polynomial
  // models fold back on themselves beyond the calibrated field of view, and no inverse exists
  // there.
  const LensInversion inverse = invert_distortion(xd, xd);
  if (inverse.residual > 1e-9 || inverse.folded) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan};
  }
  return inverse.xn;
}

namespace {

/// 1 + k1 r² + k2 r⁴ + k3 r⁶: the radial part of distort() at squared radius r2.
double radial_factor(const Distortion& d, double r2) { return 1 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3)); }

/// d distort / d xn at xn.
Eigen::Matrix2d distortion_jacobian(const Distortion& d, const Eigen::Vector2d& xn) {
  const double x = xn.x(), y = xn.y();
  const double r2 = x * x + y * y;
  const double radial = radial_factor(d, r2);
  const double dradial_dr2 = d.k1 + r2 * (2 * d.k2 + 3 * r2 * d.k3);
  Eigen::Matrix2d J;
  J(0, 0) = radial + 2 * x * x * dradial_dr2 + 2 * d.p1 * y + 6 * d.p2 * x;
  J(0, 1) = 2 * x * y * dradial_dr2 + 2 * d.p1 * x + 2 * d.p2 * y;
  J(1, 0) = J(0, 1);
  J(1, 1) = radial + 2 * y * y * dradial_dr2 + 6 * d.p1 * y + 2 * d.p2 * x;
  return J;
}

}  // namespace

LensInversion PinholeCamera::invert_distortion(const Eigen::Vector2d& xd,
                                               const Eigen::Vector2d& start,
                                               const LensInversionSettings& settings) const {
  LensInversion out;
  out.xn = start;
  Eigen::Vector2d residual = distort(out.xn) - xd;
  for (int steps = 0; steps < settings.max_steps && !(residual.norm() < settings.tolerance);
       ++steps) {
    const Eigen::Matrix2d J = distortion_jacobian(distortion, out.xn);
    if (J.determinant() <= 0) {
      out.folded = true;
      break;
    }
    const Eigen::Vector2d step = J.inverse() * residual;
    // A damped step is accepted only if it reduces the residual.
    double scale = 1.0;
    bool taken = false;
    for (int halvings = 0; halvings < 20; ++halvings, scale *= 0.5) {
      const Eigen::Vector2d candidate = out.xn - scale * step;
      const Eigen::Vector2d r = distort(candidate) - xd;
      if (!settings.damped || r.squaredNorm() < residual.squaredNorm()) {
        out.xn = candidate;
        residual = r;
        taken = true;
        break;
      }
    }
    if (!taken) break;
  }
  out.residual = residual.norm();
  return out;
}

Eigen::Vector2d PinholeCamera::undistort_near(const Eigen::Vector2d& xd, const Eigen::Vector2d& near) const {
  constexpr LensInversionSettings kFromNeighbour{.max_steps = 19, .tolerance = 1e-13, .damped = false};
  const LensInversion inverse = invert_distortion(xd, near, kFromNeighbour);
  // Undamped steps can leap past the lens map's fold onto a branch where it has turned back (det J
  // ≤ 0) or even mirrored the image (a negative radial factor): a root there is no inverse.
  const Eigen::Vector2d& xn = inverse.xn;
  const bool on_the_lens = radial_factor(distortion, xn.squaredNorm()) > 0 &&
                           distortion_jacobian(distortion, xn).determinant() > 0;
  return !inverse.folded && inverse.residual < kFromNeighbour.tolerance && on_the_lens ? xn : undistort(xd);
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& X) const {
  return normalized_to_pixel(X.head<2>() / X.z());
}

Eigen::Vector2d PinholeCamera::pixel_to_normalized(const Eigen::Vector2d& px) const {
  return undistort({(px.x() - cx) / fx, (px.y() - cy) / fy});
}

Eigen::Vector2d PinholeCamera::undistort_pixel(const Eigen::Vector2d& px) const {
  const Eigen::Vector2d xn = pixel_to_normalized(px);
  return {fx * xn.x() + cx, fy * xn.y() + cy};
}

Eigen::Vector3d PinholeCamera::back_project(const Eigen::Vector2d& px, double depth_m) const {
  const Eigen::Vector2d xn = pixel_to_normalized(px);
  return {xn.x() * depth_m, xn.y() * depth_m, depth_m};
}

}  // namespace fdv
