#pragma once
/// What Detector::detect reports about one window (detector.h), and the track priors it takes.
/// Plain value types; the candidate sources (candidate_source.h) fill their diagnostic fields.
#include <Eigen/Core>
#include <optional>
#include <string_view>
#include <vector>

#include "fdv/detection/detection2d.h"
#include "fdv/detection/gaussian_fit.h"

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
  kFillsView,          ///< an object larger than fills_view_fraction of the image: too near to detect
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
  double motion_cue_ms = 0; ///< the dense-motion source (0 when not run)
  double count_cue_ms = 0;  ///< the count-contrast source (0 when not run)
  double total_ms = 0;
};

struct DetectionResult {
  /// Every object found, in the order found (the strongest pattern first); empty unless status is
  /// kDetected. At most DetectorOptions::max_objects.
  std::vector<Detection2D> detections;
  DetectionStatus status = DetectionStatus::kTooFewEvents;
  double theta = 0;             ///< θ(ω, v) used
  double mean_normalized = 0;   ///< mean(N) over pixels with events
  int segmented_pixels = 0;     ///< pixels with S > 0
  int candidates = 0;           ///< patterns tried (GaussianFitSourceOptions::max_candidates, + priors)
  bool track_aided = false;     ///< found inside a track's gate (sources 2-4)
  GaussianFit fit;              ///< Algorithm 1's outcome for the last candidate (zero when not run)
  /// Why the fitted ROI was not used ("" when it was): "not converged", "diverged", "empty roi",
  /// "too large", "aspect ratio", "too few events".
  std::string_view fit_rejected;
  /// The dense-motion source (DetectorOptions::dense_motion), when it ran (no pattern of N passed):
  /// the R² of its time plane and the plane's rise across the square as a fraction of the window.
  bool motion_cue_ran = false;
  double motion_cue_r2 = 0, motion_cue_span = 0;
  /// The count-contrast source (DetectorOptions::count_contrast), when it ran: the highest contrast
  /// among centres that fill min_fill (0: none did), that centre's fill, and how many centres filled
  /// it (of its last dense search: the gates' come first, then the image's).
  bool count_cue_ran = false;
  double count_cue_contrast = 0, count_cue_fill = 0;
  int count_cue_filled_centres = 0;
  /// (the blob's mean event time − all events') / (max T − min T), when its box passed the event gates.
  double count_cue_time_offset = 0;
  /// The still-camera test, when it ran (the time test failed with the camera nearly still): the
  /// blob's isolation and, if that passed, the Wald z of its motion (0: not reached).
  double count_cue_isolation = 0, count_cue_motion_z = 0;
  /// The sparse search's active pixels per centre box, when it ran (0: it did not).
  int count_cue_sparse_min_active = 0;
  DetectionTimings timings;
  /// The first object found, or nullptr.
  const Detection2D* strongest() const { return detections.empty() ? nullptr : &detections.front(); }
};

/// Where a confirmed track expects its object in a window (raw sensor pixels, the tracker's grid):
/// when no pattern passes the normal evidence gates, the detector looks again inside
/// DetectorOptions::prior_gate_scale × this box (sources 2-4, detector.h).
struct DetectionPrior {
  Eigen::Vector2d center_raw = Eigen::Vector2d::Zero();
  Eigen::Vector2d box_size_px = Eigen::Vector2d::Zero();
  /// False for a tentative track's prior: its gate is searched by the dense-motion cue, whose
  /// time-plane test is the strictest of the gate sources, and by the count-contrast cue's sparse
  /// search with a still camera only (docs/DETECTION.md).
  bool confirmed = true;
};

}  // namespace fdv
