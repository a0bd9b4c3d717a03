#include "fdv/eval/estimate_metrics.h"

#include <algorithm>
#include <limits>

#include "fdv/eval/trajectory_error.h"

namespace fdv {

int match_object(const DatasetTruth& truth, const EstimateRecord& e) {
  int best = -1;
  double best_err = std::numeric_limits<double>::infinity();
  for (const auto& [id, r] : truth.radius_m) {
    const Summary s = summarize(ape_samples(truth, e, id));
    if (s.count && s.mean < best_err) best_err = s.mean, best = id;
  }
  return best;
}

std::map<std::pair<int, EstimatorMode>, EstimateRecord> final_estimates(
    const std::vector<EstimateRecord>& records) {
  std::map<std::pair<int, EstimatorMode>, EstimateRecord> finals;
  for (const EstimateRecord& e : records) finals[{e.track, e.mode}] = e;
  return finals;
}

std::vector<double> ape_samples(const DatasetTruth& truth, const EstimateRecord& e, int id) {
  return position_errors([&](TimeNs t) { return e.trajectory.position(t); }, truth.objects, id,
                         e.t_first, e.t_last);
}

std::optional<double> prediction_error(const DatasetTruth& truth, const EstimateRecord& e, int id,
                                       TimeNs t) {
  const auto s = truth.object_at(id, t);
  if (!s) return std::nullopt;
  return (e.trajectory.position(t) - s->p_W).norm();
}

std::optional<double> BallEstimateTiming::latency_s() const {
  if (!first || !in_flight_from) return std::nullopt;
  return to_seconds(first->t - *in_flight_from);
}

std::optional<double> BallEstimateTiming::converged_latency_s() const {
  if (!first_converged || !in_flight_from) return std::nullopt;
  return to_seconds(first_converged->t - *in_flight_from);
}

BallEstimateTiming ball_estimate_timing(const DatasetTruth& truth,
                                        const std::vector<WindowDetections>& windows,
                                        const std::vector<EstimateRecord>& records, int id,
                                        EstimatorMode mode) {
  BallEstimateTiming out;
  out.in_flight_from = first_in_flight_in_view(truth, id);
  out.closest = true_closest_approach(truth, id);
  const std::vector<int> tracks = tracks_following(truth, windows, id);
  for (const EstimateRecord& e : records) {
    if (e.mode != mode || std::find(tracks.begin(), tracks.end(), e.track) == tracks.end()) continue;
    if (!out.first_converged || e.t < out.first_converged->t) out.first_converged = e;
    if (!e.usable) continue;
    if (!out.first || e.t < out.first->t) out.first = e;
    if (e.track == tracks.front()) out.final = e;
  }
  if (out.closest) {
    if (out.first) out.first_error_m = prediction_error(truth, *out.first, id, out.closest->t);
    if (out.first_converged)
      out.first_converged_error_m = prediction_error(truth, *out.first_converged, id, out.closest->t);
    if (out.final) out.final_error_m = prediction_error(truth, *out.final, id, out.closest->t);
  }
  return out;
}

}  // namespace fdv
