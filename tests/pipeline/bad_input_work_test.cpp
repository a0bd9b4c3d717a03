// Bad input keeps a window's work bounded (docs/FORMATS.md "Bad input"): each test pushes such
// windows through Perception and checks what the stages processed against the bound, by count.
// The time of the same windows is bench/pipeline_bench's "bad input" cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "fdv/pipeline/perception.h"

namespace fdv {
namespace {

constexpr int kW = 346, kH = 260;
constexpr TimeNs kWindow = 25 * kNsPerMs;

Calibration still_camera() {
  Calibration c;
  c.event_camera = {kW, kH, 260.0, 260.0, 172.5, 129.5, {0, 0, 0, 0, 0}};
  return c;
}

std::vector<WindowResult> run(std::vector<Event> events, PerceptionOptions options, PerceptionCounters* counters) {
  std::sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  options.compensation.method = CompensationMethod::kNone;
  options.estimate_trajectories = false;
  std::vector<WindowResult> windows;
  PerceptionCallbacks cb;
  cb.on_window = [&windows](const WindowResult& w) {
    windows.push_back(w);
    windows.back().detector = nullptr;
  };
  Perception p(still_camera(), options, cb);
  p.push_events(events);
  p.finish();
  *counters = p.counters();
  return windows;
}

/// `n` events at random pixels and times in window `index`.
void random_events(std::vector<Event>& ev, int index, int n, std::mt19937& rng) {
  std::uniform_int_distribution<int> ux(0, kW - 1), uy(0, kH - 1);
  std::uniform_int_distribution<TimeNs> when(index * kWindow, (index + 1) * kWindow - 1);
  for (int i = 0; i < n; ++i)
    ev.push_back({when(rng), static_cast<std::uint16_t>(ux(rng)), static_cast<std::uint16_t>(uy(rng)), i % 2 == 0});
}

// The overload policy: a window of ten times the usual events is decimated to the cap before any
// stage sees it; every event is still counted, in a window or as decimated.
TEST(BadInputWork, TenTimesTheUsualEventsAreDecimatedToTheCap) {
  constexpr int kUsual = 20'000;
  PerceptionOptions o;
  o.windows.max_events_per_window = kUsual;
  std::mt19937 rng(3);
  std::vector<Event> ev{{0, 0, 0, true}};  // the windows start at the first event: at 0
  for (int i = 0; i < 4; ++i) random_events(ev, i, kUsual / 4, rng);
  random_events(ev, 4, 10 * kUsual, rng);
  random_events(ev, 5, kUsual / 4, rng);
  PerceptionCounters counters;
  const auto windows = run(ev, o, &counters);
  ASSERT_EQ(windows.size(), 6u);
  for (const WindowResult& w : windows) {
    EXPECT_LE(w.events, static_cast<std::size_t>(kUsual)) << w.index;
    EXPECT_EQ(w.compensation.events_in, w.events) << w.index;
  }
  // Every 10th of the 200,000 kept: k = ceil(200,000 / 20,000) = 10.
  EXPECT_EQ(windows[4].events, static_cast<std::size_t>(kUsual));
  EXPECT_EQ(windows[4].decimated, 9u * kUsual);
  EXPECT_EQ(counters.events, ev.size());
  EXPECT_EQ(counters.events, counters.events_in_windows + counters.events_dropped.overload);
}

// A window of hot pixels only: once they are learned, their events leave the window before
// compensation, so no later stage processes any event.
TEST(BadInputWork, AWindowOfHotPixelsOnlyReachesNoStageOnceTheyAreLearned) {
  PerceptionOptions o;
  o.detection.hot_pixels.enabled = true;
  std::mt19937 rng(8);
  std::vector<Event> ev;
  constexpr int kWindows = 30;
  int pixels = 0;
  // 300 isolated pixels (8 px apart: no spatial support) firing at 1 kHz with random phases.
  for (int y = 4; y < kH && pixels < 300; y += 8)
    for (int x = 4; x < kW && pixels < 300; x += 8, ++pixels) {
      const TimeNs period = kNsPerMs;
      for (TimeNs t = std::uniform_int_distribution<TimeNs>(0, period - 1)(rng); t < kWindows * kWindow; t += period)
        ev.push_back({t, static_cast<std::uint16_t>(x), static_cast<std::uint16_t>(y), true});
    }
  PerceptionCounters counters;
  const auto windows = run(ev, o, &counters);
  ASSERT_EQ(windows.size(), static_cast<std::size_t>(kWindows));
  for (const WindowResult& w : windows) {
    EXPECT_TRUE(w.detections.empty()) << w.index;
    if (w.index < 10) continue;  // learning (docs/DETECTION.md "Hot pixels": 8 windows)
    EXPECT_EQ(w.events, 300u * 25u) << w.index;
    EXPECT_EQ(w.hot_pixel_events, w.events) << w.index;
    EXPECT_EQ(w.compensation.events_in, 0u) << w.index;
    EXPECT_EQ(w.status, DetectionStatus::kTooFewEvents) << w.index;
  }
}

}  // namespace
}  // namespace fdv
