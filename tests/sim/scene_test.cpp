// Scene rendering: radiometry against hand-computed values, the band limit (texture detail
// vanishes when a pixel's footprint exceeds it), the vector renderer equal to the scalar one, and
// adaptive sampling converging (finer sampling, same events).
#include "fdv/sim/scene.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fdv/sim/random.h"
#include "fdv/sim/simulator.h"

namespace fdv::sim {
namespace {

SceneConfig room_with_panels() {
  SceneConfig s;
  s.light_direction_W = {0, 0, 1};
  s.ambient_fraction = 0.6;
  s.illuminance_lux = 500;
  s.floor_albedo = 0.25;
  PanelConfig p;
  p.axis = "x", p.position_m = 6, p.min_m = {-1, 0.5}, p.max_m = {1, 2.5}, p.albedo = 0.5;
  s.panels.push_back(p);
  p.axis = "y", p.position_m = 3, p.min_m = {2, 0}, p.max_m = {8, 3}, p.albedo = 0.2;
  s.panels.push_back(p);
  return s;
}

TEST(Scene, MeanRadianceIsIlluminanceTimesShadingTimesAlbedo) {
  const Scene scene(room_with_panels(), {}, 1);
  const float o[3] = {0, 0, 1.5f};
  const float d[3] = {0.3f, 0.1f, -1.0f};  // down to the floor
  float inv[3];
  Scene::safe_inverse(d, inv);
  const RayHit hit = scene.cast_static(o, d, inv, scene.all_panels());
  EXPECT_EQ(hit.surface, 4);  // z axis, min side
  EXPECT_NEAR(hit.t, 1.5, 1e-6);
  // A footprint far larger than every texture octave: only the mean remains. Floor facing the
  // light straight on: shade = 0.6 + 0.4 * 1 = 1 -> 500 lux * 1 * 0.25.
  EXPECT_NEAR(scene.static_radiance(hit, o, d, 1e6f), 125.0, 125.0 * 1e-5);
  // A wall (normal horizontal): shade = ambient only, 0.6 * 500 * 0.4 (default wall albedo).
  const float dw[3] = {0.0f, -1.0f, 0.05f};
  Scene::safe_inverse(dw, inv);
  const RayHit wall = scene.cast_static(o, dw, inv, scene.all_panels());
  EXPECT_EQ(wall.surface, 2);  // y axis, min side
  EXPECT_NEAR(scene.static_radiance(wall, o, dw, 1e6f), 120.0, 120.0 * 1e-5);
  // With a footprint of 1 mm the texture shows: the value differs from the mean.
  EXPECT_GT(std::abs(scene.static_radiance(hit, o, d, 1e-3f) - 125.0f), 1e-2f);
}

TEST(Scene, PanelsOccludeTheRoom) {
  const Scene scene(room_with_panels(), {}, 1);
  const float o[3] = {0, 0, 1.5f};
  const float d[3] = {1.0f, 0.0f, 0.0f};
  float inv[3];
  Scene::safe_inverse(d, inv);
  const RayHit hit = scene.cast_static(o, d, inv, scene.all_panels());
  EXPECT_EQ(hit.surface, kRoomSurfaces + 0);
  EXPECT_NEAR(hit.t, 6.0, 1e-6);
  EXPECT_EQ(scene.cast_static(o, d, inv, 0).surface, 1);  // without panels: the far wall (x max)
}

TEST(Scene, VectorRendererEqualsScalar) {
  const Scene scene(room_with_panels(), {}, 3);
  Rng rng(11);
  const float o[3] = {0.3f, -0.2f, 1.4f};
  for (int trial = 0; trial < 500; ++trial) {
    // kLanes rays in a cone (sometimes narrow: same surface; sometimes wide: mixed).
    const float spread = trial % 2 ? 0.01f : 0.6f;
    const float cx = static_cast<float>(rng.uniform(-1, 1)),
                cy = static_cast<float>(rng.uniform(-1, 1));
    lanes::vf d[3], inv[3], fp;
    for (int k = 0; k < lanes::kLanes; ++k) {
      d[0][k] = 1.0f;
      d[1][k] = cx + spread * static_cast<float>(rng.uniform(-1, 1));
      d[2][k] = cy + spread * static_cast<float>(rng.uniform(-1, 1));
      fp[k] = static_cast<float>(rng.uniform(1e-4, 3e-3));
    }
    for (int a = 0; a < 3; ++a) inv[a] = 1.0f / d[a];
    lanes::vf t;
    lanes::vi surf;
    scene.cast_static_v(o, d, inv, scene.all_panels(), t, surf);
    const lanes::vf radiance = scene.static_radiance_v(surf[0], t, o, d, fp);
    for (int k = 0; k < lanes::kLanes; ++k) {
      const float dk[3] = {d[0][k], d[1][k], d[2][k]}, ik[3] = {inv[0][k], inv[1][k], inv[2][k]};
      const RayHit hit = scene.cast_static(o, dk, ik, scene.all_panels());
      ASSERT_EQ(hit.surface, surf[k]);
      ASSERT_EQ(hit.t, t[k]);
      if (surf[k] == surf[0]) {
        ASSERT_EQ(scene.static_radiance(hit, o, dk, fp[k]), radiance[k]);
      }
    }
  }
}

TEST(SimSampling, FinerSamplingGivesTheSameEvents) {
  // The adaptive step keeps image motion below max_motion_px between samples; halving it twice
  // must not change the events much (the rendered signal is band-limited, so linear
  // interpolation between samples is already close).
  auto count = [](double max_motion) {
    ScenarioConfig c = make_preset("scene1_no_object", 1);
    c.duration_s = 0.15;
    c.depth_camera.enabled = false;
    c.event_camera.background_rate_hz = 0;
    c.event_camera.hot_pixel_fraction = 0;
    c.event_camera.max_motion_px = max_motion;
    set_event_resolution(c, 128, 96);
    Simulator sim(c);
    MemorySink sink;
    const auto summary = sim.run(sink);
    return std::make_pair(static_cast<double>(summary.events), summary.mean_sample_rate_hz);
  };
  const auto coarse = count(0.5), fine = count(0.125);
  // (Not 4x: slow tiles sit at the floor of one sample per chunk either way.)
  EXPECT_GT(fine.second, 2.5 * coarse.second) << "finer sampling must take more samples";
  EXPECT_GT(coarse.first, 5000);
  EXPECT_NEAR(coarse.first / fine.first, 1.0, 0.03);
}

}  // namespace
}  // namespace fdv::sim
