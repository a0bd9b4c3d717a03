#pragma once
/// Pinhole camera with radial-tangential ("plumb bob", OpenCV) distortion k1 k2 p1 p2 k3.
///
///   PinholeCamera cam{640, 480, 536.3, 536.3, 320.9, 234.0, {k1, k2, p1, p2, k3}};
///   Eigen::Vector2d px = cam.project(X_E);              // raw (distorted) pixel
///   Eigen::Vector3d X = cam.back_project(px, depth_m);  // point in E with z = depth_m
///
/// Raw pixels are what the sensor reports; "undistorted" pixels are K·(normalised coordinates).
/// Undistortion inverts the distortion by damped Newton iterations, exact to < 1e-9 (normalised
/// units). Where the lens polynomial is not invertible (it folds back beyond the calibrated field
/// of view, as in the corners of the real DAVIS346 calibration) the result is NaN, never a wrong
/// point: callers treat such pixels as unusable. Thread-safe (const).
#include <Eigen/Core>
#include <array>
#include <string>

namespace fdv {

struct Distortion {
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  bool is_zero() const { return k1 == 0 && k2 == 0 && p1 == 0 && p2 == 0 && k3 == 0; }
};

/// How PinholeCamera::invert_distortion iterates Newton's method on distort(xn) = xd.
struct LensInversionSettings {
  int max_steps = 50;
  double tolerance = 1e-15;  ///< stops once |distort(xn) - xd| < tolerance (normalised units)
  /// Halves a step until it reduces the residual: needed from a cold start far out in a strongly
  /// distorted lens; from a nearby solution the plain step converges.
  bool damped = true;
};

/// Where PinholeCamera::invert_distortion stopped.
struct LensInversion {
  Eigen::Vector2d xn;   ///< the last iterate (normalised undistorted coordinates)
  double residual = 0;  ///< |distort(xn) - xd|
  bool folded = false;  ///< stopped where the lens map folds back (det J <= 0): no inverse there
};

/// The largest image side any camera may declare [px], whatever its source (a calibration file, a
/// dataset, a message): image-sized buffers are allocated from it.
inline constexpr int kMaxCameraSide = 4096;
/// The focal lengths a camera may have [px]: outside, a lens is not a pinhole camera of this scale
/// (1 px: a 180° view of a 2-pixel image; 1e6 px: a 0.2° view of the largest image).
inline constexpr double kMinFocalPx = 1, kMaxFocalPx = 1e6;

struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  Distortion distortion;

  /// Empty when valid, else a readable reason (a size outside 1..kMaxCameraSide, a focal length
  /// outside kMinFocalPx..kMaxFocalPx, a non-finite value, a principal point far outside the image).
  std::string validate() const;

  /// Normalised undistorted coordinates (x/z, y/z) -> normalised distorted coordinates.
  /// (Defined here, as normalized_to_pixel: per-pixel loops such as depth registration inline them.)
  Eigen::Vector2d distort(const Eigen::Vector2d& xn) const {
    const auto& d = distortion;
    const double x = xn.x(), y = xn.y();
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
    return {x * radial + 2 * d.p1 * x * y + d.p2 * (r2 + 2 * x * x),
            y * radial + d.p1 * (r2 + 2 * y * y) + 2 * d.p2 * x * y};
  }
  /// Inverse of distort(); NaN where the lens map has no inverse.
  Eigen::Vector2d undistort(const Eigen::Vector2d& xd) const;
  /// Newton's method on distort(xn) = xd from `start`, the solver undistort() uses (from xd
  /// itself, with the default settings), for callers with a better start, e.g. the solution of a
  /// neighbouring pixel. The caller judges the result (residual, folded).
  LensInversion invert_distortion(const Eigen::Vector2d& xd, const Eigen::Vector2d& start,
                                  const LensInversionSettings& settings = {}) const;
  /// undistort() for a scan of the image: plain Newton steps from `near`, a neighbouring pixel's
  /// solution (2-3 steps where a cold start takes about twice as many, and the damped solver's
  /// last step halves itself up to 20 times at the limit of double precision), undistort() where
  /// they do not converge to 1e-13 on the lens's invertible part. NaN where the lens map has no
  /// inverse.
  Eigen::Vector2d undistort_near(const Eigen::Vector2d& xd, const Eigen::Vector2d& near) const;

  /// Point in the camera frame (z > 0) -> raw pixel.
  Eigen::Vector2d project(const Eigen::Vector3d& X) const;
  /// Raw pixel -> normalised undistorted coordinates (x/z, y/z).
  Eigen::Vector2d pixel_to_normalized(const Eigen::Vector2d& px) const;
  /// Normalised undistorted coordinates -> raw pixel.
  Eigen::Vector2d normalized_to_pixel(const Eigen::Vector2d& xn) const {
    const Eigen::Vector2d xd = distort(xn);
    return {fx * xd.x() + cx, fy * xd.y() + cy};
  }
  /// Raw pixel -> undistorted pixel K·xn.
  Eigen::Vector2d undistort_pixel(const Eigen::Vector2d& px) const;
  /// Raw pixel and z-depth -> point in the camera frame.
  Eigen::Vector3d back_project(const Eigen::Vector2d& px, double depth_m) const;

  bool in_image(const Eigen::Vector2d& px) const {
    return px.x() >= -0.5 && px.y() >= -0.5 && px.x() < width - 0.5 && px.y() < height - 0.5;
  }
};

}  // namespace fdv
