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
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <cstdint>
#include <optional>
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

/// 8-connected components of the pixels of `image` (CV_32F) greater than 0, labelled 1, 2, ... in
/// the order cv::connectedComponentsWithStats gives them (its scan is by 2x2 blocks: a component's
/// number follows the first block, in raster order of blocks, that holds one of its pixels);
/// 0 = background. `labels` (CV_32S) receives the labels in its top-left image.size() corner (it is
/// reallocated only when smaller than the image); `stats[i]` is label i's (stats[0] unused);
/// `stack` is scratch. Returns the number of labels including the background, as OpenCV does.
/// Allocation-free when `labels` is large enough and the vectors' capacities suffice (at most
/// ⌈w/2⌉·⌈h/2⌉ + 1 components and w·h stack entries).
int label_components(const cv::Mat& image, cv::Mat& labels, std::vector<ComponentStats>& stats,
                     std::vector<std::int32_t>& stack);

/// Scratch of retrieve_region, kept between calls: reserve(width, height) once and no call on an
/// image of at most that size allocates.
struct RegionScratch {
  cv::Mat labels;  ///< CV_32S
  std::vector<ComponentStats> stats;
  std::vector<std::int32_t> stack;
  void reserve(int width, int height);
};

/// Moving-region retrieval: connected components (8-connected) of P > 0 computed inside `search`
/// (components are cut at its border); of those with at least region_min_area_px pixels that
/// overlap `roi`, the one with the largest mass Σ P (on a tie, the lower label). Nothing when none
/// qualifies.
std::optional<Region> retrieve_region(const cv::Mat& P, const Box2D& roi, const cv::Rect& search,
                                      const DetectorOptions& o, RegionScratch& scratch);

}  // namespace fdv
