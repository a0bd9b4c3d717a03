#pragma once
/// What Detector::detect reports about one window (detector.h), and the track priors it takes.
/// Plain value types; each candidate source (candidate_source.h) writes its own diagnostics and is
/// timed under its registered name:
///
///   DetectionResult r = detector.detect(view);
///   if (const auto* cc = r.diagnostics<CountContrastDiagnostics>("count_contrast")) use(cc->contrast);
///   double ms = r.timings.source_ms("count_contrast");   // 0: not tried in this window
/// Thread safety: value types; const access from any thread.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <new>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "fdv/detection/detection2d.h"

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
  /// Set by the pipeline, not the detector: a window between anchors with no track's gate to look
  /// in (PerceptionOptions::gates_only_between_anchors), whose events were not searched.
  kNotSearched,
};
std::string_view to_string(DetectionStatus s);

/// Candidate sources a detector can have registered (candidate_source.h): a result keeps each one's
/// diagnostics and time inline, so that detect() does not allocate.
inline constexpr int kMaxCandidateSources = 8;

/// One candidate source's diagnostics of a window, under its registered name: a value of the
/// source's own diagnostics type D, which the source writes (write<D>()) as it runs, or nothing
/// when it did not run as far. D: trivially copyable, at most kBytes, one type per source.
class SourceDiagnostics {
 public:
  static constexpr std::size_t kBytes = 64;
  explicit SourceDiagnostics(std::string_view source = {}) : source_(source) {}
  std::string_view source() const { return source_; }
  bool empty() const { return type_ == nullptr; }

  /// The diagnostics, value-initialised on the first call of the window.
  template <class D>
  D& write() {
    static_assert(std::is_trivially_copyable_v<D> && sizeof(D) <= kBytes && alignof(D) <= alignof(std::max_align_t),
                  "a source's diagnostics: a small, trivially copyable struct");
    if (type_ == nullptr) {
      type_ = &kTag<D>;
      return *::new (bytes_.data()) D{};
    }
    if (type_ != &kTag<D>) throw std::logic_error("source " + std::string(source_) + " writes two diagnostics types");
    return *std::launder(reinterpret_cast<D*>(bytes_.data()));
  }
  /// What the source wrote; nullptr when nothing, or another type than D.
  template <class D>
  const D* read() const {
    return type_ == &kTag<D> ? std::launder(reinterpret_cast<const D*>(bytes_.data())) : nullptr;
  }

 private:
  template <class D>
  static constexpr char kTag = 0;  ///< its address identifies D
  std::string_view source_;
  const void* type_ = nullptr;
  alignas(std::max_align_t) std::array<std::byte, kBytes> bytes_{};
};

/// The time of one candidate source's find() calls in a window [ms], under its registered name.
struct SourceTime {
  std::string_view source;
  double ms = 0;
};

/// Wall-clock time of each stage [ms] (steady clock).
struct DetectionTimings {
  double time_images_ms = 0;
  double segmentation_ms = 0;
  double preprocess_ms = 0;
  double refine_ms = 0;  ///< center / time refinement from the events
  double total_ms = 0;

  /// Each candidate source's time, in the order they were first tried; one not tried is absent.
  std::span<const SourceTime> sources() const { return {sources_.data(), source_count_}; }
  /// `source`'s time; 0 when it was not tried.
  double source_ms(std::string_view source) const {
    for (const SourceTime& s : sources())
      if (s.source == source) return s.ms;
    return 0;
  }
  /// Adds `ms` to `source`'s time (tried from now on).
  void add_source_ms(std::string_view source, double ms) {
    for (std::size_t i = 0; i < source_count_; ++i)
      if (sources_[i].source == source) {
        sources_[i].ms += ms;
        return;
      }
    if (source_count_ == sources_.size()) throw std::length_error("more candidate sources than kMaxCandidateSources");
    sources_[source_count_++] = {source, ms};
  }

 private:
  std::array<SourceTime, kMaxCandidateSources> sources_{};
  std::size_t source_count_ = 0;
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
  DetectionTimings timings;
  /// The diagnostics `source` (its registered name) wrote in this window, as its diagnostics type D
  /// (the source's header names it, e.g. CountContrastDiagnostics); nullptr when it wrote none: it
  /// is not registered, or did not run as far. Those of a window's first object.
  template <class D>
  const D* diagnostics(std::string_view source) const {
    for (const SourceDiagnostics& d : source_diagnostics())
      if (d.source() == source) return d.read<D>();
    return nullptr;
  }
  /// Where `source` writes its diagnostics (CandidateSource::find): its slot, added on first use.
  SourceDiagnostics& diagnostics_of(std::string_view source) {
    for (std::size_t i = 0; i < diagnostics_count_; ++i)
      if (diagnostics_[i].source() == source) return diagnostics_[i];
    if (diagnostics_count_ == diagnostics_.size())
      throw std::length_error("more candidate sources than kMaxCandidateSources");
    return diagnostics_[diagnostics_count_++] = SourceDiagnostics(source);
  }
  std::span<const SourceDiagnostics> source_diagnostics() const { return {diagnostics_.data(), diagnostics_count_}; }
  /// The first object found, or nullptr.
  const Detection2D* strongest() const { return detections.empty() ? nullptr : &detections.front(); }

 private:
  std::array<SourceDiagnostics, kMaxCandidateSources> diagnostics_;
  std::size_t diagnostics_count_ = 0;
};

/// Where a confirmed track expects its object in a window (raw sensor pixels, the tracker's grid):
/// when no pattern passes the normal evidence gates, the detector looks again inside
/// DetectorOptions::prior_gate_scale × this box (sources 2-4, detector.h).
struct DetectionPrior {
  Eigen::Vector2d center_raw = Eigen::Vector2d::Zero();
  Eigen::Vector2d box_size_px = Eigen::Vector2d::Zero();
  /// False for a tentative track's prior: its gate is searched by the dense-motion source, whose
  /// time-plane test is the strictest of the gate sources, and by the count-contrast source's sparse
  /// search with a still camera only (docs/DETECTION.md).
  bool confirmed = true;
  /// Placed where the track's 3D estimate projects (PerceptionOptions::trajectory_gates) rather than
  /// by its image-plane filter; the detector searches both alike.
  bool from_trajectory = false;
};

}  // namespace fdv
