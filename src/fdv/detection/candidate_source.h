#pragma once
/// The interface of the detector's candidate sources (detector.h runs them in a fixed order until
/// one finds a candidate) and the window they all look at.
///
///   SourceWindow in{.events = view, .ti = ti, .S = S, .P = P, .P_support = support, ...,
///                   .region_scratch = scratch};
///   DetectionResult res;
///   if (std::optional<Candidate> c = source.find(in, res)) use(*c);  // else in.why_not says why
///
/// A source writes its own diagnostic fields and timings of `res` and may lower `in.why_not`'s
/// verdict. Sources keep their scratch buffers between windows: allocate(width, height) sizes them
/// and find() then does not allocate. Not thread-safe: one per Detector.
#include <Eigen/Core>
#include <chrono>
#include <opencv2/core.hpp>
#include <optional>
#include <span>

#include "fdv/detection/detection2d.h"
#include "fdv/detection/detection_result.h"
#include "fdv/detection/gaussian_fit.h"
#include "fdv/detection/segmentation.h"
#include "fdv/detection/time_images.h"

namespace fdv {

/// One pattern's box that passed its source's plausibility and evidence gates (undistorted grid).
struct Candidate {
  Box2D box;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  DetectionSource source = DetectionSource::kGaussianFit;
  int events = 0;            ///< compensated events in the box
  double score = 0;          ///< Detection2D::score
  double event_density = 0;  ///< events per pixel of the box
  double t_mean_s = 0;       ///< mean event time in the box [s since t_start]
};

/// One window as every source sees it, built by Detector::detect once the window passed its
/// guards. Borrowed: valid for the call.
struct SourceWindow {
  const CompensatedEventsView& events;
  const TimeImages& ti;
  const cv::Mat& S;         ///< segmentation (§IV-B.1), CV_32F
  const cv::Mat& P;         ///< pre-processed S (§IV-B.2), CV_32F, zero outside P_support
  cv::Rect P_support;
  MaxLocation P_max;        ///< first_maximum(P, P_support)
  double theta = 0;         ///< θ(ω, v)
  double window_s = 0;      ///< the window's duration [s]
  /// The confirmed tracks' gates on the undistorted grid (priors with an inverse lens map only).
  std::span<const Box2D> gates;
  /// Tentative tracks' gates (DetectionPrior::confirmed false), searched by the dense-motion cue and
  /// the count-contrast cue's sparse search only.
  std::span<const Box2D> tentative_gates;
  /// Scratch of moving-region retrieval, shared by the sources that run it (it is large: a run
  /// list sized for the whole image).
  RegionScratch& region_scratch;
  /// False in the search for the window's further objects: the pattern source asks for
  /// GaussianFitSourceOptions::further_min_peak, and the count-contrast source keeps to the gates
  /// (the count image still holds the objects found).
  bool first_object = true;
  /// A source saw an object larger than DetectorOptions::fills_view_fraction (status kFillsView).
  bool fills_view = false;
  /// Why there is no detection when no source finds one; the pattern sources refine it.
  DetectionStatus why_not = DetectionStatus::kRemovedAsNoise;
};

namespace detection_internal {
/// Wall-clock milliseconds since t0, for DetectionTimings.
inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace detection_internal

class CandidateSource {
 public:
  virtual ~CandidateSource() = default;
  /// Sizes the buffers for width × height images.
  virtual void allocate(int width, int height) = 0;
  /// The source's candidate in this window, or nothing.
  virtual std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) = 0;
};

}  // namespace fdv
