#pragma once
/// Segmentation of a tracked object in a depth image registered into the event camera's raw
/// pixel grid (paper §IV-C.2): ROI = the track's box at the depth frame's time scaled ×2; the
/// nearest significant peak of the ROI's depth histogram; a window around it; gates on spread,
/// footprint, position and size; the object's centre depth with the sphere-radius correction.
///
///   DepthSegmentationOptions opt;  opt.object_radius_m = 0.1;    // if the ball is known
///   DepthQuery q{track.predict(frame.t).center_px, track.predict(frame.t).box_size_px};
///   DepthSegmentation r = segment_object_depth(depth_view(registered), event_camera, q, opt);
///   if (r.observation) use(*r.observation); else report(r.rejection, r.reason);
///
/// Pitfalls: the depth image must be in the event camera's raw grid with z along E's optical
/// axis (what DepthRegistrar produces); the box is the tracker's *prediction at the depth frame's
/// time*, not the latest detection. Thread-safe (pure function); allocates one small histogram.
#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/camera.h"
#include "fdv/core/time.h"

namespace fdv {

/// Non-owning view of a depth image [m], row-major, 0 = invalid.
struct DepthImageView {
  TimeNs t = 0;
  int width = 0;
  int height = 0;
  std::span<const float> depth_m;
};
/// View of any frame type with t, width, height and a depth_m vector (DepthFrame, RegisteredDepth).
template <class Frame>
DepthImageView depth_view(const Frame& f) {
  return {f.t, f.width, f.height, std::span<const float>(f.depth_m)};
}

/// Stereo depth noise σ(z) = z²·s/(f·B) (Intel's RMS formula; DESIGN.md defaults, D435).
struct DepthNoiseModel {
  double subpixel_px = 0.08;  ///< s: stereo matching subpixel accuracy [px]
  double focal_px =
      385.7;  ///< f: depth camera focal length [px] (paper release's depth intrinsics)
  double baseline_m = 0.05;  ///< B: stereo baseline [m] (D435: 50 mm)
  double sigma_m(double z_m) const { return z_m * z_m * subpixel_px / (focal_px * baseline_m); }
  std::string validate() const;
};

struct DepthSegmentationOptions {
  /// ROI = box scaled about its centre by this factor (paper §IV-C.2: "twice").
  double roi_scale = 2.0;
  /// Histogram bin width [m]: about σ(z) at 5 m (0.10 m) and the depth extent of a 0.1 m-radius
  /// ball, so the object's pixels fall into 1-3 bins over the working range.
  double bin_width_m = 0.10;
  /// Valid depth range [m] (D435 0.3-10 m, DESIGN.md).
  double min_depth_m = 0.3;
  double max_depth_m = 10.0;
  /// A histogram peak is significant when a 3-bin sum holds at least this many pixels...
  int min_peak_pixels = 8;
  /// ...and at least this fraction of the ROI's valid pixels (a ball filling its box covers
  /// π/16 ≈ 0.2 of a ×2 ROI; 0.04 leaves room for holes and partial occlusion).
  double min_peak_fraction = 0.04;
  /// Peaks tried from near to far when the nearer ones fail the object gates (an occluder in
  /// front).
  int max_peaks = 3;
  /// Segmentation half-window about the peak's mean [m]: radius + window_sigmas·σ(z).
  double window_sigmas = 2.5;
  /// Known object radius [m]; 0 = unknown: estimated from the segmented pixels (silhouette radius
  /// ρ = 2·σ of their x or y, the larger), r = ρ·z/f.
  double object_radius_m = 0.0;
  /// Radius assumed for the window when the radius is unknown [m] (a handball is 0.09 m).
  double default_window_radius_m = 0.10;
  /// Spread gate: reject when std of the segmented depths > spread_gate × the expected std
  /// sqrt((0.236·r)² + σ(z)²) of a sphere's visible cap plus sensor noise.
  double spread_gate = 2.0;
  /// Footprint gate: reject when segmented pixels > max_fill_ratio × the box's inscribed ellipse
  /// area (an occluder or wall filling the ×2 ROI has up to 5× that).
  double max_fill_ratio = 1.5;
  /// Position gate: the segmented centroid must lie inside the box's ellipse scaled by this.
  double max_centroid_offset = 1.0;
  /// Size gate (known radius only): ½·min(w, h)·z/f must be within [1/k, k] × object_radius_m.
  double radius_ratio_gate = 1.6;
  /// Relative std of the estimated radius, used in the observation's sigma when r is estimated.
  double radius_relative_sigma = 0.25;
  /// Floor of the observation's sigma [m]: registration rounds to whole event pixels and the
  /// cap model (2r/3) is approximate; 1 cm.
  double min_sigma_m = 0.01;
  DepthNoiseModel noise;

  std::string validate() const;
};

/// The field lists (fdv/core/field_list.h): YAML section `depth_segmentation`.
template <class V>
void describe(V& v, DepthNoiseModel& o) {
  v("subpixel_px", o.subpixel_px, "px", "s: stereo matching subpixel accuracy");
  v("focal_px", o.focal_px, "px", "f: depth camera focal length");
  v("baseline_m", o.baseline_m, "m", "B: stereo baseline; σ(z) = z²·s / (f·B)");
}
template <class V>
void describe(V& v, DepthSegmentationOptions& o) {
  v("roi_scale", o.roi_scale, "-", "ROI = the track's box scaled about its centre (paper §IV-C.2: twice)");
  v("bin_width_m", o.bin_width_m, "m", "histogram bin width");
  v("min_depth_m", o.min_depth_m, "m", "valid depth range, lower end");
  v("max_depth_m", o.max_depth_m, "m", "valid depth range, upper end");
  v("min_peak_pixels", o.min_peak_pixels, "px", "a significant peak's 3-bin sum holds at least this many pixels");
  v("min_peak_fraction", o.min_peak_fraction, "-", "... and this fraction of the ROI's valid pixels");
  v("max_peaks", o.max_peaks, "-", "peaks tried from near to far when nearer ones fail the gates");
  v("window_sigmas", o.window_sigmas, "-", "segmentation half-window about the peak: radius + this·σ(z)");
  v("object_radius_m", o.object_radius_m, "m", "known object radius; 0 = estimated from the pixels");
  v("default_window_radius_m", o.default_window_radius_m, "m", "radius for the window when it is unknown");
  v("spread_gate", o.spread_gate, "-", "reject when the depths' std exceeds this × the expected std");
  v("max_fill_ratio", o.max_fill_ratio, "-", "reject when the pixels exceed this × the box's inscribed ellipse");
  v("max_centroid_offset", o.max_centroid_offset, "-", "the centroid must lie in the box's ellipse scaled by this");
  v("radius_ratio_gate", o.radius_ratio_gate, "-", "known radius only: the image radius within [1/k, k] of it");
  v("radius_relative_sigma", o.radius_relative_sigma, "-", "relative std of an estimated radius");
  v("min_sigma_m", o.min_sigma_m, "m", "floor of the observation's sigma");
  v.section("noise", o.noise, "the depth camera's noise model");
}

/// Where to look: the track's box at the depth frame's time (raw event pixels), optionally the
/// depth the current trajectory estimate expects there (consistency with the event track).
struct DepthQuery {
  Eigen::Vector2d center_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d box_size_px = Eigen::Vector2d::Zero();  ///< width, height
  std::optional<double> expected_depth_m;                 ///< z of the centre in E, if known
  double expected_depth_sigma_m = 0.0;                    ///< its std (added to σ(z))
  double expected_depth_gate_sigmas = 3.0;                ///< reject peaks farther than this
};

/// One depth observation of the object, in the frame of the registered image (E).
struct DepthObservation {
  TimeNs t = 0;
  /// z of the object's CENTRE along the optical axis [m] (what r_D = z - d compares, eq. 15):
  /// surface_depth_m + (2/3)·r·cosθ, the mean depth of a sphere's visible cap lying 2r/3 in front
  /// of its centre along the line of sight θ off the axis.
  double depth_m = 0;
  double surface_depth_m = 0;  ///< mean z of the segmented pixels [m]
  double radius_m = 0;         ///< radius used for the correction [m]
  bool radius_estimated = false;
  double sigma_m = 0;  ///< std of depth_m for the estimator: σ(z) ⊕ radius uncertainty
  int pixel_count = 0;
  double spread_m = 0;                                  ///< std of the segmented depths [m]
  double expected_spread_m = 0;                         ///< what a sphere plus noise would give [m]
  Eigen::Vector2d center_px = Eigen::Vector2d::Zero();  ///< centroid of the segmented pixels
};

enum class DepthRejection {
  kNone,
  kInvalidInput,       ///< image buffer size, box or camera inconsistent
  kRoiOutsideImage,    ///< nothing of the ROI lies in the image
  kTooFewValidPixels,  ///< holes over the ROI
  kNoSignificantPeak,  ///< no histogram peak reaches the significance threshold
  kSpreadTooLarge,     ///< variance gate
  kFootprintTooLarge,  ///< more pixels than the object can cover (wall, large occluder)
  kOffCenter,          ///< segmented blob not where the event track says the object is
  kSizeInconsistent,   ///< the box at this depth implies a radius unlike the known one
  kDepthInconsistent,  ///< far from the depth the trajectory estimate expects
};
const char* to_string(DepthRejection r);

struct DepthSegmentation {
  std::optional<DepthObservation> observation;
  DepthRejection rejection = DepthRejection::kNone;  ///< of the nearest peak when all failed
  std::string reason;    ///< readable: every peak tried and why it failed
  int roi_pixels = 0;    ///< pixels of the ROI inside the image
  int valid_pixels = 0;  ///< of those, with a depth in range
  int peaks_tried = 0;
};

/// Segments the object in `depth` (registered into `event_camera`'s raw grid). Never throws on
/// bad data: inconsistencies come back as kInvalidInput. Throws ConfigError for invalid options.
DepthSegmentation segment_object_depth(const DepthImageView& depth,
                                       const PinholeCamera& event_camera, const DepthQuery& query,
                                       const DepthSegmentationOptions& options);

// The first phases of segment_object_depth, exposed as units for tests.

/// Pixels [x0, x1] × [y0, y1], bounds included; empty when x0 > x1 or y0 > y1.
struct PixelRect {
  int x0 = 0, x1 = -1, y0 = 0, y1 = -1;
  bool empty() const { return x0 > x1 || y0 > y1; }
};

/// The ROI (§IV-C.2, the box "scaled twice"): the pixels whose centres lie inside the query's
/// box scaled by roi_scale about its centre, clipped to a width × height image.
PixelRect depth_roi(const DepthQuery& query, double roi_scale, int width, int height);

/// Histogram of the ROI's depths in [min_depth_m, max_depth_m) (others are holes or out of range).
struct DepthHistogram {
  /// Bin i holds [min_depth_m + i·bin_width_m, + bin_width_m); the last one up to max_depth_m.
  std::vector<int> counts;
  double min_depth_m = 0;
  double bin_width_m = 1;
  int roi_pixels = 0;    ///< pixels of the ROI
  int valid_pixels = 0;  ///< of those, counted in a bin
  int bins() const { return static_cast<int>(counts.size()); }
  /// Count of bin i; 0 outside the histogram.
  int at(int i) const { return i < 0 || i >= bins() ? 0 : counts[static_cast<std::size_t>(i)]; }
  double bin_center_m(int i) const { return min_depth_m + (i + 0.5) * bin_width_m; }
};
DepthHistogram depth_histogram(const DepthImageView& depth, const PixelRect& roi,
                               const DepthSegmentationOptions& options);

struct DepthPeak {
  int bin = 0;         ///< the fullest of the three significant bins
  double depth_m = 0;  ///< m₀: count-weighted centre of that bin and its two neighbours [m]
};
/// The nearest peak of the histogram (§IV-C.2: "the nearest peak in the histogram of the depth
/// map") at or beyond bin `from`: the first bin whose 3-bin sum (it and its neighbours, so that an
/// object split across a bin border stays significant) holds >= threshold pixels. Nothing if none.
std::optional<DepthPeak> nearest_significant_peak(const DepthHistogram& histogram, int from,
                                                  double threshold);

}  // namespace fdv
