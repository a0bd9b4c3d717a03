#pragma once
/// Iterative Gaussian fitting (paper §IV-B.2, Algorithm 1) and moving-region retrieval (§IV-B.3).
///
///   GaussianFit fit = iterative_gaussian_fit(P, c0, {w / 2.0, h / 2.0}, options);
///   if (!fit.converged || !roi_plausible(...)) region = retrieve_region(P, fit.roi(), options, ...);
///
/// Fit: the ROI S(C, L) is the box of sides L = (w, h) centred at C. Each iteration fits a
/// Gaussian to the image inside the ROI, treating pixel values as weights: μ = Σ P·x / Σ P,
/// σ² = Σ P·(x − μ)² / Σ P per axis, then C ← μ and L ← 4σ (floored at fit_min_size_px). It has
/// converged when ‖C_{k+1} − C_k‖ < δ_C and |w_{k+1} − w_k| < δ_L and |h_{k+1} − h_k| < δ_L
/// within K iterations; an ROI with no weight ends the fit unconverged, and so does an ROI that
/// outgrows the initial one on both sides (diverging: no dominant pattern; it could only be
/// rejected as too large, so the remaining iterations are skipped). (Algorithm 1's line
/// "J_c ← J(D_P, T)" computes a quantity the paper never uses or defines; it is omitted.)
/// Thread safety: value types and pure functions; may be used from any thread.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "fdv/detection/detection2d.h"
#include "fdv/detection/detector_options.h"

namespace fdv {

struct GaussianFit {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< C* [px]
  Eigen::Vector2d size = Eigen::Vector2d::Zero();    ///< L* = (w, h) [px]
  int iterations = 0;
  bool converged = false;
  bool empty_roi = false;  ///< stopped because the ROI held no weight
  bool diverged = false;   ///< stopped because the ROI outgrew the initial ROI on both sides
  Box2D roi() const {
    return {center.x() - 0.5 * size.x(), center.y() - 0.5 * size.y(), center.x() + 0.5 * size.x(),
            center.y() + 0.5 * size.y()};
  }
};

/// Runs Algorithm 1 on the pre-processed image P (CV_32F, non-negative) from C0, L0. Does not
/// allocate. The marginal sums are summed in float in the order cv::reduce sums them (the earlier
/// version called it), so results are the same to the bit.
GaussianFit iterative_gaussian_fit(const cv::Mat& P, const Eigen::Vector2d& c0, const Eigen::Vector2d& l0,
                                   const DetectorOptions& o);

/// Pixel index range of a box clipped to a w×h image: pixels whose centre lies inside.
cv::Rect box_pixels(const Box2D& box, int width, int height);

struct Region {
  Box2D box;                                         ///< covers the component's pixels
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< P-weighted centroid
  double mass = 0;                                   ///< Σ P over the component
  int area_px = 0;
};

/// Size and bounding box of one connected component (as cv::connectedComponentsWithStats's stats).
struct ComponentStats {
  int left = 0, top = 0, width = 0, height = 0, area = 0;
};

/// One horizontal run of foreground pixels [x0, x1] in row y (inclusive), and its component.
struct PixelRun {
  std::int32_t y = 0, x0 = 0, x1 = 0;
  std::int32_t label = 0;  ///< after labelling: the component's label (1, 2, ...)
};

/// Scratch of label_components and retrieve_region, kept between calls: reserve(width, height) once
/// and no call on an image of at most that size allocates.
struct RegionScratch {
  cv::Mat labels;                     ///< CV_32S, created and written by label_components only
  std::vector<ComponentStats> stats;  ///< stats[label] (stats[0] unused)
  std::vector<PixelRun> runs;         ///< foreground runs in raster order
  std::vector<std::int32_t> parent;   ///< union-find over runs
  std::vector<std::int32_t> roots;    ///< one run per component, then sorted into label order
  std::vector<std::int32_t> key;      ///< per root run: the component's first 2x2 block, then its label
  std::vector<ComponentStats> root_stats;  ///< per root run, while collecting
  std::vector<double> mass;           ///< retrieve_region: Σ P, Σ P·x, Σ P·y per label
  void reserve(int width, int height);
};

/// 8-connected components of the pixels of `image` (CV_32F) greater than 0, as runs of pixels
/// (`scratch.runs`, each with its label) and per-label stats (`scratch.stats[i]`, stats[0]
/// unused), labelled 1, 2, ... in the order cv::connectedComponentsWithStats gives them (its scan
/// is by 2x2 blocks: a component's number follows the first block, in raster order of blocks,
/// that holds one of its pixels; every foreground pixel of a block is 8-adjacent to the others,
/// so that block belongs to one component). Returns the number of labels including the
/// background, as OpenCV does. Runs joined by union-find: one pass over the image, then work per
/// run, not per pixel.
int label_runs(const cv::Mat& image, RegionScratch& scratch);

/// label_runs, plus the label image (CV_32S, 0 = background) written into the top-left
/// image.size() corner of `scratch.labels` (reallocated only when smaller than the image).
int label_components(const cv::Mat& image, RegionScratch& scratch);

/// Moving-region retrieval: connected components (8-connected) of P > 0 computed inside `search`
/// (components are cut at its border); of those with at least region_min_area_px pixels that
/// overlap `roi`, the one with the largest mass Σ P (on a tie, the lower label). Nothing when none
/// qualifies.
std::optional<Region> retrieve_region(const cv::Mat& P, const Box2D& roi, const cv::Rect& search,
                                      const DetectorOptions& o, RegionScratch& scratch);

/// The same for several ROIs tried in order on one labelling of the search area: the region of the
/// first ROI that yields one (the detector's "overlapping the failed fit's ROI, else any").
std::optional<Region> retrieve_region(const cv::Mat& P, std::span<const Box2D> rois, const cv::Rect& search,
                                      const DetectorOptions& o, RegionScratch& scratch);

}  // namespace fdv
