// Depth of a plane at a known distance: the noise follows σ(z) = z² s / (f B) and holes come at
// the configured rate; outside the range everything is invalid.
#include <gtest/gtest.h>

#include <cmath>

#include "fdv/sim/simulator.h"
#include "sim_test_util.h"

namespace fdv::sim {
namespace {

/// A still camera facing a wall (the room's far end) at `wall_x`; the room is wide and tall
/// enough that the depth camera sees nothing else.
ScenarioConfig facing_wall(double wall_x) {
  ScenarioConfig c = test::still_scene(32, 24, 0.2);
  c.vehicle.start_W_m = {0.0, 0.0, 0.0};
  c.scene.room_min_W_m = {-1.0, -40.0, -40.0};
  c.scene.room_max_W_m = {wall_x, 40.0, 40.0};
  auto& d = c.depth_camera;
  d.enabled = true;
  d.width = 160, d.height = 120;
  d.fx = d.fy = 385.7 / 4, d.cx = 79.5, d.cy = 59.5;
  d.rate_hz = 30;
  d.hole_fraction = 0.05;
  return c;
}

TEST(SimDepth, PlaneAtKnownDistanceWithinTheNoiseModel) {
  ScenarioConfig c = facing_wall(3.0);
  c.depth_camera.noise_correlation_px = 1;  // independent: the sample statistics below are sharp
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  ASSERT_EQ(sink.depth.size(), 7u);  // 0, 1/30, ..., 6/30 s
  // The depth camera sits 0.11 m ahead of the body origin, looking along +x (no rotation):
  // every pixel's z-depth is 3.0 - 0.11 m.
  const double z = 3.0 - c.depth_camera.position_B_m.x();
  const double sigma =
      z * z * c.depth_camera.subpixel_px / (c.depth_camera.fx * c.depth_camera.baseline_m);
  double sum = 0, sum2 = 0, n = 0, holes = 0, total = 0;
  for (const auto& f : sink.depth) {
    ASSERT_EQ(f.width, 160);
    ASSERT_EQ(f.height, 120);
    for (float d : f.depth_m) {
      ++total;
      if (d == 0) {
        ++holes;
        continue;
      }
      const double r = (d - z) / sigma;
      sum += r, sum2 += r * r, ++n;
    }
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.02);  // 127k samples: standard error 0.003
  EXPECT_NEAR(sd, 1.0, 0.02);
  // Holes: binomial, rate 5 %, 134400 pixels -> σ = 0.0006. No edges, no range cut here.
  EXPECT_NEAR(holes / total, 0.05, 0.004);
}

TEST(SimDepth, CorrelatedNoiseKeepsItsSigmaAndCorrelatesNeighbours) {
  // Box-correlated over c x c pixels: per-pixel σ unchanged, and pixels du apart along a row
  // correlate (c − du)/c (shared samples of the two boxes), by hand: 0.8 and 0.4 for c = 5.
  ScenarioConfig c = facing_wall(3.0);
  c.depth_camera.noise_correlation_px = 5;
  c.depth_camera.hole_fraction = 0;
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  const double z = 3.0 - c.depth_camera.position_B_m.x();
  const double sigma =
      z * z * c.depth_camera.subpixel_px / (c.depth_camera.fx * c.depth_camera.baseline_m);
  double s2 = 0, n = 0, lag1 = 0, lag3 = 0, n1 = 0, n3 = 0;
  for (const auto& f : sink.depth) {
    // Interior only: the border's reflected samples change the statistics there.
    for (int v = 2; v < f.height - 2; ++v) {
      for (int u = 2; u < f.width - 2; ++u) {
        const float* row = f.depth_m.data() + static_cast<std::size_t>(v) * f.width;
        ASSERT_GT(row[u], 0.0f);
        const double r = (row[u] - z) / sigma;
        s2 += r * r, ++n;
        if (u + 1 < f.width - 2) lag1 += r * (row[u + 1] - z) / sigma, ++n1;
        if (u + 3 < f.width - 2) lag3 += r * (row[u + 3] - z) / sigma, ++n3;
      }
    }
  }
  EXPECT_NEAR(std::sqrt(s2 / n), 1.0, 0.05);  // 7 frames x ~18k pixels, ~700 independent boxes each
  EXPECT_NEAR(lag1 / n1, 0.8, 0.05);
  EXPECT_NEAR(lag3 / n3, 0.4, 0.05);
}

TEST(SimDepth, NoiseCorrelationMustBeOddAndBounded) {
  ScenarioConfig c = facing_wall(3.0);
  for (int bad : {0, 4, 33}) {
    c.depth_camera.noise_correlation_px = bad;
    EXPECT_NE(c.validate().find("depth_camera.noise_correlation_px: must be odd"),
              std::string::npos)
        << bad << ": " << c.validate();
  }
  c.depth_camera.noise_correlation_px = 7;
  EXPECT_EQ(c.validate(), "");
}

TEST(SimDepth, OutOfRangeIsInvalid) {
  const ScenarioConfig c = facing_wall(12.0);  // beyond the 10 m range
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  ASSERT_FALSE(sink.depth.empty());
  for (float d : sink.depth.front().depth_m) ASSERT_EQ(d, 0.0f);
}

TEST(SimDepth, MoreHolesAtDepthEdges) {
  // A panel 1.5 m nearer than the wall covers part of the view: its outline is a depth edge
  // where holes come with probability 0.5 (plus the 5 % everywhere).
  ScenarioConfig c = facing_wall(4.0);
  PanelConfig p;
  p.axis = "x";
  p.position_m = 2.5;
  p.min_m = {-0.5, -0.5};
  p.max_m = {0.5, 0.5};
  c.scene.panels.push_back(p);
  c.depth_camera.edge_hole_probability = 0.5;
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  const auto& f = sink.depth.front();
  double edge = 0, edge_holes = 0, inner = 0, inner_holes = 0;
  // Classify by the clean geometry: a pixel is on an edge if its 4-neighbourhood mixes panel
  // (z ~ 2.39) and wall (z ~ 3.89) pixels; decide from the noisy frame by the nearer surface.
  auto surface = [&](int u, int v) {
    const double x = (u - 79.5) / c.depth_camera.fx, y = (v - 59.5) / c.depth_camera.fy;
    // Ray hits the panel plane at depth 2.5 - 0.11; the panel covers |Y|, |Z| <= 0.5 in W.
    const double zp = 2.5 - 0.11;
    const double wy = -x * zp - 0.015, wz = -y * zp - 0.05;  // camera x right = -W y, y down = -W z
    return std::abs(wy) <= 0.5 && std::abs(wz) <= 0.5;
  };
  for (int v = 1; v + 1 < f.height; ++v)
    for (int u = 1; u + 1 < f.width; ++u) {
      const bool s = surface(u, v);
      const bool is_edge = s != surface(u - 1, v) || s != surface(u + 1, v) ||
                           s != surface(u, v - 1) || s != surface(u, v + 1);
      const bool hole = f.at(u, v) == 0;
      if (is_edge) {
        ++edge, edge_holes += hole;
      } else {
        ++inner, inner_holes += hole;
      }
    }
  ASSERT_GT(edge, 100);
  // Edge pixels: 1 - (1 - 0.5)(1 - 0.05) = 0.525 (a few pixels near the analytic outline may be
  // classified differently, hence the wide band). Inner pixels: 0.05.
  EXPECT_NEAR(edge_holes / edge, 0.525, 0.1);
  EXPECT_NEAR(inner_holes / inner, 0.05, 0.01);
}

}  // namespace
}  // namespace fdv::sim
