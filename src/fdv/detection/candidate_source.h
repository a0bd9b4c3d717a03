#pragma once
/// The interface of the detector's candidate sources, the window they all look at, and their
/// registry: a Detector makes one of each registered source and tries them in the registry's order
/// until one finds a candidate (detector.h).
///
///   SourceWindow in{.events = view, .ti = ti, .S = S, .P = P, .P_support = support, ...,
///                   .region_scratch = scratch};
///   DetectionResult res;
///   if (std::optional<Candidate> c = source.find(in, res)) use(*c);  // else in.why_not says why
///
/// A source writes its own diagnostics into `res` under its name (res.diagnostics_of(kName)) and
/// may lower `in.why_not`'s verdict; the Detector times its find() calls under the same name. Sources
/// keep their scratch buffers between windows: allocate(width, height) sizes them and find() then
/// does not allocate. Not thread-safe: one per Detector.
///
/// A new source (docs/DETECTION.md, "Adding a candidate source"): a class with a `kName`, its
/// diagnostics struct, a constructor from DetectorOptions, and one line in the list of built-in
/// sources (candidate_source.cpp), or a register_candidate_source call from the user's program.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "fdv/detection/detection2d.h"
#include "fdv/detection/detection_result.h"
#include "fdv/detection/detector_options.h"
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
  int fit_iterations = 0;    ///< Algorithm 1's iterations for the box (0: not a fit's)
};

/// A box's events per pixel over its surround's, the surround being the box grown by its own sides
/// on every side (within the image), whose density is floored at `floor_density` (the image's mean:
/// an empty surround must not make any small cluster infinitely isolated). `box_events`: the count
/// image's sum over `box`. A small object is a blob on its own; texture and edges run on into the
/// surround.
double isolation(const cv::Mat& count, const cv::Rect& box, double box_events, double floor_density);

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
  /// Tentative tracks' gates (DetectionPrior::confirmed false), searched by the dense-motion source and
  /// the count-contrast source's sparse search only.
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
  /// The window's events, all of them when only a part was searched (CompensatedEventsView::window_t_s):
  /// what the image's mean density and mean time are taken over.
  double window_events() const {
    return events.window_t_s.empty() ? static_cast<double>(ti.events) : static_cast<double>(events.window_t_s.size());
  }
};

/// One image of the state a source keeps across windows (CandidateSource::state_images).
struct SourceStateImage {
  std::string_view name;
  const cv::Mat* image;  ///< the source's own, valid until its next window
};

class CandidateSource {
 public:
  virtual ~CandidateSource() = default;
  /// Sizes the buffers for width × height images.
  virtual void allocate(int width, int height) = 0;
  /// Called once for every window that reaches the sources, before any find() and whichever
  /// source wins it: a source that keeps evidence across windows updates it here. Returns whether
  /// it did any work (the detector then times it under the source's name).
  virtual bool begin_window(const SourceWindow& /*in*/) { return false; }
  /// The source's candidate in this window, or nothing. Writes its diagnostics to
  /// res.diagnostics_of(its name); may add to res.candidates and set res.track_aided.
  virtual std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) = 0;
  /// The state it keeps across windows, as named images, for inspection (Python's
  /// `Perception(images=True)`); nothing in the pipeline reads them. None by default.
  virtual void state_images(std::vector<SourceStateImage>& /*out*/) const {}
};

/// Makes a registered source for a detector's options (valid ones: DetectorOptions::validate);
/// nullptr when these options switch it off.
using CandidateSourceFactory = std::function<std::unique_ptr<CandidateSource>(const DetectorOptions&)>;

struct RegisteredSource {
  /// Its name: the key of its diagnostics and time in DetectionResult, and its timing.csv column.
  std::string_view name;
  CandidateSourceFactory make;
};

/// Every registered source, in the order a Detector tries them: the built-in ones (listed in
/// candidate_source.cpp), then those added by register_candidate_source in the order added.
std::vector<RegisteredSource> registered_sources();

/// Adds a source after the registered ones, for the Detectors constructed from now on. `name`:
/// letters, digits and '_' (a timing.csv column), new, and of static storage duration (a string
/// literal: results keep a view of it). Throws ConfigError otherwise, or beyond
/// kMaxCandidateSources. Thread-safe.
void register_candidate_source(std::string_view name, CandidateSourceFactory make);
/// Removes a source register_candidate_source added; false when there is none of that name.
bool unregister_candidate_source(std::string_view name);

/// The factory of a source constructed from the options.
template <class S>
std::unique_ptr<CandidateSource> make_source(const DetectorOptions& options) {
  return std::make_unique<S>(options);
}

}  // namespace fdv
