#pragma once
/// The winning candidate's centre and time re-estimated from the events themselves
/// (docs/DETECTION.md, "centre and time"): the centroid and mean time of a time-complete slice of
/// the object around the box, by mean shift with a flat square kernel. Removes the forward bias of
/// the segmented pattern's centroid (the pattern is the object's latest sweep). A box on a fragment
/// of a larger object grows until the square holds the whole object.
///
///   EventRefiner refiner(options);      // once; allocate(width, height) before the first refine()
///   if (auto r = refiner.refine(view, box, t_mean_s)) { centre = r->center; t = r->t_mean_s; }
///
/// Options: DetectorOptions::refine_box_scale, refine_recenter_passes, refine_grow_density,
/// refine_grow_contrast, fills_view_fraction, roi_min_events.
/// Does not allocate once allocated. Not thread-safe.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>

#include "fdv/detection/detection2d.h"
#include "fdv/detection/detector_options.h"
#include "fdv/detection/time_images.h"

namespace fdv {

struct RefinedCenter {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< undistorted grid [px]
  double t_mean_s = 0;                               ///< [s since t_start]
  /// The object's extent [px]: the box's longer side, or, when the square grew past a fragment of a
  /// larger object, the diameter that the last two squares bracket.
  double extent_px = 0;
};

class EventRefiner {
 public:
  explicit EventRefiner(const DetectorOptions& options) : options_(options) {}
  void allocate(int width, int height);
  /// Centroid and mean time of the events in a time-complete slice around `box` (whose events' mean
  /// time is t_box_s), or nothing when too few or when the centroid leaves the box's reach. When
  /// the square grew and then failed either test, the last square's result.
  std::optional<RefinedCenter> refine(const CompensatedEventsView& window, const Box2D& box, double t_box_s);

 private:
  /// The centre of the ellipse fitted to `square`'s pixels with an event in acc_, when it is a
  /// plausible outline of an object of `extent` px whose events' centroid is `centroid`.
  std::optional<Eigen::Vector2d> outline_center(const cv::Rect& square, const Eigen::Vector2d& centroid,
                                                double extent) const;
  /// Runs the ellipse fit's code paths once, so that the first window does not pay for loading them.
  static void warm_up_outline_fit();

  DetectorOptions options_;
  cv::Mat acc_;  ///< the slice's events per pixel: (count, Σt), CV_32FC2
};

}  // namespace fdv
