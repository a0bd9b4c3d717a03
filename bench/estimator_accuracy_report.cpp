// Accuracy of the trajectory estimator on the synthetic Table II throws, over many noise draws:
// the Monte-Carlo behind the bounds of the test FusionAccuracyOnTableTwoThrows, and when the first
// usable fusion estimate appears in the forward stream (docs/ESTIMATION.md quotes both). A plain
// report program, not Google Benchmark: it measures accuracy, not time. About 15 s.
//
//   build/bench/estimator_accuracy_report
#include <cstdio>
#include <random>
#include <vector>

#include "fdv/estimation/trajectory_estimator.h"
#include "tests/estimation/estimator_monte_carlo.h"

namespace fdv {
namespace {

using test::mean;
using test::percentile;

/// Fusion and monocular APE RMSE over 2000 draws (seeds 1000-2999) of each scene and noise level.
void monte_carlo_report() {
  for (const auto& [name, s] :
       {std::pair{"forward", test::forward_scene()}, std::pair{"swing", test::swing_scene()}}) {
    for (double sigma_px : {1.0, 1.5, 2.0}) {
      const test::MonteCarloResult r = test::monte_carlo(s, 1000, 2000, sigma_px);
      std::printf(
          "%s sigma %.1f px: fusion mean %.3f median %.3f p99 %.3f max %.3f usable %d | mono "
          "median %.3f p90 %.3f usable %d | NEES %.2f | refused observations %d\n",
          name, sigma_px, mean(r.fusion), percentile(r.fusion, 0.5), percentile(r.fusion, 0.99),
          percentile(r.fusion, 1.0), r.fusion_usable, percentile(r.mono, 0.5),
          percentile(r.mono, 0.9), r.mono_usable, r.nees_mean, r.refused);
    }
  }
}

/// When the first usable fusion estimate appears in the forward stream (events every 30 ms, depth
/// at 33/100/167 ms) and how good it is, over 500 draws (seeds 1000-1499).
void first_usable_estimate_report() {
  const test::Scene s = test::forward_scene();
  std::vector<double> t_first, err_first;
  for (int seed = 1000; seed < 1500; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    const test::Observations obs = test::observe(s, rng, 1.5, true);
    TrajectoryEstimator est(test::options_for(s));
    std::size_t i = 0, j = 0;
    while (i < obs.events.size() || j < obs.depths.size()) {
      const bool ev =
          j >= obs.depths.size() || (i < obs.events.size() && obs.events[i].t <= obs.depths[j].t);
      const TimeNs t = ev ? obs.events[i].t : obs.depths[j].t;
      if (ev)
        est.add(obs.events[i++]);
      else
        est.add(obs.depths[j++]);
      const TrajectoryEstimate& e = est.solve();
      if (e.usable) {
        t_first.push_back(to_seconds(t) * 1e3);
        err_first.push_back(test::ape_rmse(e.trajectory, s.truth, 0, 180 * kNsPerMs));
        break;
      }
    }
  }
  std::printf(
      "first usable after %zu/500 runs: median t %.0f ms (p90 %.0f); APE over 0-180 ms of that "
      "estimate: median %.3f m p90 %.3f m\n",
      t_first.size(), percentile(t_first, 0.5), percentile(t_first, 0.9),
      percentile(err_first, 0.5), percentile(err_first, 0.9));
}

}  // namespace
}  // namespace fdv

int main() {
  fdv::monte_carlo_report();
  fdv::first_usable_estimate_report();
}
