// Detection metrics and ball-track selection on hand-made windows against a hand-made truth whose
// pixels are known in closed form (tests/eval/handmade_truth.h).
#include "fdv/eval/detection_metrics.h"

#include <gtest/gtest.h>

#include <array>
#include <sstream>

#include "eval/handmade_truth.h"
#include "fdv/core/error.h"

namespace fdv {
namespace {

using test::pixel_of;

using test::ms;
using test::window;

// A 0.25 m ball 5 m ahead crossing at 2 m/s: ~50 px wide, moving 2 px per 10 ms window.
const Eigen::Vector3d kP0(-0.1, 0, 5), kV(2, 0, 0);
Eigen::Vector3d ball_at(int t_ms) { return kP0 + 1e-3 * t_ms * kV; }

TEST(DetectionMetrics, TheFirstBallDetectionSkipsDetectionsOffTheBall) {
  const DatasetTruth truth = test::straight_flight(kP0, kV);
  const std::vector<WindowDetections> windows{
      window(10),                                            // nothing
      window(20, {{ms(25), Eigen::Vector2d(50, 50), 4}}),    // off the ball
      window(30, {{ms(33), Eigen::Vector2d(60, 60), 4}, {ms(35), pixel_of(ball_at(35)), 7}}),  // the second is on it
      window(40, {{ms(45), pixel_of(ball_at(45)), 7}}),
  };
  const auto first = first_ball_detection(truth, windows, 1);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->window_end, ms(40));
  EXPECT_EQ(first->detection.t, ms(35));
  EXPECT_EQ(first->detection.track, 7);
  EXPECT_FALSE(first_ball_detection(truth, {windows[0], windows[1]}, 1));
  EXPECT_FALSE(first_ball_detection(truth, windows, 2));  // no such ball
}

TEST(DetectionMetrics, CountsFoundMissedAndFalseAgainstTheTruthBox) {
  const DatasetTruth truth = test::straight_flight(kP0, kV);
  const Eigen::Vector2d exact = pixel_of(ball_at(15));
  const std::vector<WindowDetections> windows{
      window(10, {{ms(15), exact, 1}}),  // found, error 0
      window(20,
             {{ms(25), pixel_of(ball_at(25)) + Eigen::Vector2d(1.5, 0), 1}}),  // found, error 1.5
      window(30, {{ms(35), Eigen::Vector2d(50, 50), 2}}),  // far from the ball: false
      window(40),                                          // missed
  };
  const DetectionMetrics m = detection_metrics(truth, windows);
  EXPECT_EQ(m.windows, 4u);
  EXPECT_EQ(m.eligible, 4u);
  EXPECT_EQ(m.found, 2u);
  EXPECT_EQ(m.false_detections, 1u);
  EXPECT_DOUBLE_EQ(m.recall(), 0.5);
  EXPECT_DOUBLE_EQ(m.false_per_window(), 0.25);
  ASSERT_EQ(m.center_errors_px.size(), 2u);
  EXPECT_NEAR(m.center_errors_px[0], 0.0, 1e-9);
  EXPECT_NEAR(m.center_errors_px[1], 1.5, 1e-9);

  // The same outcomes window by window, and as the CSV `fdv eval` writes.
  ASSERT_EQ(m.per_window.size(), 4u);
  const std::vector<std::array<int, 4>> expected{{1, 1, 1, 0}, {1, 1, 1, 0}, {1, 0, 1, 1}, {1, 0, 0, 0}};
  for (std::size_t i = 0; i < 4; ++i) {
    const WindowOutcome& o = m.per_window[i];
    EXPECT_EQ(o.t_start, ms(10 + 10 * static_cast<int>(i)));
    EXPECT_EQ((std::array<int, 4>{o.eligible, o.found, o.detections, o.false_detections}), expected[i]) << i;
    EXPECT_EQ(o.ball, 1) << i;
    EXPECT_DOUBLE_EQ(o.fraction_in_view_min, 1.0);
    EXPECT_NEAR(o.span_px_min, 2 * test::kF * 0.25 / 5, 2.0);  // 2 f r / Z = 50 px
    // The box over the window: the disc (2 f r / Z) swept by the 2 px the ball moves in it.
    const int t0 = 10 + 10 * static_cast<int>(i);
    EXPECT_NEAR(0.5 * (o.box.u_min + o.box.u_max), pixel_of(ball_at(t0 + 5)).x(), 0.1) << i;
    EXPECT_NEAR(o.box.u_max - o.box.u_min, 2 * test::kF * 0.25 / 5 + test::kF * 0.02 / 5, 0.5) << i;
    EXPECT_NEAR(0.5 * (o.box.v_min + o.box.v_max), pixel_of(ball_at(t0 + 5)).y(), 0.1) << i;
  }
  EXPECT_NEAR(m.per_window[1].center_error_px, 1.5, 1e-9);
  EXPECT_EQ(m.per_window[3].center_error_px, -1);
  std::ostringstream csv;
  std::vector<WindowOutcome> rows = m.per_window;
  rows.push_back({});  // a window without a ball: its box's columns are empty
  write_window_outcomes_csv(csv, rows);
  std::istringstream lines(csv.str());
  std::string header, row;
  std::getline(lines, header);
  EXPECT_EQ(header,
            "t_start_s,t_end_s,eligible,found,detections,false_detections,center_error_px,ball,"
            "fraction_in_view_min,span_px_min,size_px,fills_view,u_min,v_min,u_max,v_max");
  std::getline(lines, row);
  std::getline(lines, row);
  const auto starts_with = [](const std::string& text, const std::string& prefix) {
    return text.substr(0, prefix.size()) == prefix;
  };
  EXPECT_TRUE(starts_with(row, "0.020000,0.030000,1,1,1,0,1.500,1,1.000,")) << row;
  std::getline(lines, row);
  std::getline(lines, row);
  EXPECT_TRUE(starts_with(row, "0.040000,0.050000,1,0,0,0,,1,1.000,")) << row;
  std::getline(lines, row);
  EXPECT_EQ(row, "0.000000,0.000000,0,0,0,0,,-1,0.000,0.00,0.00,0,,,,");
}

TEST(DetectionMetrics, AHeldBallIsNotEligibleAndADetectionOnItIsNotFalse) {
  const DatasetTruth truth = test::straight_flight(kP0, Eigen::Vector3d::Zero());  // held still
  const DetectionMetrics m =
      detection_metrics(truth, {window(10, {{ms(15), pixel_of(kP0), 1}}), window(20)});
  EXPECT_EQ(m.eligible, 0u);
  EXPECT_EQ(m.found, 0u);
  EXPECT_EQ(m.false_detections, 0u);
  EXPECT_TRUE(m.center_errors_px.empty());
  EXPECT_EQ(m.recall(), 0.0);
}

TEST(DetectionMetrics, SmallOrHalfHiddenBallsAreNotEligible) {
  // 2 cm ball at 5 m: 2 f r / Z = 4 px < 8 px.
  EXPECT_EQ(detection_metrics(test::straight_flight(kP0, kV, 0.02), {window(10)}).eligible, 0u);
  // Centre on the image's left edge (u = -0.5, X = (u - cx) Z / f = -3.2 m): about half the
  // silhouette is out of view.
  const Eigen::Vector3d edge(-3.2, 0, 5);
  EXPECT_EQ(detection_metrics(test::straight_flight(edge, Eigen::Vector3d(0, 2, 0)), {window(10)})
                .eligible,
            0u);
  // With the in-view bound lowered to 40 %, the same window counts.
  DetectionMetricsOptions o;
  o.min_fraction_in_view = 0.4;
  EXPECT_EQ(
      detection_metrics(test::straight_flight(edge, Eigen::Vector3d(0, 2, 0)), {window(10)}, o)
          .eligible,
      1u);
}

TEST(DetectionMetrics, MergePoolsRuns) {
  DetectionMetrics a, b;
  a.windows = 10, a.eligible = 4, a.found = 3, a.false_detections = 1, a.center_errors_px = {1, 2};
  b.windows = 30, b.eligible = 6, b.found = 6, b.false_detections = 0, b.center_errors_px = {0.5};
  a.per_window = {WindowOutcome{.t_start = 1}};
  b.per_window = {WindowOutcome{.t_start = 2}, WindowOutcome{.t_start = 3}};
  a.merge(b);
  ASSERT_EQ(a.per_window.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(a.per_window[i].t_start, i + 1);
  EXPECT_EQ(a.windows, 40u);
  EXPECT_EQ(a.eligible, 10u);
  EXPECT_EQ(a.found, 9u);
  EXPECT_EQ(a.false_detections, 1u);
  EXPECT_EQ(a.center_errors_px, (std::vector<double>{1, 2, 0.5}));
  EXPECT_DOUBLE_EQ(a.recall(), 0.9);
}

TEST(DetectionMetrics, InvalidOptionsAreRejected) {
  DetectionMetricsOptions o;
  o.min_fraction_in_view = 1.5;
  EXPECT_THROW(detection_metrics(test::straight_flight(kP0, kV), {}, o), ConfigError);
}

TEST(TracksFollowing, MajorityOnTheBallOrderedByCount) {
  const DatasetTruth truth = test::straight_flight(kP0, kV);
  std::vector<WindowDetections> windows;
  auto on_ball = [](int t0, int track) {
    return window(t0, {{ms(t0 + 5), pixel_of(ball_at(t0 + 5)), track}});
  };
  auto off_ball = [](int t0, int track) {
    return window(t0, {{ms(t0 + 5), Eigen::Vector2d(30, 400), track}});
  };
  // Track 3: 2 of 2 on the ball. Track 5: 3 of 4. Track 7: 1 of 3 (mostly background). -1:
  // untracked.
  for (int t0 : {0, 10}) windows.push_back(on_ball(t0, 3));
  for (int t0 : {20, 30, 40}) windows.push_back(on_ball(t0, 5));
  windows.push_back(off_ball(50, 5));
  windows.push_back(on_ball(60, 7));
  for (int t0 : {70, 80}) windows.push_back(off_ball(t0, 7));
  windows.push_back(on_ball(90, -1));
  EXPECT_EQ(tracks_following(truth, windows, 1), (std::vector<int>{5, 3}));
  EXPECT_TRUE(tracks_following(truth, windows, 2).empty());  // no such ball
}

}  // namespace
}  // namespace fdv
