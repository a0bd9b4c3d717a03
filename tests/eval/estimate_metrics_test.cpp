// Trajectory-estimate scoring against a hand-made truth: APE samples, the final estimate per
// track and mode, and the first-estimate latency and closest-approach errors.
#include "fdv/eval/estimate_metrics.h"

#include <gtest/gtest.h>

#include "eval/handmade_truth.h"

namespace fdv {
namespace {

using test::pixel_of;

using test::ms;

// Held still at (0.5, 0, 5) until 50 ms, then thrown across at 2 m/s along -x (in view throughout):
// released at 50 ms, closest to the (still) vehicle at the origin when x = 0, i.e. at 300 ms, 5 m
// away.
std::pair<Eigen::Vector3d, Eigen::Vector3d> thrown(double t) {
  if (t < 0.050) return {{0.5, 0, 5}, Eigen::Vector3d::Zero()};
  return {{0.5 - 2 * (t - 0.050), 0, 5}, {-2, 0, 0}};
}
const BallisticTrajectory kTrue{ms(50), {0.5, 0, 5}, {-2, 0, 0}, Eigen::Vector3d::Zero()};

EstimateRecord record(int t_ms, int track, EstimatorMode mode, const BallisticTrajectory& traj,
                      int first_ms = 50, int last_ms = 0, bool usable = true) {
  return {ms(t_ms), track, mode, ms(first_ms), ms(last_ms ? last_ms : t_ms), traj, usable};
}

BallisticTrajectory shifted(const Eigen::Vector3d& d) {
  BallisticTrajectory t = kTrue;
  t.p0_W += d;
  return t;
}

TEST(EstimateMetrics, ApeSamplesCoverTheObservedIntervalAtEveryTruthSample) {
  const DatasetTruth truth = test::handmade_truth(0.1, 400, thrown);
  const auto s = ape_samples(
      truth, record(100, 1, EstimatorMode::kFusion, shifted({0, 0.3, 0.4}), 60, 100), 1);
  ASSERT_EQ(s.size(), 41u);  // 60..100 ms inclusive at 1 kHz
  for (double e : s) EXPECT_NEAR(e, 0.5, 1e-12);
  EXPECT_NEAR(*prediction_error(truth, record(100, 1, EstimatorMode::kFusion, kTrue), 1, ms(300)),
              0.0, 1e-12);
  EXPECT_FALSE(prediction_error(truth, record(100, 1, EstimatorMode::kFusion, kTrue), 1,
                                ms(900)));  // no truth
}

TEST(DatasetTruth, ContactIsTheFirstSampleInsideTheSafetySphere) {
  // Along x at 1 m/s from x = 0.9 m, 0.3 m beside the still vehicle's origin: the distance
  // √(x² + 0.3²) reaches 0.5 m at x = 0.4 m, i.e. at 500 ms; the closest is 0.3 m at 900 ms.
  const DatasetTruth truth = test::handmade_truth(
      0.1, 1000, [](double t) { return std::pair{Eigen::Vector3d(0.9 - t, 0.3, 0), Eigen::Vector3d(-1, 0, 0)}; });
  EXPECT_EQ(true_contact_time(truth, 1, 0.5), ms(500));
  EXPECT_EQ(true_contact_time(truth, 1, 0.3), ms(900));
  EXPECT_FALSE(true_contact_time(truth, 1, 0.29));  // never that close
  EXPECT_FALSE(true_contact_time(truth, 2, 0.5));   // no such ball
}

TEST(EstimateMetrics, MatchObjectPicksTheClosestBall) {
  DatasetTruth truth = test::handmade_truth(0.1, 400, thrown);
  for (int t = 0; t <= 400; ++t)
    truth.objects.push_back({ms(t), 2, {3, 0, 5}, Eigen::Vector3d::Zero()});
  truth.radius_m[2] = 0.1;
  std::stable_sort(truth.objects.begin(), truth.objects.end(),
                   [](auto& a, auto& b) { return a.t < b.t; });
  EXPECT_EQ(match_object(truth, record(100, 1, EstimatorMode::kFusion, shifted({0, 0.1, 0}))), 1);
  EXPECT_EQ(match_object(
                truth, record(100, 1, EstimatorMode::kFusion,
                              {0, {3, 0.1, 5}, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()})),
            2);
}

TEST(EstimateMetrics, FinalEstimatesKeepTheLastPerTrackAndMode) {
  const std::vector<EstimateRecord> records{
      record(60, 1, EstimatorMode::kFusion, kTrue), record(60, 1, EstimatorMode::kMonocular, kTrue),
      record(70, 1, EstimatorMode::kFusion, shifted({0, 1, 0})),
      record(80, 2, EstimatorMode::kFusion, kTrue)};
  const auto finals = final_estimates(records);
  ASSERT_EQ(finals.size(), 3u);
  EXPECT_EQ(finals.at({1, EstimatorMode::kFusion}).t, ms(70));
  EXPECT_EQ(finals.at({1, EstimatorMode::kMonocular}).t, ms(60));
  EXPECT_EQ(finals.at({2, EstimatorMode::kFusion}).t, ms(80));
}

TEST(BallEstimateTiming, FirstEstimateOfATrackFollowingTheBall) {
  const DatasetTruth truth = test::handmade_truth(0.1, 400, thrown);
  // Track 3 follows the ball; track 9 sits on the background.
  std::vector<WindowDetections> windows;
  for (int t0 = 50; t0 < 150; t0 += 10) {
    const Eigen::Vector3d p = thrown(1e-3 * (t0 + 5)).first;
    windows.push_back(
        {ms(t0), ms(t0 + 10), {{ms(t0 + 5), pixel_of(p), 3}, {ms(t0 + 5), {20, 20}, 9}}});
  }
  const std::vector<EstimateRecord> records{
      record(60, 9, EstimatorMode::kFusion, kTrue),     // a background track: not the ball's
      record(70, 3, EstimatorMode::kMonocular, kTrue),  // another estimator
      record(75, 3, EstimatorMode::kFusion, shifted({0, 9, 0}), 50, 0, false),  // converged, not usable
      record(80, 3, EstimatorMode::kFusion, shifted({0, 0.1, 0})),  // first: 0.1 m off everywhere
      record(150, 3, EstimatorMode::kFusion, kTrue)};               // final: exact
  const BallEstimateTiming t = ball_estimate_timing(truth, windows, records, 1);
  ASSERT_TRUE(t.in_flight_from);
  EXPECT_EQ(*t.in_flight_from, ms(50));
  ASSERT_TRUE(t.closest);
  EXPECT_EQ(t.closest->t, ms(300));
  EXPECT_NEAR(t.closest->distance_m, 5.0, 1e-12);
  ASSERT_TRUE(t.first && t.final);
  EXPECT_EQ(t.first->t, ms(80));
  EXPECT_EQ(t.final->t, ms(150));
  EXPECT_NEAR(*t.latency_s(), 0.030, 1e-12);
  EXPECT_NEAR(*t.first_error_m, 0.1, 1e-12);
  EXPECT_NEAR(*t.final_error_m, 0.0, 1e-12);
  // The first converged estimate, usable or not: the 75 ms one, 9 m off.
  ASSERT_TRUE(t.first_converged);
  EXPECT_EQ(t.first_converged->t, ms(75));
  EXPECT_NEAR(*t.converged_latency_s(), 0.025, 1e-12);
  EXPECT_NEAR(*t.first_converged_error_m, 9.0, 1e-12);

  // Monocular: only the 70 ms record.
  const BallEstimateTiming mono =
      ball_estimate_timing(truth, windows, records, 1, EstimatorMode::kMonocular);
  ASSERT_TRUE(mono.first);
  EXPECT_EQ(mono.first->t, ms(70));
}

}  // namespace
}  // namespace fdv
