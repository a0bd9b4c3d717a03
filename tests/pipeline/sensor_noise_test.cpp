// Sensor noise through the whole pipeline (a still DAVIS346-sized camera, events only): hot pixels
// learned and kept out of every source, flickering lamps, a ball that passes over a hot pixel, and
// bad input whose work per window must stay bounded.
// The scenes are synthetic, so the truth is known exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

struct Outcome {
  std::vector<WindowResult> windows;
  PerceptionCounters counters;
};

/// The hot-pixel filter is off by default (its cost, docs/DETECTION.md "Hot pixels"): these tests
/// switch it on.
PerceptionOptions with_hot_pixel_filter() {
  PerceptionOptions o;
  o.detection.hot_pixels.enabled = true;
  return o;
}

Outcome run(std::vector<Event> events, PerceptionOptions options = with_hot_pixel_filter()) {
  std::sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  options.compensation.method = CompensationMethod::kNone;
  options.estimate_trajectories = false;
  Outcome r;
  PerceptionCallbacks cb;
  cb.on_window = [&r](const WindowResult& w) {
    r.windows.push_back(w);
    r.windows.back().detector = nullptr;
  };
  Perception p(still_camera(), options, cb);
  p.push_events(events);
  p.finish();
  r.counters = p.counters();
  return r;
}

/// A real DAVIS346's background activity: ≈ 0.013 events per pixel and window, at random.
void background_noise(std::vector<Event>& ev, int windows, std::mt19937& rng) {
  std::uniform_int_distribution<int> ux(0, kW - 1), uy(0, kH - 1);
  std::uniform_int_distribution<TimeNs> when(0, windows * kWindow - 1);
  const int n = static_cast<int>(0.013 * kW * kH * windows);
  for (int i = 0; i < n; ++i)
    ev.push_back({when(rng), static_cast<std::uint16_t>(ux(rng)), static_cast<std::uint16_t>(uy(rng)), i % 2 == 0});
}

/// A hot pixel at `rate_hz` from t = 0 for `windows` windows: periodic with a random phase, or at
/// random times (Poisson) as a real one.
void hot_pixel(std::vector<Event>& ev, int x, int y, double rate_hz, int windows, std::mt19937& rng, bool poisson = false) {
  const auto at = [&](TimeNs t) { ev.push_back({t, static_cast<std::uint16_t>(x), static_cast<std::uint16_t>(y), true}); };
  if (poisson) {
    std::exponential_distribution<double> gap_s(rate_hz);
    for (TimeNs t = from_seconds(gap_s(rng)); t < windows * kWindow; t += from_seconds(gap_s(rng))) at(t);
    return;
  }
  const TimeNs period = static_cast<TimeNs>(1e9 / rate_hz);
  for (TimeNs t = std::uniform_int_distribution<TimeNs>(0, period - 1)(rng); t < windows * kWindow; t += period) at(t);
}

/// The detections of the windows from `from` on, one line each ("" when none).
std::string detections_from(const Outcome& r, std::uint64_t from = 0) {
  std::string out;
  for (const WindowResult& w : r.windows)
    for (const TrackedDetection& d : w.detections)
      if (w.index >= from)
        out += "window " + std::to_string(w.index) + ": " + std::string(to_string(d.detection.source)) + " at " +
               std::to_string(d.detection.center_raw.x()) + ", " + std::to_string(d.detection.center_raw.y()) +
               (d.detection.track_aided ? " (track-aided)" : "") + "\n";
  return out;
}

TEST(SensorNoise, AHotPixelAt1kHzGivesNoDetectionAndIsLearnedInEightWindows) {
  std::mt19937 rng(11);
  std::vector<Event> ev;
  background_noise(ev, 40, rng);
  hot_pixel(ev, 120, 90, 1000, 40, rng);
  const Outcome r = run(ev);
  ASSERT_EQ(r.windows.size(), 40u);
  EXPECT_EQ(detections_from(r), "");
  // Learned in window 7 (the 8th: hot_pixels.h, 1 − 0.8⁸ ≥ 0.8): from then on its 25 events per
  // window are dropped, and nothing else (the background's pixels fire in ≈ 1 window of 77).
  for (const WindowResult& w : r.windows) EXPECT_EQ(w.hot_pixel_events, w.index < 7 ? 0u : 25u) << w.index;
  EXPECT_EQ(r.counters.events_dropped.hot_pixel, 33u * 25u);
}

TEST(SensorNoise, AClusterOfHotPixelsIsNoBallOnceLearned) {
  // Nine isolated hot pixels 2 px apart (a 5x5 patch: the sparse search's box at 346x260) firing
  // at random at 0.3-1 kHz: their events' times are unrelated to their positions, so the sparse
  // search's motion test sees a "moving" blob by chance, and once a track starts its gate keeps it.
  std::mt19937 rng(5);
  std::vector<Event> ev;
  background_noise(ev, 80, rng);
  std::uniform_real_distribution<double> rate(300, 1000);
  for (int dy = 0; dy <= 4; dy += 2)
    for (int dx = 0; dx <= 4; dx += 2) hot_pixel(ev, 200 + dx, 150 + dy, rate(rng), 80, rng, true);
  const Outcome r = run(ev);
  ASSERT_EQ(r.windows.size(), 80u);
  EXPECT_EQ(detections_from(r, 7), "");
  for (const WindowResult& w : r.windows) EXPECT_TRUE(w.index < 7 || w.hot_pixel_events > 0) << w.index;
  // Without the filter, the same events are a "ball" in most windows.
  const PerceptionOptions off;  // the default
  const Outcome unfiltered = run(ev, off);
  const auto with_detection = std::count_if(unfiltered.windows.begin(), unfiltered.windows.end(),
                                            [](const WindowResult& w) { return !w.detections.empty(); });
  EXPECT_GT(with_detection, 40) << detections_from(unfiltered);
}

/// A lamp (or a screen) over a region: every pixel fires ON at the start of each period and OFF
/// half a period later (2 events each, 0.5 ms jitter); a screen's phase rolls down the rows.
std::vector<Event> flicker(double hz, bool rolling, int windows, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Event> ev;
  background_noise(ev, windows, rng);
  std::uniform_int_distribution<TimeNs> jitter(0, kNsPerMs / 2);
  const TimeNs period = static_cast<TimeNs>(1e9 / hz);
  for (int y = 60; y < 160; ++y)
    for (int x = 100; x < 220; ++x) {
      const TimeNs phase = rolling ? period * (y - 60) / 100 : 0;
      for (TimeNs t0 = phase - period; t0 < windows * kWindow; t0 += period)  // flickering before t = 0 too
        for (const auto& [offset, on] : {std::pair{TimeNs{0}, true}, std::pair{period / 2, false}})
          for (int k = 0; k < 2; ++k) {
            const TimeNs t = t0 + offset + jitter(rng);
            if (t >= 0 && t < windows * kWindow) ev.push_back({t, static_cast<std::uint16_t>(x), static_cast<std::uint16_t>(y), on});
          }
    }
  return ev;
}

TEST(SensorNoise, AFlickeringLampAt100Or120HzIsNoObject) {
  for (const double hz : {100.0, 120.0})
    for (const bool rolling : {false, true}) {
      SCOPED_TRACE(std::to_string(hz) + " Hz" + (rolling ? ", rolling like a screen" : ", a lamp"));
      const Outcome r = run(flicker(hz, rolling, 20, 7));
      ASSERT_EQ(r.windows.size(), 20u);
      EXPECT_EQ(detections_from(r), "");
      EXPECT_EQ(r.counters.events_dropped.hot_pixel, 0u);  // the region supports each of its pixels
    }
}

TEST(SensorNoise, ABallPassingOverAHotPixelIsFoundInEveryWindow) {
  std::mt19937 rng(2);
  std::vector<Event> ev;
  constexpr int kWindows = 24;
  background_noise(ev, kWindows, rng);
  hot_pixel(ev, 173, 130, 1000, kWindows, rng);
  // From window 12 on, a 12 px disc firing 120 k events/s crosses the image at 400 px/s (10 px per
  // window) through the hot pixel, learned since window 7, which it covers in windows 17-18.
  const Eigen::Vector2d start(113, 130), velocity(400, 0);
  const TimeNs t_ball = 12 * kWindow;
  std::uniform_real_distribution<double> unit(0, 1);
  std::uniform_int_distribution<TimeNs> when(t_ball, kWindows * kWindow - 1);
  for (int i = 0; i < 120'000 * (kWindows - 12) / 40; ++i) {
    const TimeNs t = when(rng);
    const double r = 6 * std::sqrt(unit(rng)), phi = 2 * M_PI * unit(rng);
    const Eigen::Vector2d p = start + velocity * to_seconds(t - t_ball) + r * Eigen::Vector2d(std::cos(phi), std::sin(phi));
    ev.push_back({t, static_cast<std::uint16_t>(std::lround(p.x())), static_cast<std::uint16_t>(std::lround(p.y())), true});
  }
  const Outcome r = run(ev);
  ASSERT_EQ(r.windows.size(), static_cast<std::size_t>(kWindows));
  for (const WindowResult& w : r.windows) {
    SCOPED_TRACE("window " + std::to_string(w.index));
    if (w.index < 12) {
      EXPECT_TRUE(w.detections.empty());
      continue;
    }
    ASSERT_EQ(w.detections.size(), 1u);
    const Eigen::Vector2d truth = start + velocity * to_seconds(w.detections[0].detection.t - t_ball);
    EXPECT_LT((w.detections[0].detection.center_raw - truth).norm(), 3.0);
  }
}

// Bad input keeps a window's work bounded (docs/FORMATS.md "Bad input"); checked by count here,
// timed by bench/frontend_bench's BM_BadInputWindow.

// The overload policy: a window of ten times the usual events is decimated to the cap before any
// stage sees it; every event is still counted, in a window or as decimated.
TEST(BadInputWork, TenTimesTheUsualEventsAreDecimatedToTheCap) {
  constexpr int kUsual = 20'000;
  PerceptionOptions o;
  o.windows.max_events_per_window = kUsual;
  std::mt19937 rng(3);
  // The windows start at the first event: at 0. Windows 0-3 and 5 hold a quarter of the usual
  // count of random events, window 4 ten times the usual.
  std::vector<Event> ev{{0, 0, 0, true}};
  std::uniform_int_distribution<int> ux(0, kW - 1), uy(0, kH - 1);
  for (int window = 0; window < 6; ++window) {
    std::uniform_int_distribution<TimeNs> when(window * kWindow, (window + 1) * kWindow - 1);
    for (int i = 0; i < (window == 4 ? 10 * kUsual : kUsual / 4); ++i)
      ev.push_back({when(rng), static_cast<std::uint16_t>(ux(rng)), static_cast<std::uint16_t>(uy(rng)), i % 2 == 0});
  }
  const Outcome r = run(ev, o);
  ASSERT_EQ(r.windows.size(), 6u);
  for (const WindowResult& w : r.windows) {
    EXPECT_LE(w.events, static_cast<std::size_t>(kUsual)) << w.index;
    EXPECT_EQ(w.compensation.events_in, w.events) << w.index;
  }
  // Every 10th of the 200,000 kept: k = ceil(200,000 / 20,000) = 10.
  EXPECT_EQ(r.windows[4].events, static_cast<std::size_t>(kUsual));
  EXPECT_EQ(r.windows[4].decimated, 9u * kUsual);
  EXPECT_EQ(r.counters.events, ev.size());
  EXPECT_EQ(r.counters.events, r.counters.events_in_windows + r.counters.events_dropped.overload);
}

// A window of hot pixels only: once they are learned, their events leave the window before
// compensation, so no later stage processes any event.
TEST(BadInputWork, AWindowOfHotPixelsOnlyReachesNoStageOnceTheyAreLearned) {
  std::mt19937 rng(8);
  std::vector<Event> ev;
  constexpr int kWindows = 30;
  int pixels = 0;
  // 300 isolated pixels (8 px apart: no spatial support) at 1 kHz, 25 events a window each.
  for (int y = 4; y < kH && pixels < 300; y += 8)
    for (int x = 4; x < kW && pixels < 300; x += 8, ++pixels) hot_pixel(ev, x, y, 1000, kWindows, rng);
  const Outcome r = run(ev);
  ASSERT_EQ(r.windows.size(), static_cast<std::size_t>(kWindows));
  for (const WindowResult& w : r.windows) {
    EXPECT_TRUE(w.detections.empty()) << w.index;
    if (w.index < 10) continue;  // learning: 8 windows (the first test above)
    EXPECT_EQ(w.events, 300u * 25u) << w.index;
    EXPECT_EQ(w.hot_pixel_events, w.events) << w.index;
    EXPECT_EQ(w.compensation.events_in, 0u) << w.index;
    EXPECT_EQ(w.status, DetectionStatus::kTooFewEvents) << w.index;
  }
}

}  // namespace
}  // namespace fdv
