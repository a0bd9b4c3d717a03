#pragma once
/// Candidate source 2: where a confirmed track expects its object, the strongest pattern of P inside
/// the track's gate (SourceWindow::gates) may pass at the lower TrackAidedSourceOptions::min_peak,
/// evaluated as source 1's patterns (evaluate_pattern); its box must stay centred inside the gate.
///
///   TrackAidedSource source(options);
///   std::optional<Candidate> c = source.find(in, res);   // res.track_aided when found
///   res.diagnostics<PatternFitDiagnostics>(TrackAidedSource::kName)   // the last pattern's fit
///
/// It has no buffers of its own: the patterns are evaluated on P itself (no blanking).
/// Thread safety: not thread-safe (per-window state); owned by one Detector, used by one thread.
#include <optional>
#include <string_view>

#include "fdv/detection/candidate_source.h"
#include "fdv/detection/gaussian_fit_source.h"
#include "fdv/detection/detector_options.h"

namespace fdv {

class TrackAidedSource final : public CandidateSource {
 public:
  static constexpr std::string_view kName = "track_aided";
  /// `options` must be valid (DetectorOptions::validate).
  explicit TrackAidedSource(const DetectorOptions& options) : options_(options) {}
  void allocate(int, int) override {}
  std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) override;

 private:
  DetectorOptions options_;
};

}  // namespace fdv
