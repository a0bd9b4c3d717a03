#pragma once
/// Ground-truth image box of a ball over a time interval: the raw-pixel bounding box of the
/// union of the ball's projected silhouette during [t0, t1], with how much of the ball was in
/// view and how large it looked.
///
///   GroundTruthBox box = ground_truth_box(objects, /*id=*/1, /*radius_m=*/0.105, body_truth,
///                                         calib, t0, t1);
///   if (box.visible && box.contains(e.x, e.y)) ...
///
/// Silhouette: a sphere of radius r whose centre is at distance L from the camera is seen as
/// the cone of rays at angle asin(r / L) around the centre direction (not centre ± f r / z,
/// which is too small off-axis and near the camera). The cone's boundary is projected through
/// the full lens model (distortion included) at enough points that the box is within ~0.01 px
/// of the true extreme; where the silhouette leaves the image the box is clipped to the image
/// and the image border inside the cone counts. Times: the interval is sampled at every truth
/// sample and in between, densely enough that the silhouette moves ≤ max_step_px between
/// samples. Ball positions between truth samples by cubic Hermite interpolation of (p, v)
/// (exact for ballistic flight); vehicle poses by fdv::interpolate_odometry.
/// Visibility is geometric (no occlusion by the scene). Thread-safe.
#include <algorithm>
#include <optional>
#include <span>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"

namespace fdv {

struct GroundTruthBox {
  bool visible = false;  ///< some part of the silhouette is in the image during the interval
  /// Raw-pixel box (pixel centres at integers), clipped to [-0.5, W-0.5] x [-0.5, H-0.5].
  double u_min = 0, v_min = 0, u_max = 0, v_max = 0;
  double fraction_in_view_min = 0;  ///< of the silhouette's solid angle, over the samples
  double fraction_in_view_max = 0;
  double fraction_in_view_mean = 0;
  double span_px_min = 0;  ///< larger side of the single-instant silhouette box (unclipped)
  double span_px_max = 0;
  int samples = 0;  ///< instants evaluated
  double width() const { return u_max - u_min; }
  double height() const { return v_max - v_min; }
  /// Whether pixel (x, y) overlaps the box enlarged by margin_px (a pixel covers ±0.5).
  bool contains(double x, double y, double margin_px = 0) const {
    return visible && x + 0.5 >= u_min - margin_px && x - 0.5 <= u_max + margin_px &&
           y + 0.5 >= v_min - margin_px && y - 0.5 <= v_max + margin_px;
  }
};

struct GroundTruthBoxOptions {
  double max_step_px = 0.25;   ///< most silhouette motion between evaluated instants [px]
  double max_error_px = 0.01;  ///< polygon error of the projected silhouette boundary [px]
  int view_samples = 1024;     ///< rays over the silhouette disc for the in-view fraction
  /// Camera the ball is seen from. Unset: the camera at each instant (a raw image). Set: the
  /// camera's orientation (rotation_time) and/or position (position_time) held at that fixed
  /// time for every instant: where an exact rotational (and translational) compensation to that
  /// time puts the ball's events (paper §III-A: events warped to t0).
  std::optional<TimeNs> rotation_time;
  std::optional<TimeNs> position_time;
};

/// The ball's silhouette at one instant as the image shows it (the apparent size and the
/// centre of a partly visible ball).
struct VisibleSilhouette {
  bool visible = false;  ///< some part of the silhouette is in the image
  /// Raw-pixel box of the in-view part, clipped to [-0.5, W-0.5] x [-0.5, H-0.5].
  double u_min = 0, v_min = 0, u_max = 0, v_max = 0;
  double fraction_in_view = 0;  ///< of the silhouette's solid angle
  /// The centre of the visible part [raw px]: the projected ball centre when the whole silhouette
  /// is in view, else the area centroid of its in-view part.
  Eigen::Vector2d visible_center_px = Eigen::Vector2d::Zero();
  /// The ball's centre projected through the lens; nothing behind the camera or beyond the lens
  /// model's valid field.
  std::optional<Eigen::Vector2d> projected_center_px;
  /// Apparent size: the longer side of the visible extent [px].
  double size_px() const { return visible ? std::max(u_max - u_min, v_max - v_min) : 0; }
  bool partial() const { return visible && fraction_in_view < 1; }
};

/// The silhouette of ball `id` at time t (inputs as ground_truth_box); not visible when no truth
/// covers t. Throws std::invalid_argument for radius <= 0.
VisibleSilhouette visible_silhouette(std::span<const ObjectState> objects, int id, double radius_m,
                                     std::span<const OdometrySample> body, const Calibration& calib,
                                     TimeNs t, const GroundTruthBoxOptions& options = {});

/// `objects` may hold several ids (only `id` is used) and must be time-sorted; `body` is the
/// true vehicle motion (T_W_B), time-sorted. Empty result (visible = false, samples = 0) when
/// no truth covers the interval. Throws std::invalid_argument for t1 < t0 or radius <= 0.
GroundTruthBox ground_truth_box(std::span<const ObjectState> objects, int id, double radius_m,
                                std::span<const OdometrySample> body, const Calibration& calib,
                                TimeNs t0, TimeNs t1, const GroundTruthBoxOptions& options = {});

}  // namespace fdv
