#pragma once
/// Candidate source 4 (not in the paper; docs/DETECTION.md, "Count-contrast source"): the filled centre
/// box of the count image I with the highest count contrast against its surround
/// (CountContrastSourceOptions), its box from Algorithm 1 on I above the background level. First
/// inside the tracks' gates without the time test (in_gates), then over the whole image with it: the
/// blob's mean event time must stand out from all events' by θ's margin, or, with the camera nearly
/// still, the blob must stand out from its own-scale surround and move within the window. With the
/// camera nearly still and nothing found, the same search again for a sparse blob (Activity::kSparse):
/// a far object that fires an event on a fraction of its pixels per window.
///
///   CountContrastSource source(options);   // once; allocate(width, height) before the first find()
///   std::optional<Candidate> c = source.find(in, res);
///   res.diagnostics<CountContrastDiagnostics>(CountContrastSource::kName)   // how close; nullptr: no search
/// Thread safety: not thread-safe (per-window tables); owned by one Detector, used by one thread.
#include <optional>
#include <string_view>
#include <vector>

#include "fdv/detection/candidate_source.h"
#include "fdv/detection/detector_options.h"

namespace fdv {

/// What the source saw, once it searched (its last dense search: the gates' come first, then the
/// image's).
struct CountContrastDiagnostics {
  /// The highest contrast among centers that fill min_fill (0: none did), that center's fill, and
  /// how many centers filled it.
  double contrast = 0, fill = 0;
  int filled_centers = 0;
  /// (the blob's mean event time − all events') / (max T − min T), when its box passed the event gates.
  double time_offset = 0;
  /// The still-camera test, when it ran (the time test failed with the camera nearly still): the
  /// blob's isolation and, if that passed, the Wald z of its motion (0: not reached).
  double isolation = 0, motion_z = 0;
  /// The sparse search's active pixels per center box, when it ran (0: it did not).
  int sparse_min_active = 0;
};

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
  const cv::Mat& fired();  ///< I ≥ 1, as 255
  bool has_saturated() const { return saturated_built_; }

 private:
  const TimeImages* ti_ = nullptr;
  int min_pixel_events_ = 1;
  cv::Mat active8_, active_integral_, saturated8_, saturated_integral_, fired_integral_;
  bool active_built_ = false, saturated_built_ = false, fired_built_ = false;
};

/// The fewest active pixels of n that a centre box needs so that, were the image's active pixels
/// scattered independently with the image's fraction p, the expected number of `centres` boxes
/// reaching it is at most `chance`: the least m with centres · P(Binomial(n, p) ≥ m) ≤ chance
/// (n + 1 when no count is that unlikely).
int fewest_unlikely_active(int n, double p, double centers, double chance);

class CountContrastSource final : public CandidateSource {
 public:
  static constexpr std::string_view kName = "count_contrast";
  /// `options` must be valid (DetectorOptions::validate).
  explicit CountContrastSource(const DetectorOptions& options) : options_(options) {}
  void allocate(int width, int height) override;
  std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) override;

 private:
  /// What makes a centre box filled: a fraction ≥ min_fill of its pixels is active. Dense: active =
  /// I ≥ min_pixel_events, min_fill = CountContrastSourceOptions::min_fill. Sparse (the camera
  /// nearly still and the dense search found nothing): active = I ≥ 1, min_fill =
  /// sparse_min_active() / k², a count that scattered events would seldom reach; over the image no
  /// filled centre may lie outside the best one's surround, the density gate is waived and the
  /// still-camera test is required.
  struct Activity {
    bool sparse = false;
    double min_fill = 0;
  };
  /// The candidate among centres within `search`. Over the image (not `in_gate`), a dense blob's
  /// mean event time must stand out from all events' by θ's margin, or the blob pass the
  /// still-camera test. Writes the diagnostics to `out`.
  std::optional<Candidate> find_in(const SourceWindow& in, const cv::Rect& search, bool in_gate, Activity activity,
                                   SourceDiagnostics& out);
  /// θ's motion term a‖ω‖ + b‖v‖ at most CountContrastSourceOptions::still_motion.
  bool camera_still(const SourceWindow& in) const;
  /// kSparse's active pixels per centre box: the fewest that the image's fired pixels, scattered at
  /// random, would fill in CountContrastSourceOptions::sparse_chance boxes per window.
  int sparse_min_active(const TimeImages& ti);
  /// The still-camera test (CountContrastSourceOptions::still_motion): with the camera nearly still
  /// its compensated background is sparse, so a blob that stands out from its own-scale surround and
  /// moves within the window is an object even when its events fire evenly over the window (a
  /// spinning ball coming head-on), which the time test cannot see. In a track's gate the motion
  /// within the window is not asked: the track is its evidence. Writes diagnostics.isolation and
  /// motion_z.
  bool still_camera_object(const SourceWindow& in, const Candidate& cand, const cv::Rect& box,
                           double image_density, bool in_gate, CountContrastDiagnostics& diagnostics) const;
  DetectorOptions options_;
  CountTables tables_;
  std::vector<int> live_blocks_;  ///< the scan's blocks in one band that it cannot skip
  cv::Mat excess_;                ///< I above the background level, CV_32F, zero outside excess_bounds_
  cv::Rect excess_bounds_;
};

}  // namespace fdv
