#pragma once
/// The detection front end of one compensated window (paper §IV-B): time images, adaptive
/// threshold, pre-processing, iterative Gaussian fitting, moving-region retrieval, Detection2D.
///
///   Detector detector(options, calibration.event_camera);
///   CompensatedEventsView view{w.t_start_ns, w.t_end_ns, w.width, w.height, w.pixel(), w.t_s(),
///                              w.report.omega_E.norm(), w.report.v_E.norm(),
///                              w.report.events_out_of_order == 0};
///   DetectionResult r = detector.detect(view);
///   if (r.detection) use(*r.detection);              // else r.status says why not
///   show(detector.time_images().normalized, detector.segmentation());   // valid until next call
///
/// The images live on the undistorted grid K·xn of `event_camera` (the compensators' output
/// grid); detections are reported there and in raw sensor pixels through the lens model.
/// A Detector keeps its image buffers between calls. Not thread-safe: one per thread.
#include <optional>
#include <span>
#include <utility>
#include <string_view>
#include <vector>

#include "fdv/core/camera.h"
#include "fdv/detection/detection2d.h"
#include "fdv/detection/detector_options.h"
#include "fdv/detection/gaussian_fit.h"
#include "fdv/detection/segmentation.h"
#include "fdv/detection/time_images.h"

namespace fdv {

enum class DetectionStatus {
  kDetected,
  kTooFewEvents,       ///< fewer than min_window_events compensated events (incl. none)
  kNoTemporalContrast, ///< all event pixels share one mean time (N ≡ 0)
  kNothingSegmented,   ///< no pixel reached θ
  kFlooded,            ///< more than max_segmented_fraction of the image reached θ
  kRemovedAsNoise,     ///< nothing above θ survived the pre-processing as a solid pattern (min_peak)
  kNoRegion,           ///< the fit failed and no connected component qualified
  kTooFewEventsInBox,  ///< the final box holds fewer than roi_min_events events
  kWeakEvidence,       ///< the box's peak (score) or event density is below min_peak / min_event_density
};
std::string_view to_string(DetectionStatus s);

/// Wall-clock time of each stage [ms] (steady clock).
struct DetectionTimings {
  double time_images_ms = 0;
  double segmentation_ms = 0;
  double preprocess_ms = 0;
  double fit_ms = 0;
  double retrieval_ms = 0;  ///< 0 when retrieval was not needed
  double refine_ms = 0;     ///< centre / time refinement from the events
  double motion_cue_ms = 0; ///< the dense-motion cue (0 when not run)
  double count_cue_ms = 0;  ///< the count-contrast cue (0 when not run)
  double total_ms = 0;
};

struct DetectionResult {
  std::optional<Detection2D> detection;
  DetectionStatus status = DetectionStatus::kTooFewEvents;
  double theta = 0;             ///< θ(ω, v) used
  double mean_normalized = 0;   ///< mean(N) over pixels with events
  int segmented_pixels = 0;     ///< pixels with S > 0
  int candidates = 0;           ///< patterns tried (DetectorOptions::max_candidates, + priors)
  bool track_aided = false;     ///< found inside a track's gate with prior_min_peak
  GaussianFit fit;              ///< Algorithm 1's outcome for the last candidate (zero when not run)
  /// Why the fitted ROI was not used ("" when it was): "not converged", "diverged", "empty roi",
  /// "too large", "aspect ratio", "too few events".
  std::string_view fit_rejected;
  /// The dense-motion cue (DetectorOptions::motion_cue), when it ran (no pattern of N passed): the
  /// R² of its time plane and the plane's rise across the square as a fraction of the window.
  bool motion_cue_ran = false;
  double motion_cue_r2 = 0, motion_cue_span = 0;
  /// The count-contrast cue (DetectorOptions::count_cue), when it ran: the highest contrast among
  /// centres that fill count_cue_min_fill (0: none did), that centre's fill, and how many centres
  /// filled it (of its last search: the gates' come first, then the image's).
  bool count_cue_ran = false;
  double count_cue_contrast = 0, count_cue_fill = 0;
  int count_cue_filled_centres = 0;
  /// (the blob's mean event time − all events') / (max T − min T), when its box passed the event gates.
  double count_cue_time_offset = 0;
  DetectionTimings timings;
};

/// Where a confirmed track expects its object in a window (raw sensor pixels, the tracker's grid):
/// when no pattern passes the normal evidence gates, the detector looks again inside
/// DetectorOptions::prior_gate_scale × this box with the lower DetectorOptions::prior_min_peak.
struct DetectionPrior {
  Eigen::Vector2d center_raw = Eigen::Vector2d::Zero();
  Eigen::Vector2d box_size_px = Eigen::Vector2d::Zero();
};

class Detector {
 public:
  /// Throws ConfigError for invalid options or camera.
  Detector(const DetectorOptions& options, const PinholeCamera& event_camera);
  DetectionResult detect(const CompensatedEventsView& window, std::span<const DetectionPrior> priors = {});

  // Intermediate images of the last call (valid until the next one), for visualisation.
  const TimeImages& time_images() const { return ti_; }
  const cv::Mat& segmentation() const { return S_; }   ///< S, CV_32F
  const cv::Mat& preprocessed() const { return pre_.P(); }  ///< P = (open(mean(S)))², CV_32F (before any blanking)
  const DetectorOptions& options() const { return options_; }

  /// Undistorted-grid point -> raw sensor pixel, and the box outline's raw bounding box.
  Eigen::Vector2d undistorted_to_raw(const Eigen::Vector2d& uv) const;
  Box2D undistorted_box_to_raw(const Box2D& box) const;

 private:
  /// One pattern's box that passed the plausibility and evidence gates.
  struct Candidate {
    Box2D box;
    Eigen::Vector2d center = Eigen::Vector2d::Zero();
    DetectionSource source = DetectionSource::kGaussianFit;
    int events = 0;
    double score = 0, event_density = 0, t_mean_s = 0;
  };
  /// Algorithm 1 from `seed` on `P`, else moving-region retrieval; then the gates. On failure sets
  /// `why_not` and `blank` (the area to blank before the next attempt).
  std::optional<Candidate> evaluate_candidate(const CompensatedEventsView& window, const cv::Mat& P, cv::Point seed,
                                              double min_peak, DetectionResult& res, DetectionStatus& why_not,
                                              Box2D& blank);
  /// The dense-motion cue: the densest patch of active pixels of I within `search`, accepted when
  /// T rises across it as a plane (DetectorOptions::motion_cue_*) and its box passes the event gates.
  std::optional<Candidate> dense_motion_candidate(double window_s, const cv::Rect& search, DetectionResult& res);
  /// The count-contrast cue: the filled centre box within `search` with the highest count contrast
  /// (DetectorOptions::count_cue_*), its box from Algorithm 1 on I above the background level; with
  /// `time_test`, its events' mean time must stand out from all events' by θ's margin.
  std::optional<Candidate> count_contrast_candidate(const cv::Rect& search, bool time_test, DetectionResult& res);
  /// The search box on the undistorted grid of a prior, or nothing when its centre has no inverse.
  std::optional<Box2D> prior_gate(const DetectionPrior& prior) const;
  /// Centroid and mean time [s since t_start] of the events in a time-complete slice around the
  /// box (DetectorOptions::refine_box_scale), or nothing when too few or outside the box.
  std::optional<std::pair<Eigen::Vector2d, double>> refine_with_events(const CompensatedEventsView& window,
                                                                      const Box2D& box, double t_box_s);
  /// Sizes every image buffer for width × height (S = P = 0).
  void allocate(int width, int height);
  DetectorOptions options_;
  PinholeCamera camera_;
  // Buffers, sized to the image in the constructor: detect() does not allocate once the time
  // images have seen a window (tests/pipeline/no_allocation_test.cpp).
  TimeImages ti_;
  cv::Mat S_;
  Preprocessor pre_;
  RegionScratch region_;
  cv::Mat blanked_;         ///< P with failed candidates blanked; zero outside blanked_bounds_
  cv::Rect blanked_bounds_;
  cv::Mat count_f_, count_integral_;  ///< I as float and its summed-area table (dense-motion cue)
  // Count-contrast cue: I's active pixels (255) as CV_8U and their summed-area table; I saturated
  // at 255 as CV_8U and its table, built only when many centres pass the fill test; I above the
  // background level (CV_32F, zero outside excess_bounds_).
  cv::Mat cue_active8_, cue_active_integral_, cue_count8_, cue_count_integral_, count_excess_;
  cv::Rect excess_bounds_;
  bool cue_active_ready_ = false;  ///< the active table holds this window's I (gates and image share it)
  bool cue_count_ready_ = false;   ///< the same for the count table
  std::vector<int> cue_live_blocks_;  ///< the scan's blocks in one band that it cannot skip
  cv::Mat refine_acc_;  ///< the refinement's slice events per pixel: (count, Σt), CV_32FC2
};

}  // namespace fdv
