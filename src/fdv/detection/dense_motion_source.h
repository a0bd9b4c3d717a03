#pragma once
/// Candidate source 3 (not in the paper; docs/DETECTION.md, "Dense-motion source"): inside each
/// confirmed track's gate, the densest patch of active pixels of I (I ≥ min_pixel_events), accepted
/// when the mean-time image T rises across it as a plane (DenseMotionSourceOptions) and its box
/// passes the event gates. Runs only when enabled (the registry makes none otherwise), with priors,
/// and for a window of positive length.
///
///   DenseMotionSource source(options);   // once; allocate(width, height) before the first find()
///   std::optional<Candidate> c = source.find(in, res);
///   res.diagnostics<DenseMotionDiagnostics>(DenseMotionSource::kName)   // how close; nullptr: no square
/// Thread safety: not thread-safe (per-window state); owned by one Detector, used by one thread.
#include <optional>
#include <string_view>

#include "fdv/detection/candidate_source.h"
#include "fdv/detection/detector_options.h"

namespace fdv {

/// The last square's plane fit, once a square was searched: the R² of its time plane and the
/// plane's rise across the square as a fraction of the window.
struct DenseMotionDiagnostics {
  double r2 = 0;
  double span = 0;
};

class DenseMotionSource final : public CandidateSource {
 public:
  static constexpr std::string_view kName = "dense_motion";
  /// `options` must be valid (DetectorOptions::validate).
  explicit DenseMotionSource(const DetectorOptions& options) : options_(options) {}
  void allocate(int width, int height) override;
  std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) override;
  /// The candidate within `search` (clipped to the image), gate or not; writes the diagnostics.
  std::optional<Candidate> find_in(const SourceWindow& in, const cv::Rect& search, DetectionResult& res);

 private:
  DetectorOptions options_;
  cv::Mat active_, active_integral_;  ///< I's active pixels (1) as CV_32F, and their summed-area table
};

}  // namespace fdv
