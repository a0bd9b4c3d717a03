#pragma once
/// Per-pixel undistortion of the event camera, computed once per calibration.
///
///   auto map = std::make_shared<const UndistortionMap>(calibration.event_camera);
///   const NormalizedRay r = map->ray(x, y);          // normalised undistorted (x/z, y/z), NaN = none
///   std::int32_t i = map->grid_index(x, y);          // nearest pixel of the undistorted grid, or < 0
///
/// The undistorted grid is the pinhole image K·xn with the event camera's own K and size: time
/// images and detections live on it (docs/DETECTION.md). Raw pixels whose lens map has no inverse
/// (PinholeCamera::undistort returns NaN, e.g. the folded-back corners of a strongly distorted
/// lens) are marked and their events are counted and dropped by the compensators.
/// Immutable after construction: share one instance between threads and compensators.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "fdv/core/camera.h"

namespace fdv {

struct NormalizedRay {
  float x = 0, y = 0;  ///< normalised undistorted coordinates; NaN when the pixel has no inverse
};

class UndistortionMap {
 public:
  static constexpr std::int32_t kNoInverse = -1;  ///< grid_index(): lens map not invertible
  static constexpr std::int32_t kOutside = -2;    ///< grid_index(): lands outside the grid

  explicit UndistortionMap(const PinholeCamera& camera);

  const PinholeCamera& camera() const { return camera_; }
  int width() const { return camera_.width; }
  int height() const { return camera_.height; }
  /// Raw pixel (x, y) must be inside the sensor.
  NormalizedRay ray(int x, int y) const { return rays_[static_cast<std::size_t>(y) * camera_.width + x]; }
  const NormalizedRay* rays() const { return rays_.data(); }
  /// Row-major index of the undistorted-grid pixel nearest to K·xn of raw pixel (x, y), or
  /// kNoInverse / kOutside.
  std::int32_t grid_index(int x, int y) const { return grid_index_[static_cast<std::size_t>(y) * camera_.width + x]; }
  const std::int32_t* grid_indices() const { return grid_index_.data(); }
  /// Raw pixels without an inverse (their events are dropped).
  int pixels_without_inverse() const { return pixels_without_inverse_; }

  /// Undistorted-grid point (K·xn) -> raw sensor pixel (exact: applies the lens polynomial).
  Eigen::Vector2d undistorted_to_raw(const Eigen::Vector2d& uv) const;
  /// Raw sensor pixel (continuous) -> undistorted-grid point; NaN without an inverse.
  Eigen::Vector2d raw_to_undistorted(const Eigen::Vector2d& px) const { return camera_.undistort_pixel(px); }

 private:
  PinholeCamera camera_;
  std::vector<NormalizedRay> rays_;
  std::vector<std::int32_t> grid_index_;
  int pixels_without_inverse_ = 0;
};

}  // namespace fdv
