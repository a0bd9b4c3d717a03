// The any-size detection's presets, checked on their exact truth (no events rendered): close_pass
// grows past a third of the frame and leaves through a border; two_balls' image paths cross.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "fdv/eval/dataset_truth.h"
#include "fdv/eval/ground_truth_box.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/simulator.h"
#include "test_support.h"

namespace fdv::sim {
namespace {

/// The truth the simulator writes (truth/body.csv, truth/objects.csv), without rendering.
struct Truth {
  std::vector<OdometrySample> body;
  std::vector<ObjectState> objects;
};

Truth truth_of(const Simulator& sim) {
  Truth truth;
  const auto& c = sim.config();
  const auto n = static_cast<std::int64_t>(std::floor(c.duration_s * c.truth.rate_hz + 1e-9));
  for (std::int64_t k = 0; k <= n; ++k) {
    const TimeNs t = std::llround(static_cast<double>(k) * 1e9 / c.truth.rate_hz);
    truth.body.push_back(to_pose_sample(t, sim.vehicle().at(to_seconds(t))));
    for (const auto& b : sim.balls()) {
      const BallState bs = b.at(to_seconds(t));
      if (bs.exists) truth.objects.push_back({t, b.config().id, bs.p_W, bs.v_W});
    }
  }
  return truth;
}

/// The ball's silhouette at each truth instant (every `step`-th).
struct Sighting {
  TimeNs t = 0;
  GroundTruthBox box;
};

std::vector<Sighting> sightings(const Simulator& sim, const Truth& truth, int id, int step = 2) {
  double radius = 0;
  for (const auto& b : sim.config().balls)
    if (b.id == id) radius = b.radius_m;
  GroundTruthBoxOptions options;  // coarser than the evaluation's: sizes to ~0.1 px suffice
  options.view_samples = 128;
  options.max_error_px = 0.1;
  std::vector<Sighting> out;
  for (std::size_t i = 0; i < truth.body.size(); i += step) {
    const TimeNs t = truth.body[i].t;
    out.push_back({t, ground_truth_box(truth.objects, id, radius, truth.body, sim.calibration(),
                                       t, t, options)});
  }
  return out;
}

/// The image border a box touching it lies against: the one nearest the box's centre.
std::string border_of(const GroundTruthBox& box, int width, int height) {
  const double u = 0.5 * (box.u_min + box.u_max), v = 0.5 * (box.v_min + box.v_max);
  const double d[4] = {u + 0.5, width - 0.5 - u, v + 0.5, height - 0.5 - v};
  const char* names[4] = {"left", "right", "top", "bottom"};
  int best = 0;
  for (int k = 1; k < 4; ++k)
    if (d[k] < d[best]) best = k;
  return names[best];
}

/// Whether the (clipped) box lies against the image border.
bool at_border(const GroundTruthBox& box, int width, int height) {
  const double eps = 1e-6;
  return box.u_min <= -0.5 + eps || box.v_min <= -0.5 + eps || box.u_max >= width - 0.5 - eps ||
         box.v_max >= height - 0.5 - eps;
}

struct Pass {
  double release_px = 0;  ///< apparent size when first seen (the thrower holds the ball)
  double max_px = 0;      ///< largest apparent size while any part is in view
  double max_px_30 = 0;   ///< largest while at least 30 % is in view (eligible at any size)
  std::string border;     ///< where it leaves the view
  bool leaves = false;    ///< seen, then out of view until the end, last seen at a border
};

Pass close_pass(const ScenarioConfig& c) {
  Simulator sim(c);
  const auto seen = sightings(sim, truth_of(sim), 1);
  Pass pass;
  std::size_t last = seen.size();
  for (std::size_t i = 0; i < seen.size(); ++i) {
    const GroundTruthBox& box = seen[i].box;
    if (!box.visible) continue;
    if (last == seen.size()) pass.release_px = box.span_px_max;
    last = i;
    pass.max_px = std::max(pass.max_px, box.span_px_max);
    if (box.fraction_in_view_min >= 0.3) pass.max_px_30 = std::max(pass.max_px_30, box.span_px_max);
  }
  const int w = c.event_camera.width, h = c.event_camera.height;
  if (last + 1 < seen.size()) {
    pass.border = border_of(seen[last].box, w, h);
    pass.leaves = at_border(seen[last].box, w, h) && seen[last].box.fraction_in_view_max < 0.2;
  }
  return pass;
}

TEST(Presets, ClosePassGrowsPastAThirdOfTheFrameAndLeavesThroughABorder) {
  std::set<std::string> borders;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const ScenarioConfig c = make_preset("close_pass", seed);
    const Pass pass = close_pass(c);
    const int shorter = std::min(c.event_camera.width, c.event_camera.height);
    EXPECT_LT(pass.release_px, 18.0) << "seed " << seed << ": small when thrown";
    EXPECT_GT(pass.max_px, shorter / 3.0) << "seed " << seed;
    EXPECT_GT(pass.max_px_30, shorter / 5.0) << "seed " << seed << ": large while mostly in view";
    EXPECT_TRUE(pass.leaves) << "seed " << seed << ": leaves through a border, for good";
    borders.insert(pass.border);
    std::printf("close_pass seed %d: %.1f px thrown, %.1f px largest (%.1f px with >= 30 %% in view), "
                "leaves through the %s border\n",
                static_cast<int>(seed), pass.release_px, pass.max_px, pass.max_px_30,
                pass.border.c_str());
  }
  EXPECT_GE(borders.size(), 3u) << "the exit border varies with the seed";
}

TEST(Presets, ClosePassGrowsPastAThirdOfTheFrameAtTheDavis346Resolution) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    ScenarioConfig c = make_preset("close_pass", seed);
    set_event_resolution(c, 346, 260);
    const Pass pass = close_pass(c);
    EXPECT_GT(pass.max_px, 260 / 3.0) << "seed " << seed;
    EXPECT_TRUE(pass.leaves) << "seed " << seed;
  }
}

TEST(Presets, TwoBallsImagesCrossWhileBothAreInView) {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const ScenarioConfig c = make_preset("two_balls", seed);
    ASSERT_EQ(c.balls.size(), 2u);
    EXPECT_EQ(c.balls[0].id, 1);
    EXPECT_EQ(c.balls[1].id, 2);
    EXPECT_LE(std::abs(c.balls[1].release_t_s - c.balls[0].release_t_s), 0.005);
    for (const auto& b : c.balls) {
      EXPECT_GE(b.speed_m_s, 5.0);
      EXPECT_LE(b.speed_m_s, 15.0);
    }
    Simulator sim(c);
    const Truth truth = truth_of(sim);
    int ids[3] = {0, 0, 0};
    for (const auto& o : truth.objects) ++ids[o.id == 1 ? 1 : o.id == 2 ? 2 : 0];
    EXPECT_EQ(ids[0], 0);
    EXPECT_EQ(ids[1], static_cast<int>(truth.body.size())) << "truth of ball 1 at every instant";
    EXPECT_EQ(ids[2], static_cast<int>(truth.body.size())) << "truth of ball 2 at every instant";

    const auto one = sightings(sim, truth, 1), two = sightings(sim, truth, 2);
    const double release = c.balls[0].release_t_s;
    const double catch_t = release + (c.balls[0].to_m - c.balls[0].from_m).norm() / c.balls[0].speed_m_s;
    int flight = 0, both_in_view = 0, crossings = 0;
    double crossed_at = -1, previous = 0;
    for (std::size_t i = 0; i < one.size(); ++i) {
      const double t = to_seconds(one[i].t);
      if (t < release || t > catch_t) continue;
      const GroundTruthBox &a = one[i].box, &b = two[i].box;
      ++flight;
      const bool in_view = a.fraction_in_view_min >= 1 && b.fraction_in_view_min >= 1;
      both_in_view += in_view;
      // Which ball is further left in the image; it changes exactly where the paths cross.
      const double du = (a.u_min + a.u_max) - (b.u_min + b.u_max);
      if (previous != 0 && du * previous < 0) {
        ++crossings;
        crossed_at = t;
        EXPECT_TRUE(in_view) << "seed " << seed << ": both in view where they cross";
        const double dv = 0.5 * std::abs((a.v_min + a.v_max) - (b.v_min + b.v_max));
        EXPECT_LT(dv, 0.5 * (a.height() + b.height()) + 10.0)
            << "seed " << seed << ": the images meet where they cross";
      }
      previous = du;
    }
    EXPECT_EQ(crossings, 1) << "seed " << seed;
    EXPECT_GE(both_in_view, 0.7 * flight) << "seed " << seed << ": both well in view";
    std::printf("two_balls seed %d: images cross at %.3f s (flight %.3f-%.3f s)\n",
                static_cast<int>(seed), crossed_at, release, catch_t);
  }
}

TEST(Presets, TwoBallsDatasetHasTruthPerBall) {
  // What `fdv eval` reads back: both ids with their radii and samples.
  ScenarioConfig c = make_preset("two_balls", 1);
  c.duration_s = 0.3;
  c.depth_camera.enabled = false;
  set_event_resolution(c, 64, 48);
  const std::string dir = fdv::test::scratch_dir("sim_two_balls");
  Simulator sim(c);
  DatasetSink sink(dir, sim.calibration());
  sim.run(sink);
  sink.finish(sim.manifest_yaml());
  const DatasetTruth truth = load_dataset_truth(dir);
  ASSERT_EQ(truth.radius_m.size(), 2u);
  EXPECT_EQ(truth.radius_m.at(1), c.balls[0].radius_m);
  EXPECT_EQ(truth.radius_m.at(2), c.balls[1].radius_m);
  for (int id : {1, 2}) {
    const auto state = truth.object_at(id, from_seconds(0.25));
    ASSERT_TRUE(state.has_value()) << "ball " << id;
    EXPECT_TRUE(truth.in_flight(id, from_seconds(0.25))) << "ball " << id;
    EXPECT_NEAR((state->p_W - sim.balls()[id - 1].at(0.25).p_W).norm(), 0.0, 1e-6);
  }
}

}  // namespace
}  // namespace fdv::sim
