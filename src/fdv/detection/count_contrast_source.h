#pragma once
/// Candidate source 4 (not in the paper; docs/DETECTION.md, "Count-contrast cue"): the filled centre
/// box of the count image I with the highest count contrast against its surround
/// (CountContrastSourceOptions), its box from Algorithm 1 on I above the background level. First
/// inside the tracks' gates without the time test (in_gates), then over the whole image with it: the
/// blob's mean event time must stand out from all events' by θ's margin, or, with the camera nearly
/// still, the blob must stand out from its own-scale surround and move within the window.
///
///   CountContrastSource source(options);   // once; allocate(width, height) before the first find()
///   std::optional<Candidate> c = source.find(in, res);   // res.count_cue_* say how close
#include <optional>
#include <vector>

#include "fdv/detection/candidate_source.h"
#include "fdv/detection/detector_options.h"

namespace fdv {

/// Summed-area tables (CV_32S) of one window's count image I over the whole image, each built on
/// its first use after reset() (the gates' searches and the image's share them): I's active pixels
/// (I ≥ min_pixel_events, as 255) and I saturated at 255.
class CountTables {
 public:
  void allocate(int width, int height);
  /// A new window: both tables are rebuilt from `ti` when next asked for.
  void reset(const TimeImages& ti, int min_pixel_events);
  const cv::Mat& active();
  const cv::Mat& saturated();
  bool has_saturated() const { return saturated_built_; }

 private:
  const TimeImages* ti_ = nullptr;
  int min_pixel_events_ = 1;
  cv::Mat active8_, active_integral_, saturated8_, saturated_integral_;
  bool active_built_ = false, saturated_built_ = false;
};

class CountContrastSource final : public CandidateSource {
 public:
  /// `options` must be valid (DetectorOptions::validate).
  explicit CountContrastSource(const DetectorOptions& options) : options_(options) {}
  void allocate(int width, int height) override;
  std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) override;

 private:
  /// The candidate among centres within `search`; with `time_test`, its events' mean time must
  /// stand out from all events' by θ's margin. Sets res.count_cue_*.
  std::optional<Candidate> find_in(const SourceWindow& in, const cv::Rect& search, bool time_test,
                                   DetectionResult& res);
  /// The still-camera test (CountContrastSourceOptions::still_motion): with the camera nearly still
  /// its compensated background is sparse, so a blob that stands out from its own-scale surround and
  /// moves within the window is an object even when its events fire evenly over the window (a
  /// spinning ball coming head-on), which the time test cannot see. Sets res.count_cue_isolation
  /// and count_cue_motion_z.
  bool still_camera_object(const SourceWindow& in, const Candidate& cand, const cv::Rect& box,
                           double image_density, DetectionResult& res) const;
  DetectorOptions options_;
  CountTables tables_;
  std::vector<int> live_blocks_;  ///< the scan's blocks in one band that it cannot skip
  cv::Mat excess_;                ///< I above the background level, CV_32F, zero outside excess_bounds_
  cv::Rect excess_bounds_;
};

}  // namespace fdv
