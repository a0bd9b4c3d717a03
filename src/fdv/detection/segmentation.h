#pragma once
/// Dynamic obstacle segmentation (paper §IV-B.1) and the pre-processing before the Gaussian fit
/// (§IV-B.2).
///
///   double theta = adaptive_threshold(ti.mean_normalized, omega, speed, options);
///   SegmentResult s = segment(ti, theta, options.min_pixel_events, S);  // S = N where N ≥ θ, else 0
///   Preprocessor pre(options);                                          // once: buffers are kept
///   const cv::Mat& P = pre.run(S, s.bounds);                            // P = (open(mean_filter(S)))²
///
/// Both passes are allocation-free once their buffers have the image's size, and the
/// pre-processing only visits the pixels S can make nonzero (the bounds of S grown by the mean
/// filter's half-width): a window's segmentation is a small part of the image.
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "fdv/detection/detector_options.h"
#include "fdv/detection/time_images.h"

namespace fdv {

/// m(r) = 0 for a CV_32F or CV_32S image (r clipped to m), row by row: cv::Mat::setTo allocates a
/// block buffer at each call.
void zero_rect(cv::Mat& m, const cv::Rect& r);

struct MaxLocation {
  float value = 0;
  cv::Point at;  ///< image coordinates
};
/// The maximum of a CV_32F image (no NaN) inside r (clipped to the image) and its first location in
/// raster order, as cv::minMaxLoc reports them; r ∩ image empty: value 0. Row maxima four
/// lanes at a time: several times faster than cv::minMaxLoc on large areas, where it also showed
/// occasional 3 ms calls in the pipeline.
MaxLocation first_maximum(const cv::Mat& m, const cv::Rect& r);

/// θ(ω, v) = mean_N + a·‖ω‖ + b·‖v‖ + c, mean_N = mean of N over pixels with events.
double adaptive_threshold(double mean_normalized, double omega_rad_s, double speed_m_s, const DetectorOptions& o);

struct SegmentResult {
  int pixels = 0;   ///< pixels with S > 0
  cv::Rect bounds;  ///< bounding rectangle of those pixels (empty when none)
};

/// S_ij = N_ij where N_ij ≥ θ and I_ij ≥ min_pixel_events (≥ 1), else 0 (CV_32F; reuses S's
/// buffer when it has the size). Written over the whole image, unless `s_nonzero` is given: S has
/// the image's size and is zero outside that rectangle (the last result's bounds), and then only
/// the rows that can hold events (ti.event_rows) are computed and the rest of `s_nonzero` blanked.
SegmentResult segment(const TimeImages& ti, double theta, int min_pixel_events, cv::Mat& S,
                      int threads = 1, std::optional<cv::Rect> s_nonzero = std::nullopt);

/// P = (open_k2(mean_k1(S)))², element-wise square, CV_32F: a k1×k1 mean filter, then the opening
/// (erosion followed by dilation) with a k2×k2 square, everything zero beyond the image border.
/// The mean is Σ S over the k1×k1 neighbourhood (row sums, then the sum of k1 row sums, in float)
/// times float(1/k1²): within 2e-7 of OpenCV's cv::sepFilter2D with a box kernel on values in
/// [0, 1] (a few float roundings); the opening and the square are exact.
class Preprocessor {
 public:
  /// Kernel sizes from o.mean_filter_px and o.opening_px (validated by DetectorOptions::validate).
  explicit Preprocessor(const DetectorOptions& o);
  /// S: CV_32F, zero outside `s_bounds`. Returns P (this object's buffer, valid until the next
  /// call), the size of S, zero outside nonzero_bounds().
  /// `threads` (run_parts, at most 8): bands of rows run in parallel, with the same result.
  const cv::Mat& run(const cv::Mat& S, const cv::Rect& s_bounds, int threads = 1);
  /// Sizes the buffers for images of `size` (P = 0); run() does it when S's size differs.
  void allocate(cv::Size size);
  /// P = 0 everywhere (e.g. after a window with nothing to pre-process).
  void clear();
  const cv::Mat& P() const { return P_; }
  /// P is zero outside this rectangle: the bounds of S grown by the mean filter's half-width (the
  /// opening never extends the support of what it opens).
  const cv::Rect& nonzero_bounds() const { return written_; }
  /// first_maximum(P(), nonzero_bounds()) of the last run, found while P was written.
  const MaxLocation& first_max() const { return first_max_; }

 private:
  int h_mean_, h_open_;  // half-widths of the kernels
  /// Two strips of intermediate rows (the passes go through P in strips) and a padded row, per thread.
  struct StripBuffers {
    cv::Mat a, b;
    std::vector<float> line;
  };
  void add_strip_buffers(int width);

  cv::Mat P_;
  std::vector<StripBuffers> strips_;
  cv::Rect written_;  // where P_ may be nonzero
  MaxLocation first_max_;
};

/// The same computation over the whole image (P and `scratch` are reused when they have the size;
/// a new Preprocessor's buffers are allocated at each call, so prefer the class in a loop).
void preprocess(const cv::Mat& S, const DetectorOptions& o, cv::Mat& P, cv::Mat& scratch);

}  // namespace fdv
