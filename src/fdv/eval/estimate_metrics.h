#pragma once
/// Scoring 3D trajectory estimates against a simulated dataset's truth: APE of a track's final
/// estimate over its observed interval (paper Table II), and how early the first usable estimate
/// of the ball came and how well it predicted the closest approach.
///
///   const auto tracks = tracks_following(truth, windows, ball);          // detection_metrics.h
///   const auto finals = final_estimates(estimates);
///   if (auto it = finals.find({tracks.front(), EstimatorMode::kFusion}); it != finals.end())
///     Summary s = summarize(ape_samples(truth, it->second, ball));
///   BallEstimateTiming timing = ball_estimate_timing(truth, windows, estimates, ball);
///
/// Records come from a run in memory (run_experiment) or from a results folder (read_estimates).
/// Records are the converged estimates; `usable` marks those fit to act on (the first-estimate
/// timing counts only these; APE scores the final converged fit, usable or not, as Table II
/// compares estimators on their in-sample fits).
/// Thread safety: value types and pure functions; may be used from any thread.
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "fdv/estimation/ballistic.h"
#include "fdv/estimation/trajectory_estimator.h"
#include "fdv/eval/dataset_truth.h"
#include "fdv/eval/detection_metrics.h"

namespace fdv {

/// One usable trajectory estimate as evaluation needs it.
struct EstimateRecord {
  TimeNs t =
      0;  ///< stream time at which it was made (end of the window or depth frame that triggered it)
  int track = -1;
  EstimatorMode mode = EstimatorMode::kFusion;
  TimeNs t_first = 0, t_last = 0;  ///< observed interval
  BallisticTrajectory trajectory;
  bool usable = true;  ///< TrajectoryEstimate::usable (converged is implied)
};

/// The ball an estimate follows: the one closest to it on average over its observed interval; -1
/// when no ball has truth samples there.
int match_object(const DatasetTruth& truth, const EstimateRecord& e);

/// The final (last in `records`) estimate of each (track, mode).
std::map<std::pair<int, EstimatorMode>, EstimateRecord> final_estimates(
    const std::vector<EstimateRecord>& records);

/// APE samples of `e` against ball `id` at every truth sample of its observed interval.
std::vector<double> ape_samples(const DatasetTruth& truth, const EstimateRecord& e, int id);

/// |position predicted by `e` at t − true position of ball `id` at t|; nothing without truth at t.
std::optional<double> prediction_error(const DatasetTruth& truth, const EstimateRecord& e, int id,
                                       TimeNs t);

/// How early a usable estimate of ball `id` came (and the first converged one, usable or not) (paper §V-D: the ball must be estimated long
/// before it arrives) and how well the first and the final one predicted the closest approach.
struct BallEstimateTiming {
  std::optional<TimeNs> in_flight_from;        ///< truth: first_in_flight_in_view()
  std::optional<TrueClosestApproach> closest;  ///< truth: true_closest_approach()
  std::optional<EstimateRecord> first;  ///< earliest usable estimate of any track following the ball
  /// Earliest converged estimate of such a track, usable or not (the "first 3D estimate";
  /// its covariance may still say it cannot be acted on).
  std::optional<EstimateRecord> first_converged;
  std::optional<double> first_converged_error_m;  ///< prediction_error(first_converged) there
  std::optional<EstimateRecord> final;  ///< last estimate of the main track following it
  std::optional<double> first_error_m;  ///< prediction_error(first) at the true closest approach
  std::optional<double> final_error_m;  ///< prediction_error(final) there
  /// first->t − in_flight_from [s], when both exist.
  std::optional<double> latency_s() const;
  /// first_converged->t − in_flight_from [s], when both exist.
  std::optional<double> converged_latency_s() const;
};
BallEstimateTiming ball_estimate_timing(const DatasetTruth& truth,
                                        const std::vector<WindowDetections>& windows,
                                        const std::vector<EstimateRecord>& records, int id,
                                        EstimatorMode mode = EstimatorMode::kFusion);

}  // namespace fdv
