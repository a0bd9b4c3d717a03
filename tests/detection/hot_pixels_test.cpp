// The hot-pixel model (hot_pixels.h) against its analytic expectations: a steady isolated pixel is
// hot after n windows, the least n with 1 − αⁿ ≥ min_firing; a burst, a flickering region, a
// line of texture and a ball's neighbourhood make no pixel hot.
#include "fdv/detection/hot_pixels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fdv/core/error.h"

namespace fdv {
namespace {

constexpr int kW = 64, kH = 48;
constexpr TimeNs kWindow = 25 * kNsPerMs;

/// `n` events of pixel (x, y) spread evenly over window k (n = 25: 1 kHz).
void fire(std::vector<Event>& ev, int x, int y, std::uint64_t k, int n = 25) {
  for (int i = 0; i < n; ++i)
    ev.push_back({static_cast<TimeNs>(k) * kWindow + i * kWindow / n, static_cast<std::uint16_t>(x),
                  static_cast<std::uint16_t>(y), i % 2 == 0});
}

int events_at(const std::vector<Event>& ev, int x, int y) {
  return static_cast<int>(std::count_if(ev.begin(), ev.end(), [&](const Event& e) { return e.x == x && e.y == y; }));
}

TEST(HotPixelFilter, ASteadyIsolatedPixelIsHotAfterTheWindowsTheModelGivesAndOnlyItsEventsAreDropped) {
  const HotPixelOptions o;  // α = 0.8, min_firing 0.8
  HotPixelFilter filter(o, kW, kH);
  // 1 − 0.8ⁿ ≥ 0.8: n = 8 (1 − 0.8⁷ = 0.790, 1 − 0.8⁸ = 0.832).
  ASSERT_EQ(filter.windows_to_learn(), 8);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> ux(0, kW - 1), uy(0, kH - 1);
  for (std::uint64_t k = 0; k < 20; ++k) {
    std::vector<Event> ev;
    fire(ev, 30, 20, k);
    for (int i = 0; i < 40; ++i) {  // sparse noise elsewhere (≈ 0.013 events per pixel, as a DAVIS346)
      const int x = ux(rng), y = uy(rng);
      if (std::abs(x - 30) > 1 || std::abs(y - 20) > 1) fire(ev, x, y, k, 1);
    }
    const std::size_t n = ev.size();
    const std::size_t dropped = filter.filter(ev, k);
    SCOPED_TRACE("window " + std::to_string(k));
    EXPECT_NEAR(filter.firing(30, 20), 1 - std::pow(0.8, static_cast<double>(k + 1)), 1e-4);  // f is kept in 16 bits
    if (k + 1 < 8) {
      EXPECT_FALSE(filter.is_hot(30, 20));
      EXPECT_EQ(dropped, 0u);
    } else {
      EXPECT_TRUE(filter.is_hot(30, 20));
      EXPECT_EQ(dropped, 25u);  // its own events, nothing else
      EXPECT_EQ(ev.size(), n - 25);
      EXPECT_EQ(events_at(ev, 30, 20), 0);
      EXPECT_EQ(filter.hot_pixels(), 1u);
    }
  }
  // It stops: not hot once its firing fraction has decayed below 0.8 (0.832·0.8 < 0.8, 1 window).
  std::vector<Event> quiet;
  fire(quiet, 5, 5, 20, 1);
  filter.filter(quiet, 20);
  EXPECT_FALSE(filter.is_hot(30, 20));
}

TEST(HotPixelFilter, ABurstOfNoiseMakesNoPixelHot) {
  HotPixelFilter filter(HotPixelOptions{}, kW, kH);
  for (std::uint64_t k = 0; k < 30; ++k) {
    std::vector<Event> ev;
    if (k == 10)  // one window of uniform noise: every pixel fires 3 times
      for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) fire(ev, x, y, k, 3);
    else
      fire(ev, k % kW, 7, k, 1);
    const std::size_t n = ev.size();
    EXPECT_EQ(filter.filter(ev, k), 0u) << "window " << k;
    EXPECT_EQ(ev.size(), n);
    EXPECT_EQ(filter.hot_pixels(), 0u) << "window " << k;
  }
  EXPECT_NEAR(filter.firing(40, 40), 0.2 * std::pow(0.8, 19), 1e-5);  // 1 − α, decaying since window 10
}

TEST(HotPixelFilter, AFlickeringRegionAndALineOfTextureHaveSpatialSupport) {
  HotPixelFilter filter(HotPixelOptions{}, kW, kH);
  for (std::uint64_t k = 0; k < 30; ++k) {
    std::vector<Event> ev;
    for (int y = 10; y < 20; ++y)  // a lamp: a 10x10 region, 100 Hz, both polarities
      for (int x = 10; x < 20; ++x) fire(ev, x, y, k, 5);
    for (int x = 30; x < 60; ++x) fire(ev, x, 35, k, 2);  // a 1 px edge that fires in every window
    filter.filter(ev, k);
  }
  EXPECT_GT(filter.firing(15, 15), 0.99);
  for (int y = 10; y < 20; ++y)
    for (int x = 10; x < 20; ++x) EXPECT_FALSE(filter.is_hot(x, y)) << x << "," << y;  // a corner: 3 of 8
  for (int x = 31; x < 59; ++x) EXPECT_FALSE(filter.is_hot(x, 35)) << x;              // 2 of 8
  // The line's two ends have one steady neighbour, as a pair of hot pixels: they are learned.
  EXPECT_TRUE(filter.is_hot(30, 35));
  EXPECT_TRUE(filter.is_hot(59, 35));
  EXPECT_EQ(filter.hot_pixels(), 2u);
}

TEST(HotPixelFilter, TwoAdjacentHotPixelsAreBothLearned) {
  HotPixelFilter filter(HotPixelOptions{}, kW, kH);
  for (std::uint64_t k = 0; k < 10; ++k) {
    std::vector<Event> ev;
    fire(ev, 40, 30, k);
    fire(ev, 41, 30, k, 3);
    filter.filter(ev, k);
  }
  EXPECT_TRUE(filter.is_hot(40, 30));
  EXPECT_TRUE(filter.is_hot(41, 30));
}

TEST(HotPixelFilter, ABallOverAHotPixelReleasesItInTheWindowItArrives) {
  HotPixelFilter filter(HotPixelOptions{}, kW, kH);
  std::uint64_t k = 0;
  for (; k < 10; ++k) {
    std::vector<Event> ev;
    fire(ev, 30, 20, k);
    filter.filter(ev, k);
  }
  ASSERT_TRUE(filter.is_hot(30, 20));
  // A 7 px ball covers the pixel and its whole neighbourhood for 2 windows: the neighbours' mean
  // firing fraction is 1 − α = 0.2 > 0.15 in the first, so the pixel's events stay in the window.
  for (; k < 12; ++k) {
    std::vector<Event> ev;
    for (int y = 17; y <= 23; ++y)
      for (int x = 27; x <= 33; ++x) fire(ev, x, y, k, 2);
    fire(ev, 30, 20, k);
    const std::size_t n = ev.size();
    EXPECT_EQ(filter.filter(ev, k), 0u);
    EXPECT_EQ(ev.size(), n);
    EXPECT_FALSE(filter.is_hot(30, 20));
  }
}

TEST(HotPixelFilter, ALongGapDecaysTheStateAndEventsOutsideTheSensorAreKept) {
  HotPixelFilter filter(HotPixelOptions{}, kW, kH);
  std::uint64_t k = 100;
  for (; k < 110; ++k) {
    std::vector<Event> ev;
    fire(ev, 30, 20, k);
    filter.filter(ev, k);
  }
  ASSERT_TRUE(filter.is_hot(30, 20));
  std::vector<Event> ev;
  fire(ev, 30, 20, 1000);
  fire(ev, kW + 3, 2, 1000);  // outside: the compensation counts it
  EXPECT_EQ(filter.filter(ev, 1000), 0u);
  EXPECT_EQ(ev.size(), 50u);
  EXPECT_NEAR(filter.firing(30, 20), 0.2, 1e-4);  // everything before is forgotten: one window's worth
}

TEST(HotPixelFilter, InvalidOptionsNameTheirKey) {
  HotPixelOptions o;
  o.memory_windows = 1;
  EXPECT_NE(o.validate().find("hot_pixels_memory_windows"), std::string::npos) << o.validate();
  o = {};
  o.min_firing = 1.5;
  EXPECT_NE(o.validate().find("hot_pixels_min_firing"), std::string::npos) << o.validate();
  o = {};
  o.max_neighbour_firing = std::nan("");
  EXPECT_FALSE(o.validate().empty());
  EXPECT_THROW(HotPixelFilter(o, kW, kH), ConfigError);
  EXPECT_THROW(HotPixelFilter(HotPixelOptions{}, 0, kH), ConfigError);
}

}  // namespace
}  // namespace fdv
