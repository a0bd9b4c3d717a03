// The ground-truth box (fdv::ground_truth_box, computed independently from the ball's truth and
// the calibration) contains at least 95 % of the events labelled as the ball in every window.
#include <gtest/gtest.h>

#include "fdv/eval/ground_truth_box.h"
#include "fdv/sim/simulator.h"

namespace fdv::sim {
namespace {

void check_labels_in_boxes(const std::string& preset, std::uint64_t seed, double from_s,
                           double to_s) {
  ScenarioConfig c = make_preset(preset, seed);
  c.duration_s = to_s;
  c.depth_camera.enabled = false;
  set_event_resolution(c, 160, 120);
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  const double radius = c.balls.at(0).radius_m;
  const TimeNs window = 25 * kNsPerMs;
  int windows = 0;
  std::size_t i = 0;
  for (TimeNs t0 = from_seconds(from_s); t0 + window <= from_seconds(to_s); t0 += window) {
    const TimeNs t1 = t0 + window;
    const GroundTruthBox box =
        ground_truth_box(sink.objects, 1, radius, sink.body, sim.calibration(), t0, t1);
    std::size_t ball = 0, inside = 0;
    for (; i < sink.events.size() && sink.events[i].t < t1; ++i) {
      if (sink.events[i].t < t0 || sink.labels[i] != 1) continue;
      ++ball;
      inside += box.contains(sink.events[i].x, sink.events[i].y);
    }
    if (ball < 20) continue;
    ++windows;
    EXPECT_TRUE(box.visible) << preset << " window at " << to_seconds(t0) << " s";
    EXPECT_GE(static_cast<double>(inside) / static_cast<double>(ball), 0.95)
        << preset << " window at " << to_seconds(t0) << " s: " << inside << " of " << ball
        << " ball events in the box [" << box.u_min << ", " << box.u_max << "] x [" << box.v_min
        << ", " << box.v_max << "]";
  }
  EXPECT_GE(windows, 4) << preset << ": the ball must be seen in several windows";
}

TEST(SimLabels, BallEventsLieInTheGroundTruthBoxAcrossTheView) {
  check_labels_in_boxes("fast_forward", 1, 0.25, 0.8);
}

TEST(SimLabels, BallEventsLieInTheGroundTruthBoxHeadOn) {
  ScenarioConfig c = make_preset("hover_headon", 2);
  check_labels_in_boxes("hover_headon", 2, 0.2, c.duration_s);
}

TEST(SimLabels, NoBallNoBallLabels) {
  ScenarioConfig c = make_preset("scene1_no_object", 1);
  c.duration_s = 0.1;
  c.depth_camera.enabled = false;
  set_event_resolution(c, 96, 72);
  Simulator sim(c);
  MemorySink sink;
  const auto summary = sim.run(sink);
  EXPECT_GT(summary.events_scene, 1000u) << "fast flight through a textured hall makes events";
  EXPECT_EQ(summary.events_object, 0u);
  for (auto l : sink.labels) ASSERT_LE(l, 0);
}

}  // namespace
}  // namespace fdv::sim
