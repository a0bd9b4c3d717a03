#pragma once
// The trajectory estimator over many noisy draws of one synthetic throw: what the accuracy test
// asserts and what bench/estimator_accuracy_report prints (tests and bench only).
#include <algorithm>
#include <random>
#include <vector>

#include "ballistic_scenario.h"
#include "fdv/estimation/trajectory_estimator.h"

namespace fdv::test {

inline EstimatorOptions options_for(const Scene& s, EstimatorMode mode = EstimatorMode::kFusion) {
  EstimatorOptions o;
  o.mode = mode;
  o.event_focal_px = s.focal_px;
  o.gravity_W = s.truth.gravity_W;
  return o;
}

/// Feeds all observations in time order, solving after each one as the pipeline does. `refused`
/// counts the observations the estimator neither accepted nor ignored (none on valid input).
inline TrajectoryEstimate run_streaming(TrajectoryEstimator& est, const Observations& obs,
                                        int& refused) {
  std::size_t i = 0, j = 0;
  while (i < obs.events.size() || j < obs.depths.size()) {
    const bool event_next =
        j >= obs.depths.size() || (i < obs.events.size() && obs.events[i].t <= obs.depths[j].t);
    const AddResult r = event_next ? est.add(obs.events[i++]) : est.add(obs.depths[j++]);
    refused += r != AddResult::kAccepted && r != AddResult::kIgnored;
    est.solve();
  }
  return est.latest();
}

struct MonteCarloResult {
  std::vector<double> fusion, mono;  ///< APE RMSE [m] of each run's final estimate
  double nees_mean = 0;  ///< mean of (x - x_true)ᵀ Σ⁻¹ (x - x_true) over fusion runs (6 dof)
  int fusion_usable = 0, mono_usable = 0;
  int refused = 0;  ///< observations refused over all runs (run_streaming)
};

/// `runs` draws (seeds first_seed, first_seed + 1, ...) of scene `s` with `sigma_px` detection noise
/// and depth noise, each estimated by the fusion and by the monocular baseline.
inline MonteCarloResult monte_carlo(const Scene& s, int first_seed, int runs, double sigma_px) {
  MonteCarloResult r;
  int nees_n = 0;
  for (int seed = first_seed; seed < first_seed + runs; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    EstimatorOptions o = options_for(s);
    o.event_sigma_px = sigma_px;
    const Observations obs = observe(s, rng, sigma_px, true);
    TrajectoryEstimator fusion(o);
    const TrajectoryEstimate f = run_streaming(fusion, obs, r.refused);
    o.mode = EstimatorMode::kMonocular;
    TrajectoryEstimator mono(o);
    const TrajectoryEstimate m = run_streaming(mono, obs, r.refused);
    const TimeNs t1 = std::max(s.event_times.back(), s.depth_times.back());
    r.fusion.push_back(ape_rmse(f.trajectory, s.truth, 0, t1));
    r.mono.push_back(ape_rmse(m.trajectory, s.truth, 0, t1));
    r.fusion_usable += f.usable;
    r.mono_usable += m.usable;
    if (f.covariance) {
      Eigen::Matrix<double, 6, 1> err;
      err << f.trajectory.p0_W - s.truth.p0_W, f.trajectory.v0_W - s.truth.v0_W;
      r.nees_mean += err.dot(f.covariance->ldlt().solve(err));
      ++nees_n;
    }
  }
  r.nees_mean /= std::max(1, nees_n);
  return r;
}

inline double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

/// The element at fraction p of the sorted values (no interpolation).
inline double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

}  // namespace fdv::test
