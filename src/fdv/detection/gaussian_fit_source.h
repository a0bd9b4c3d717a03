#pragma once
/// Candidate source 1, the paper's (§IV-B.2-3): Algorithm 1 from the strongest pattern of P, moving-
/// region retrieval when the fit yields no plausible box, then the evidence gates; a pattern that
/// fails is blanked and the next strongest is tried, up to max_candidates.
///
///   GaussianFitSource source(options);   // once; allocate(width, height) before the first find()
///   std::optional<Candidate> c = source.find(in, res);
///   res.diagnostics<PatternFitDiagnostics>(GaussianFitSource::kName)->fit_rejected   // why not
///
/// evaluate_pattern() is one pattern's evaluation, which the track-aided source reuses inside the
/// tracks' gates. Options: DetectorOptions::gaussian_fit and the shared fields.
/// Thread safety: not thread-safe (per-window state); owned by one Detector, used by one thread.
#include <optional>
#include <span>
#include <string_view>

#include "fdv/detection/candidate_source.h"
#include "fdv/detection/detector_options.h"

namespace fdv {

/// What the pattern sources (this one and the track-aided one) report: Algorithm 1's outcome for
/// the last pattern evaluated.
struct PatternFitDiagnostics {
  int fit_iterations = 0;
  bool fit_converged = false;
  /// Why the fitted ROI was not used ("" when it was): "not converged", "diverged", "empty roi",
  /// "too large", "aspect ratio", "too few events".
  std::string_view fit_rejected;
};

/// True when `box` holds the predicted centres of two confirmed tracks whose gates do not overlap:
/// a fit or region that merged two objects the tracks keep apart (docs/DETECTION.md, "Several
/// objects"). Such a box is not a candidate; the smaller initial ROIs are tried instead.
bool spans_separate_tracks(const Box2D& box, std::span<const Box2D> gates);

/// Algorithm 1 from `seed` on `P` with the half-image initial ROI, else moving-region retrieval;
/// then the evidence gates (roi_min_events, `min_peak` on the box's peak of P, min_event_density),
/// then smaller initial ROIs (GaussianFitSourceOptions::refit_min_roi_px). Writes the fit's
/// outcome to `fit`. On failure sets in.why_not and `blank`, the area to blank before the next
/// attempt.
std::optional<Candidate> evaluate_pattern(const DetectorOptions& o, SourceWindow& in, const cv::Mat& P, cv::Point seed,
                                          double min_peak, PatternFitDiagnostics& fit, Box2D& blank);

class GaussianFitSource final : public CandidateSource {
 public:
  static constexpr std::string_view kName = "gaussian_fit";
  /// `options` must be valid (DetectorOptions::validate).
  explicit GaussianFitSource(const DetectorOptions& options) : options_(options) {}
  void allocate(int width, int height) override;
  std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) override;

 private:
  DetectorOptions options_;
  /// P with failed candidates blanked (P itself stays as pre-processed); zero outside blanked_bounds_.
  cv::Mat blanked_;
  cv::Rect blanked_bounds_;
};

}  // namespace fdv
