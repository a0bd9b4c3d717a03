#pragma once
/// One detected moving object in one event window. Plain value type (Eigen only), so tracking
/// and output code can use it without OpenCV.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <Eigen/Core>
#include <optional>
#include <string_view>

#include "fdv/core/time.h"

namespace fdv {

/// Axis-aligned box [x0, x1] × [y0, y1] in continuous pixel coordinates (pixel centres at integers).
struct Box2D {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double width() const { return x1 - x0; }
  double height() const { return y1 - y0; }
  Eigen::Vector2d center() const { return {0.5 * (x0 + x1), 0.5 * (y0 + y1)}; }
  bool contains(const Eigen::Vector2d& p) const { return p.x() >= x0 && p.x() <= x1 && p.y() >= y0 && p.y() <= y1; }
  Box2D moved_by(const Eigen::Vector2d& d) const { return {x0 + d.x(), y0 + d.y(), x1 + d.x(), y1 + d.y()}; }
  bool intersects(const Box2D& b) const { return x0 <= b.x1 && b.x0 <= x1 && y0 <= b.y1 && b.y0 <= y1; }
};

enum class DetectionSource {
  kGaussianFit,      ///< Algorithm 1 converged to a plausible ROI
  kRegionRetrieval,  ///< connected component chosen after the fit failed (paper §IV-B.3)
  kDenseMotion,      ///< the dense-motion source (DetectorOptions::dense_motion), when N had no pattern
  kCountContrast,    ///< the count-contrast source (DetectorOptions::count_contrast), when nothing else passed
  kEvidence,         ///< the evidence source (DetectorOptions::evidence): evidence over windows, when nothing else passed
};
std::string_view to_string(DetectionSource s);

struct Detection2D {
  /// Mean time of the compensated events inside the box (not the window start).
  TimeNs t = 0;
  // On the compensated, undistorted pixel grid K·xn where the time images live: the camera at the
  // window's start (the events were warped there).
  Box2D box_undistorted;
  Eigen::Vector2d center_undistorted = Eigen::Vector2d::Zero();
  // The fields below are in the camera at t (CompensatedEventsView::observed_at undoes the
  // ego-motion warp between t_start and t): what the tracker, the estimator (which pairs the
  // center with the camera pose at t) and the evaluation use.
  /// The centre as normalised undistorted coordinates (x/z, y/z) of the event camera.
  Eigen::Vector2d center_normalized = Eigen::Vector2d::Zero();
  // In raw (distorted) sensor pixels: the centre mapped through the lens model, and the bounding
  // box of the undistorted box's outline (moved with the centre) mapped the same way.
  Box2D box_raw;
  Eigen::Vector2d center_raw = Eigen::Vector2d::Zero();
  int events = 0;      ///< compensated events inside the box
  /// Peak of the filtered segmentation (mean-filtered, opened S, before squaring) inside the box,
  /// in [0, 1]: the local density and recency of the segmented pattern; 1 = a fully segmented
  /// neighbourhood at N = 1. Same scale as GaussianFitSourceOptions::min_peak, the detection threshold.
  /// For source kDenseMotion: the R² of the time plane (DenseMotionSourceOptions::min_r2).
  /// For source kCountContrast: 1 − 1/contrast, the fraction of the centre box's events above the
  /// background level (CountContrastSourceOptions::min_contrast).
  double score = 0;
  /// Compensated events per pixel of the box (gate DetectorOptions::min_event_density).
  double event_density = 0;
  DetectionSource source = DetectionSource::kGaussianFit;
  int fit_iterations = 0;
  /// Found only with a track's prior (DetectionPrior), at the lower evidence threshold.
  bool track_aided = false;
  /// The object is cut by the frame's border: the boxes and centres above are of its visible
  /// part (box_raw clipped to the sensor), `visible_fraction` estimates how much of its
  /// silhouette is in the frame, and `center_full_raw` the whole object's centre where the
  /// uncut side gives its size (docs/DETECTION.md "Objects cut by the border").
  bool partial = false;
  double visible_fraction = 1;
  std::optional<Eigen::Vector2d> center_full_raw;
};

}  // namespace fdv
