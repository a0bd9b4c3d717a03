// Static camera, static scene: the only events are noise, at the configured rates.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "fdv/sim/simulator.h"
#include "sim_test_util.h"

namespace fdv::sim {
namespace {

TEST(SimNoise, NoNoiseNoEvents) {
  // Nothing moves and noise is off: the rendered image never changes, so no pixel may fire.
  Simulator sim(test::still_scene(64, 48, 0.3));
  MemorySink sink;
  const auto summary = sim.run(sink);
  EXPECT_EQ(sink.events.size(), 0u);
  EXPECT_EQ(summary.events, 0u);
}

TEST(SimNoise, BackgroundActivityAtTheConfiguredRate) {
  ScenarioConfig c = test::still_scene(64, 48, 0.5);
  c.event_camera.background_rate_hz = 20.0;
  c.event_camera.background_rate_spread_decades = 0.0;
  c.event_camera.background_on_fraction = 0.7;
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  // Poisson: expected N = rate * pixels * duration, σ = sqrt(N). Tolerance 5σ.
  const double expected = 20.0 * 64 * 48 * 0.5;
  const double n = static_cast<double>(sink.events.size());
  EXPECT_NEAR(n, expected, 5 * std::sqrt(expected));
  std::size_t on = 0;
  for (std::size_t i = 0; i < sink.events.size(); ++i) {
    EXPECT_EQ(sink.labels[i], kLabelNoise);
    on += sink.events[i].polarity;
    if (i > 0) {
      EXPECT_LE(sink.events[i - 1].t, sink.events[i].t);
    }
  }
  // Binomial ON fraction, tolerance 5σ.
  EXPECT_NEAR(static_cast<double>(on) / n, 0.7, 5 * std::sqrt(0.7 * 0.3 / n));
  // Timestamps on the sensor's microsecond grid, inside the scene.
  for (const auto& e : sink.events) {
    EXPECT_EQ(e.t % 1000, 0);
    EXPECT_GE(e.t, 0);
    EXPECT_LE(e.t, 500'000'000);
  }
}

TEST(SimNoise, HotPixelsFireAtTheirRate) {
  ScenarioConfig c = test::still_scene(64, 48, 0.5);
  c.event_camera.hot_pixel_fraction = 0.01;
  c.event_camera.hot_pixel_rate_median_hz = 200.0;
  c.event_camera.hot_pixel_rate_spread_decades = 0.0;
  Simulator sim(c);
  MemorySink sink;
  sim.run(sink);
  std::map<int, int> per_pixel;
  for (std::size_t i = 0; i < sink.events.size(); ++i) {
    ASSERT_EQ(sink.labels[i], kLabelHotPixel);
    ++per_pixel[sink.events[i].y * 64 + sink.events[i].x];
  }
  // About 1 % of 3072 pixels (binomial: 30.7 ± 5.5); each fires ~100 times in 0.5 s.
  EXPECT_GE(per_pixel.size(), 10u);
  EXPECT_LE(per_pixel.size(), 60u);
  double total = 0;
  for (const auto& [p, k] : per_pixel) total += k;
  const double expected = 200.0 * 0.5 * static_cast<double>(per_pixel.size());
  EXPECT_NEAR(total, expected, 5 * std::sqrt(expected));
}

}  // namespace
}  // namespace fdv::sim
