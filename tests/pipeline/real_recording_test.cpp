// The whole pipeline on a real recording, against positions marked by hand: the check that
// the ball is found while it is in flight and the moving person is not reported in its place.
#include <gtest/gtest.h>

#include <iostream>
#include <map>
#include <tuple>

#include "fdv/core/calibration.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/replay.h"
#include "fdv/pipeline/sensor_policy.h"
#include "fdv/tables/experiment.h"
#include "test_support.h"

namespace fdv {
namespace {

// davis346_ball_throw_person.aedat4 (346x260, 0.75 s): a ball thrown towards a nearly still camera
// falls through the image and leaves at the bottom edge during window 8-9 (25 ms windows from the
// first event); the thrower then moves. The ball's centre on the undistorted grid (the camera at
// the window's start), read by eye off the count images of `fdv run --visualize` (grid lines every
// 20 px; about ±5 px): it is a ring 35-45 px across, 60-90 px near the end.
const std::map<std::uint64_t, Eigen::Vector2d> kBallByHand = {
    {1, {103, 50}},  {2, {107, 67}},  {3, {107, 77}},  {4, {113, 97}},
    {5, {113, 117}}, {6, {117, 143}}, {7, {117, 187}}, {8, {113, 207}},
};

/// The defaults run the evidence source (8 windows of warm-up, 1 cell of travel), whose surround
/// and isolation tests must keep a moving person out; the other variant runs without it.
void without_evidence(PerceptionOptions& options) { options.detection.evidence.enabled = false; }

class RealRecordingThrow : public ::testing::TestWithParam<bool> {};

TEST_P(RealRecordingThrow, TheThrownBallIsFoundInFlightAndThePersonIsNotReported) {
  const std::string path = test::real_data("davis346_ball_throw_person.aedat4");
  FDV_REQUIRE_REAL_FILE(path);
  const Calibration calib = load_calibration(test::real_data("davis346_00000133_calibration.xml"));
  PerceptionOptions options;
  options.compensation.method = CompensationMethod::kRotation;  // events and IMU only
  if (GetParam()) without_evidence(options);
  std::map<std::uint64_t, Detection2D> detections;
  std::uint64_t windows = 0;
  PerceptionCallbacks callbacks;
  callbacks.on_window = [&](const WindowResult& w) {
    ++windows;
    if (!w.detections.empty()) detections[w.index] = w.detections.front().detection;
  };
  replay(open_recording(path), calib, options, callbacks);
  EXPECT_EQ(windows, 30u);
  for (const auto& [index, ball] : kBallByHand) {
    SCOPED_TRACE("window " + std::to_string(index));
    const auto it = detections.find(index);
    ASSERT_NE(it, detections.end()) << "ball not found";
    const Detection2D& d = it->second;
    EXPECT_LT((d.center_undistorted - ball).norm(), 12.0) << d.center_undistorted.transpose();
    // The box holds the ball's centre and has its scale (not a band across it, not the person).
    EXPECT_TRUE(d.box_undistorted.contains(ball)) << d.box_undistorted.x0 << " " << d.box_undistorted.y0 << " "
                                                  << d.box_undistorted.x1 << " " << d.box_undistorted.y1;
    EXPECT_GT(d.box_undistorted.height(), 25.0);
    EXPECT_LT(d.box_undistorted.width(), 100.0);
  }
  // After the ball has left (window 10 on), the thrower moves: nothing is reported.
  for (const auto& [index, d] : detections)
    EXPECT_LT(index, 10u) << "detection at " << d.center_undistorted.transpose() << ", source "
                          << to_string(d.source) << " after the ball left";
}

INSTANTIATE_TEST_SUITE_P(RealRecording, RealRecordingThrow, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& evidence) {
                           return std::string(evidence.param ? "WithoutEvidenceSource" : "Defaults");
                         });

// The same throw, where the ball leaves through the bottom edge (windows 8-10), labelled by hand
// in raw pixels: the recording's events in 5 ms slices from the first event, rendered as count
// images (numpy + matplotlib, grid every 20 px), read by eye. The ball is a ring about 55 px across
// (x 92-152) falling at ≈ 1.6 px/ms; its leading (bottom) arc reaches the edge (y = 259) at
// ≈ 0.222 s and its trailing (top) arc at ≈ 0.26 s: 218 at 0.225 s, 235 at 0.2375 s, 252 at 0.25 s.
// `visible` is the in-view part's box at the window's middle, `in_view` the share of the disc in
// view at the window's start, middle and end (segment areas of a 55 px disc).
struct LeavingBallLabel {
  std::uint64_t window;
  Box2D visible;
  double in_view_start, in_view_middle, in_view_end;
};
const LeavingBallLabel kBallLeaving[] = {
    {8, {92, 197, 152, 250}, 1.00, 1.00, 0.97},  // whole; its bottom arc touches the edge at the end
    {9, {95, 235, 150, 259}, 0.80, 0.41, 0.08},  // cut: ≥ 30 % in view until ≈ 0.241 s
    {10, {100, 252, 145, 259}, 0.08, 0.0, 0.0},  // the top rim only (< 30 %): not to be found
};

// fdv eval's rule for an object cut by the border: eligible when ≥ 30 % of it is in view throughout
// the window (window 8). Window 9, ≥ 30 % in view for its first 64 %, is not found today: the
// window's detection lies on the streak above the ball (y ≈ 202), 33 px above its visible part
// (docs/DETECTION.md, "Objects cut by the border"); the test prints what each labelled window got.
TEST(RealRecording, TheBallLeavingThroughTheBottomEdgeIsFoundWhileAtLeast30PercentIsInView) {
  const std::string path = test::real_data("davis346_ball_throw_person.aedat4");
  FDV_REQUIRE_REAL_FILE(path);
  const Calibration calib = load_calibration(test::real_data("davis346_00000133_calibration.xml"));
  PerceptionOptions options;
  options.compensation.method = CompensationMethod::kRotation;
  std::map<std::uint64_t, std::vector<Detection2D>> detections;
  PerceptionCallbacks callbacks;
  callbacks.on_window = [&](const WindowResult& w) {
    for (const TrackedDetection& d : w.detections) detections[w.index].push_back(d.detection);
  };
  replay(open_recording(path), calib, options, callbacks);
  int eligible = 0;
  for (const LeavingBallLabel& label : kBallLeaving) {
    const Box2D near{label.visible.x0 - 4, label.visible.y0 - 4, label.visible.x1 + 4, label.visible.y1 + 4};
    bool hit = false;
    for (const Detection2D& d : detections[label.window]) {
      hit = hit || near.contains(d.center_raw);
      std::cout << "window " << label.window << ": detection at " << d.center_raw.transpose() << "\n";
    }
    std::cout << "window " << label.window << ": in view " << label.in_view_start << " -> " << label.in_view_end
              << ", on the ball's visible part: " << (hit ? "found" : "missed") << "\n";
    const bool eligible_in_eval = std::min(label.in_view_start, label.in_view_end) >= 0.3;
    if (!eligible_in_eval) continue;
    ++eligible;
    EXPECT_TRUE(hit) << "window " << label.window << ": no detection on the ball's visible part";
  }
  EXPECT_EQ(eligible, 1);
}

// Recordings in which nothing moves towards the camera, run as `fdv run` runs a recording without a
// calibration file (pixel coordinates, no compensation): no window may report an object.
//  - davis346_flicker_noise.aedat4 (346x260, 0.13 s, 6 windows; another DAVIS346 than the
//    calibration's): a static workbench where flickering lamps and a screen make most events;
//  - dvxplorer_person_static.aedat4 (320x240, 24 windows): a still camera, a person's head and
//    shoulders move a little;
//  - dvxplorer_libcaer_ros2.db3 (640x480, 80 windows; background noise only) and evt3_trigger_ros2.db3
//    (1280x720, 51 windows; events with external triggers): ROS 2 bags.
struct StillRecording {
  const char* file;
  std::uint64_t windows;
};

class RealRecordingWithoutObject : public ::testing::TestWithParam<std::tuple<StillRecording, bool>> {};

TEST_P(RealRecordingWithoutObject, NoWindowReportsAnObject) {
  const auto& [recording, no_evidence] = GetParam();
  const std::string path = test::real_data(recording.file);
  FDV_REQUIRE_REAL_FILE(path);
  auto reader = open_recording(path);
  PerceptionOptions options;
  if (no_evidence) without_evidence(options);
  const SensorPolicy policy = apply_sensor_policy(declared_sensors(reader->info()), options);
  std::uint64_t windows = 0;
  PerceptionCallbacks callbacks;
  callbacks.on_window = [&](const WindowResult& w) {
    ++windows;
    for (const TrackedDetection& d : w.detections)
      ADD_FAILURE() << "window " << w.index << ": " << d.detection.center_raw.transpose() << ", source "
                    << to_string(d.detection.source);
  };
  replay(std::move(reader), policy.calibration, policy.options, callbacks);
  EXPECT_EQ(windows, recording.windows);
}

INSTANTIATE_TEST_SUITE_P(RealRecording, RealRecordingWithoutObject,
                         ::testing::Combine(::testing::Values(StillRecording{"davis346_flicker_noise.aedat4", 6},
                                                              StillRecording{"dvxplorer_person_static.aedat4", 24},
                                                              StillRecording{"dvxplorer_libcaer_ros2.db3", 80},
                                                              StillRecording{"evt3_trigger_ros2.db3", 51}),
                                            ::testing::Bool()),
                         [](const ::testing::TestParamInfo<std::tuple<StillRecording, bool>>& p) {
                           const std::string file = std::get<0>(p.param).file;
                           return file.substr(0, file.find('.')) + (std::get<1>(p.param) ? "_WithoutEvidenceSource" : "");
                         });

}  // namespace
}  // namespace fdv
