#pragma once
/// The detection front end of one compensated window (paper §IV-B): time images, adaptive
/// threshold θ, segmentation S, pre-processing P, then the registered candidate sources in their
/// order until one finds a candidate that passes its gates, then the centre and time from the
/// events. The built-in sources (candidate_source.cpp registers them):
///   1. GaussianFitSource: Algorithm 1 + moving-region retrieval on P's strongest patterns (the paper);
///   2. TrackAidedSource: the same inside confirmed tracks' gates, at a lower evidence threshold;
///   3. DenseMotionSource: a dense patch of I whose mean time rises as a plane, in the gates of
///      confirmed tracks and of tentative ones detected in the last window;
///   4. CountContrastSource: a compact blob of I much denser than its surround, gates then image;
///   5. EvidenceSource: a cell whose evidence summed over windows along a path passed a threshold
///      (track-before-detect), for the far, small object no single window shows.
/// Each has its own unit, options sub-struct (DetectorOptions), buffers and diagnostics; a program
/// may register more (candidate_source.h). The detector times each under its registered name.
///
///   Detector detector(options, calibration.event_camera);
///   CompensatedEventsView view{w.t_start, w.t_end, w.width, w.height, w.pixel(), w.t_s(),
///                              w.report.omega_E.norm(), w.report.v_E.norm(),
///                              w.report.events_out_of_order == 0};
///   DetectionResult r = detector.detect(view);
///   for (const Detection2D& d : r.detections) use(d);   // none: r.status says why not
///   show(detector.time_images().normalized, detector.segmentation());   // valid until next call
///
/// The images live on the undistorted grid K·xn of `event_camera` (the compensators' output
/// grid); detections are reported there and in raw sensor pixels through the lens model.
/// A Detector keeps its image buffers between calls. Not thread-safe: one per thread.
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "fdv/core/camera.h"
#include "fdv/detection/border_cut.h"
#include "fdv/detection/candidate_source.h"
#include "fdv/detection/detection2d.h"
#include "fdv/detection/detection_result.h"
#include "fdv/detection/detector_options.h"
#include "fdv/detection/event_refinement.h"
#include "fdv/detection/gaussian_fit.h"
#include "fdv/detection/segmentation.h"
#include "fdv/detection/time_images.h"

namespace fdv {

/// `options` with the gates stated at DetectorOptions::gate_focal_px scaled to `camera`'s fx when
/// it is shorter: min_event_density × fx / gate_focal_px, count_contrast_box_px × the same (odd, ≥ 3).
DetectorOptions scaled_to_camera(const DetectorOptions& options, const PinholeCamera& camera);

class Detector {
 public:
  /// Throws ConfigError for invalid options or camera.
  Detector(const DetectorOptions& options, const PinholeCamera& event_camera);
  DetectionResult detect(const CompensatedEventsView& window, std::span<const DetectionPrior> priors = {});

  // Intermediate images of the last call (valid until the next one), for visualisation.
  const TimeImages& time_images() const { return ti_; }
  const cv::Mat& segmentation() const { return S_; }   ///< S, CV_32F
  const cv::Mat& preprocessed() const { return pre_.P(); }  ///< P = (open(mean(S)))², CV_32F (before any blanking)
  /// Calls f(source name, its state images) for each source that keeps state across windows
  /// (CandidateSource::state_images), in the order the sources are tried.
  template <class F>
  void for_each_source_state(F&& f) const {
    std::vector<SourceStateImage> images;
    for (const Source& s : sources_) {
      images.clear();
      s.source->state_images(images);
      if (!images.empty()) f(s.name, images);
    }
  }
  /// The options in use: the constructor's, scaled_to_camera.
  const DetectorOptions& options() const { return options_; }

  /// Undistorted-grid point -> raw sensor pixel, and the box outline's raw bounding box.
  Eigen::Vector2d undistorted_to_raw(const Eigen::Vector2d& uv) const;
  Box2D undistorted_box_to_raw(const Box2D& box) const;
  /// The search box on the undistorted grid of a prior, or nothing when its centre has no inverse.
  std::optional<Box2D> prior_gate(const DetectionPrior& prior) const;

 private:
  /// The winning candidate as a detection: centre and time from the events (EventRefiner), the
  /// reported box, and both seen by the camera at the detection's time, in raw pixels too.
  Detection2D to_detection(const CompensatedEventsView& window, const Candidate& found, DetectionResult& res);
  /// Every source's begin_window, each timed under its name when it worked.
  void begin_window(const SourceWindow& in, DetectionResult& res);
  /// The first registered source whose candidate passes its gates, each timed under its name.
  std::optional<Candidate> find_candidate(SourceWindow& in, DetectionResult& res);
  /// What a found object's box blanks of P for the next pass, and whether a candidate centre lies
  /// in an object found before (the sources that read I rather than P can find it again). detect()
  /// restores P, and already_found() answers no, inside a confirmed track's gate that no found box
  /// overlaps: another object is predicted there.
  Box2D blanked_region(const Box2D& box) const;
  /// A later object's pass adds its candidates and stage times to the window's result.
  static void add_later_pass(const DetectionResult& later, DetectionResult& res);
  bool already_found(std::span<const Detection2D> found, const Eigen::Vector2d& center) const;
  /// The raw box against the sensor's border (border_cut.h).
  std::optional<BorderCut> border_cut(const Box2D& box_raw) const {
    return fdv::border_cut(box_raw, camera_.width, camera_.height);
  }
  /// Sizes every image buffer for width × height (S = P = 0).
  void allocate(int width, int height);
  DetectorOptions options_;
  PinholeCamera camera_;
  // Buffers, sized to the image in the constructor: detect() does not allocate once the time
  // images have seen a window (tests/pipeline/no_allocation_test.cpp).
  TimeImages ti_;
  cv::Mat S_;
  cv::Rect S_nonzero_;  ///< S_ is zero outside this rectangle (the last segmentation's bounds)
  Preprocessor pre_;
  cv::Mat rest_;          ///< P with the window's objects found so far blanked, zero outside rest_bounds_
  cv::Rect rest_bounds_;
  RegionScratch region_;      ///< retrieval's scratch, shared by the sources that run it
  std::vector<Box2D> gates_;            ///< this window's confirmed tracks' gates
  std::vector<Box2D> tentative_gates_;  ///< and its tentative tracks' (DetectionPrior::confirmed)
  /// The registered sources these options switch on, in the registry's order.
  struct Source {
    std::string_view name;
    std::unique_ptr<CandidateSource> source;
  };
  std::vector<Source> sources_;
  EventRefiner refiner_;
};

}  // namespace fdv
