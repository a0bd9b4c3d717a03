#include "fdv/compensation/undistortion_map.h"

#include <cmath>

#include "fdv/core/error.h"
#include "fdv/core/fuzz_coverage.h"

namespace fdv {

FDV_NO_FUZZ_COVERAGE UndistortionMap::UndistortionMap(const PinholeCamera& camera) : camera_(camera) {
  if (const auto why = camera.validate(); !why.empty()) throw ConfigError("event camera: " + why);
  const std::size_t n = static_cast<std::size_t>(camera.width) * camera.height;
  rays_.resize(n);
  grid_index_.resize(n);
  // Without distortion the lens solver returns K⁻¹·px (PinholeCamera::undistort): the same
  // arithmetic without its per-pixel call, which was most of a new Perception's cost.
  const bool pinhole = camera.distortion.is_zero();
  for (int y = 0; y < camera.height; ++y) {
    Eigen::Vector2d near(-camera.cx / camera.fx, (y - camera.cy) / camera.fy);  // the row's left end
    for (int x = 0; x < camera.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * camera.width + x;
      // Plain doubles, not an Eigen vector: in the fuzz build each element access was a call.
      double nx = (x - camera.cx) / camera.fx, ny = (y - camera.cy) / camera.fy;
      if (!pinhole) {
        const Eigen::Vector2d xn = camera.undistort_near({nx, ny}, near);
        if (xn.allFinite()) near = xn;
        nx = xn.x(), ny = xn.y();
        if (!std::isfinite(nx) || !std::isfinite(ny)) {
          const float nan = std::nanf("");
          rays_[i] = {nan, nan};
          grid_index_[i] = kNoInverse;
          ++pixels_without_inverse_;
          continue;
        }
      }
      rays_[i] = {static_cast<float>(nx), static_cast<float>(ny)};
      const double u = camera.fx * nx + camera.cx, v = camera.fy * ny + camera.cy;
      if (u >= -0.5 && v >= -0.5 && u < camera.width - 0.5 && v < camera.height - 0.5) {
        const int ui = static_cast<int>(u + 0.5), vi = static_cast<int>(v + 0.5);
        grid_index_[i] = vi * camera.width + ui;
      } else {
        grid_index_[i] = kOutside;
      }
    }
  }
}

Eigen::Vector2d UndistortionMap::undistorted_to_raw(const Eigen::Vector2d& uv) const {
  return camera_.normalized_to_pixel({(uv.x() - camera_.cx) / camera_.fx, (uv.y() - camera_.cy) / camera_.fy});
}

}  // namespace fdv
