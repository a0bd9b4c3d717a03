#include "fdv/detection/track_aided_source.h"

#include <cmath>
#include <sstream>

#include "fdv/detection/gaussian_fit_source.h"

namespace fdv {

std::string TrackAidedSourceOptions::validate() const {
  if (!std::isfinite(min_peak)) return "non-finite detector parameter";
  std::ostringstream why;
  if (!(min_peak >= 0 && min_peak <= 1)) why << "prior_min_peak must be in [0, 1], got " << min_peak;
  return why.str();
}

std::optional<Candidate> TrackAidedSource::find(SourceWindow& in, DetectionResult& res) {
  const double min_peak = options_.track_aided.min_peak;
  for (const Box2D& gate : in.gates) {
    const cv::Rect g = box_pixels(gate, in.events.width, in.events.height);
    if (g.area() == 0) continue;
    const MaxLocation peak = first_maximum(in.P, g);
    const double p_max = peak.value;
    if (!(p_max > 0) || p_max < min_peak * min_peak) continue;
    ++res.candidates;
    Box2D blank;
    PatternFitDiagnostics& diagnostics = res.diagnostics_of(kName).write<PatternFitDiagnostics>();
    std::optional<Candidate> found = evaluate_pattern(options_, in, in.P, peak.at, min_peak, diagnostics, blank);
    if (found && gate.contains(found->center)) {
      res.track_aided = true;
      return found;
    }
  }
  return std::nullopt;
}

}  // namespace fdv
