// The any-size detection metrics on hand-made windows against a hand-made truth whose pixels are
// known in closed form (tests/eval/handmade_truth.h): apparent-size bins, balls cut by the border,
// "fills the view" windows, and two balls scored apart with their identity switches.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <sstream>
#include <nlohmann/json.hpp>

#include "eval/handmade_truth.h"
#include "fdv/eval/detection_metrics.h"

namespace fdv {
namespace {

using test::kF;
using test::pixel_of;

using test::ms;
using test::window;

using Det = WindowDetections::Det;

/// A ball of radius r at depth z crossing slowly in front of the camera (2 m/s sideways).
struct Crossing {
  double r, z;
  Eigen::Vector3d at(int t_ms) const { return {-0.1 + 2e-3 * t_ms, 0, z}; }
  DatasetTruth truth() const { return test::straight_flight(at(0), {2, 0, 0}, r); }
  /// The silhouette's width on the axis: 2 f tan(asin(r / z)).
  double size_px() const { return 2 * kF * std::tan(std::asin(r / z)); }
};

TEST(AnySizeMetrics, EligibleWindowsArePooledByApparentSize) {
  // 0.25 m ball at 40, 10, 5 and 2 m: ~6, 25, 50, 125 px; one window found (1 px off), one missed.
  const std::vector<std::pair<Crossing, std::size_t>> cases{
      {{0.25, 40}, 0}, {{0.25, 10}, 1}, {{0.25, 5}, 2}, {{0.25, 2}, 3}};
  for (const auto& [ball, bin] : cases) {
    const DetectionMetrics m = detection_metrics(
        ball.truth(),
        {window(10, {{ms(15), pixel_of(ball.at(15)) + Eigen::Vector2d(0, 1), 4}}), window(20)});
    EXPECT_NEAR(m.per_window[0].size_px, ball.size_px(), 0.02 * ball.size_px()) << ball.z;
    for (std::size_t b = 0; b < m.size_bins.size(); ++b) {
      EXPECT_EQ(m.size_bins[b].eligible, b == bin ? 2u : 0u) << ball.z << " bin " << b;
      EXPECT_EQ(m.size_bins[b].found, b == bin ? 1u : 0u) << ball.z << " bin " << b;
    }
    ASSERT_EQ(m.size_bins[bin].center_errors_px.size(), 1u);
    EXPECT_NEAR(m.size_bins[bin].center_errors_px[0], 1.0, 1e-9);
    EXPECT_EQ(m.any_size.eligible, 2u);
    EXPECT_DOUBLE_EQ(m.any_size.recall(), 0.5);
    EXPECT_EQ(m.partial.eligible, 0u);
    // Table I's window recall leaves out the 6 px ball (< 8 px) and scores the rest alike.
    EXPECT_EQ(m.eligible, bin == 0 ? 0u : 2u) << ball.z;
  }
  EXPECT_EQ(size_bin_label(0), "< 10 px");
  EXPECT_EQ(size_bin_label(1), "10-40 px");
  EXPECT_EQ(size_bin_label(3), "> 100 px");
  EXPECT_EQ(size_bin_of(9.99), 0u);
  EXPECT_EQ(size_bin_of(10), 1u);
  EXPECT_EQ(size_bin_of(100.5), 3u);
  // 3 px: too small for any bin.
  EXPECT_EQ(detection_metrics(Crossing{0.015, 5}.truth(), {window(10)}).any_size.eligible, 0u);
}

TEST(AnySizeMetrics, FillsTheViewWindowsAreCountedNotScored) {
  // 0.25 m at 1 m: ~258 px, more than half of 480 px.
  const Crossing near{0.25, 1};
  ASSERT_GT(near.size_px(), 240);
  const DetectionMetrics m = detection_metrics(
      near.truth(), {window(10, {}, kFillsTheViewStatus),
                     window(20, {{ms(25), pixel_of(near.at(25)), 1}}, "no plausible region"),
                     window(30)});
  EXPECT_EQ(m.fills_view_windows, 3u);
  EXPECT_EQ(m.fills_view_reported, 1u);
  EXPECT_EQ(m.any_size.eligible, 0u);  // neither a hit ...
  EXPECT_EQ(m.false_detections, 0u);   // ... nor a false detection
  EXPECT_TRUE(m.per_window[1].fills_view);
  ASSERT_EQ(m.per_pair.size(), 3u);  // listed, not scored: found says a detection lay on it
  EXPECT_TRUE(m.per_pair[1].fills_view && m.per_pair[1].found);
  EXPECT_EQ(m.per_pair[1].center_error_px, -1);
  EXPECT_EQ(m.to_json()["fills_view"]["reported"], 1);
}

// A 0.25 m ball 5 m ahead (radius ~25 px) moving down along the left border.
DatasetTruth along_the_border(double u_center) {
  const double x = (u_center - test::kCx) / kF * 5;
  return test::straight_flight({x, -0.2, 5}, {0, 2, 0});
}

TEST(AnySizeMetrics, PartialWindowsScoreTheVisibleCenterAndTheWholeCenterApart) {
  const DatasetTruth truth = along_the_border(-0.5);  // centre on the border: half in view
  auto visible_center = [&](TimeNs t) {
    return visible_silhouette(truth.objects, 1, 0.25, truth.body, truth.calibration, t)
        .visible_center_px;
  };
  const Eigen::Vector3d p15 = truth.object_at(1, ms(15))->p_W;
  ASSERT_GT(visible_center(ms(15)).x(), 5);  // the visible half's centroid, well inside
  Det cut{ms(15), visible_center(ms(15)) + Eigen::Vector2d(0.5, 0), 3, true, 0.5,
          pixel_of(p15) + Eigen::Vector2d(0, 2)};
  // Found but not flagged partial, no whole-object estimate; 2 px off the visible centre.
  Det unflagged{ms(25), visible_center(ms(25)) + Eigen::Vector2d(0, 2), 3};
  const DetectionMetrics m =
      detection_metrics(truth, {window(10, {cut}), window(20, {unflagged}), window(30)});
  EXPECT_EQ(m.partial.eligible, 3u);
  EXPECT_EQ(m.partial.found, 2u);
  EXPECT_EQ(m.partial_flagged, 1u);
  ASSERT_EQ(m.partial.center_errors_px.size(), 2u);
  EXPECT_NEAR(m.partial.center_errors_px[0], 0.5, 1e-9);
  EXPECT_NEAR(m.partial.center_errors_px[1], 2.0, 1e-9);
  ASSERT_EQ(m.center_full_errors_px.size(), 1u);
  EXPECT_NEAR(m.center_full_errors_px[0], 2.0, 1e-9);
  EXPECT_EQ(m.size_bins[2].eligible, 3u);  // ~25 px wide, ~50 px tall: the 40-100 px bin
  EXPECT_EQ(m.eligible, 0u);               // Table I's recall wants 80 % in view
  EXPECT_EQ(m.false_detections, 0u);

  // 14 % in view (centre 15 px outside): not eligible, and a detection on it is not false.
  const DatasetTruth mostly_out = along_the_border(-15.5);
  const DetectionMetrics out =
      detection_metrics(mostly_out, {window(10, {{ms(15), Eigen::Vector2d(2, 239.5), 1}})});
  EXPECT_EQ(out.any_size.eligible, 0u);
  EXPECT_EQ(out.false_detections, 0u);
}

/// Two 0.25 m balls 5 m ahead falling side by side, centres 30 px apart (radius ~25 px): their
/// boxes overlap between u ≈ 310 and 330.
DatasetTruth two_balls() {
  const Eigen::Vector3d v(0, 2, 0), p1(-0.15, -0.2, 5), p2(0.15, -0.2, 5);
  DatasetTruth t = test::straight_flight(p1, v);
  const DatasetTruth other = test::handmade_truth(
      0.25, 200, [=](double s) { return std::pair{Eigen::Vector3d(p2 + s * v), v}; }, 2);
  t.objects.insert(t.objects.end(), other.objects.begin(), other.objects.end());
  std::stable_sort(t.objects.begin(), t.objects.end(),
                   [](const ObjectState& a, const ObjectState& b) { return a.t < b.t; });
  t.radius_m[2] = 0.25;
  return t;
}

TEST(AnySizeMetrics, TwoBallsAreScoredApartWithTheirIdentitySwitches) {
  const DatasetTruth truth = two_balls();
  auto on = [&](int ball, int t_ms, int track, double du = 0) {
    const Eigen::Vector3d p = truth.object_at(ball, ms(t_ms))->p_W;
    return Det{ms(t_ms), pixel_of(p) + Eigen::Vector2d(du, 0), track};
  };
  // Tracks: ball 1 follows 1, 1, 2, 2, -1, 2 (one switch); ball 2 follows 2, 2, 1, 1, -, 2 (two).
  const std::vector<WindowDetections> windows{
      window(10, {on(1, 15, 1), on(2, 15, 2)}),
      window(20, {on(1, 25, 1), on(2, 25, 2)}),
      window(30, {on(1, 35, 2), on(2, 35, 1)}),
      window(40, {on(2, 45, 1), on(1, 45, 2)}),
      window(50, {on(1, 55, -1)}),
      window(60, {on(1, 65, 2), on(2, 65, 2)}),
  };
  const DetectionMetrics m = detection_metrics(truth, windows);
  ASSERT_EQ(m.objects.size(), 2u);
  EXPECT_EQ(m.objects.at(1).counts.eligible, 6u);
  EXPECT_EQ(m.objects.at(1).counts.found, 6u);
  EXPECT_EQ(m.objects.at(2).counts.found, 5u);
  EXPECT_EQ(m.objects.at(1).id_switches, 1);
  EXPECT_EQ(m.objects.at(2).id_switches, 2);
  EXPECT_EQ(m.any_size.eligible, 12u);
  EXPECT_EQ(m.any_size.found, 11u);
  EXPECT_EQ(m.duplicate_detections, 0u);
  const nlohmann::json objects = m.objects_json();
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_EQ(objects[1]["id"], 2);
  EXPECT_EQ(objects[1]["eligible_windows"], 6);
  EXPECT_NEAR(objects[1]["recall"].get<double>(), 5.0 / 6, 1e-12);
  EXPECT_EQ(objects[1]["id_switches"], 2);

  // Pair by pair, as detection_pairs.csv lists them: in window order, then ball; ball 2 is missed
  // in window 50, and each found pair names its track.
  ASSERT_EQ(m.per_pair.size(), 12u);
  const std::vector<std::array<int, 3>> expected{{1, 1, 1}, {2, 1, 2},  {1, 1, 1}, {2, 1, 2},
                                                 {1, 1, 2}, {2, 1, 1},  {1, 1, 2}, {2, 1, 1},
                                                 {1, 1, -1}, {2, 0, -1}, {1, 1, 2}, {2, 1, 2}};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const PairOutcome& p = m.per_pair[i];
    EXPECT_EQ((std::array<int, 3>{p.ball, p.found, p.track}), expected[i]) << i;
    EXPECT_EQ(p.t_start, ms(10 + 10 * static_cast<int>(i / 2))) << i;
    EXPECT_FALSE(p.partial || p.fills_view) << i;
    // The detections lie on the true centres (both balls wholly in view): error 0.
    if (p.found) {
      EXPECT_NEAR(p.center_error_px, 0, 1e-6) << i;
    }
  }
  EXPECT_EQ(m.per_pair[9].center_error_px, -1);
  std::ostringstream csv;
  write_pair_outcomes_csv(csv, {m.per_pair[8], m.per_pair[9]});
  std::vector<std::string> rows;
  std::istringstream text(csv.str());
  for (std::string line; std::getline(text, line);) rows.push_back(line);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0],
            "t_start_s,t_end_s,ball,size_px,fraction_in_view_min,partial,fills_view,found,center_error_px,"
            "track,u_min,v_min,u_max,v_max");
  EXPECT_EQ(rows[1].substr(0, 20), "0.050000,0.060000,1,") << rows[1];
  EXPECT_NE(rows[1].find(",1.000,0,0,1,0.000,-1,"), std::string::npos) << rows[1];
  EXPECT_NE(rows[2].find(",1.000,0,0,0,,-1,"), std::string::npos) << rows[2];

  // Pooled over two runs: the switches add up, the most in one run stays.
  DetectionMetrics pooled = m;
  pooled.merge(detection_metrics(truth, {windows[0], windows[1]}));
  EXPECT_EQ(pooled.objects.at(2).id_switches, 2);
  EXPECT_EQ(pooled.objects.at(2).max_id_switches_per_run, 2);
  EXPECT_EQ(pooled.objects.at(2).counts.eligible, 8u);
}

TEST(AnySizeMetrics, ADetectionInBothBallsBoxesBelongsToTheNearerOnly) {
  const DatasetTruth truth = two_balls();
  const Eigen::Vector2d c1 = pixel_of(truth.object_at(1, ms(15))->p_W),
                        c2 = pixel_of(truth.object_at(2, ms(15))->p_W);
  // 12 px right of ball 1's centre, 18 px left of ball 2's: inside both boxes.
  const Det between{ms(15), c1 + Eigen::Vector2d(12, 0), 5};
  ASSERT_NEAR((c2 - between.center_raw).norm(), 18, 1e-9);
  const DetectionMetrics m = detection_metrics(truth, {window(10, {between})});
  EXPECT_EQ(m.objects.at(1).counts.found, 1u);
  EXPECT_EQ(m.objects.at(2).counts.found, 0u);
  EXPECT_EQ(m.objects.at(2).counts.eligible, 1u);
  EXPECT_EQ(m.false_detections, 0u);
  ASSERT_EQ(m.objects.at(1).counts.center_errors_px.size(), 1u);
  EXPECT_NEAR(m.objects.at(1).counts.center_errors_px[0], 12, 1e-9);

  // Two detections on ball 1: the nearer is its one, the other a duplicate, neither false.
  const Det near1{ms(15), c1 + Eigen::Vector2d(0, 3), 5}, far1{ms(15), c1 - Eigen::Vector2d(8, 0), 6};
  const DetectionMetrics d = detection_metrics(truth, {window(10, {far1, near1})});
  EXPECT_EQ(d.duplicate_detections, 1u);
  EXPECT_EQ(d.false_detections, 0u);
  ASSERT_EQ(d.objects.at(1).counts.center_errors_px.size(), 1u);
  EXPECT_NEAR(d.objects.at(1).counts.center_errors_px[0], 3, 1e-9);
}

}  // namespace
}  // namespace fdv
