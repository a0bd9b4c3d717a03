// Fallbacks and bad input of the compensators: missing or gappy IMU, missing odometry, missing,
// stale or wrong-sized depth, pixels without depth, event bursts. Each must be handled, reported
// in the window's report, and produce the documented result.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "fdv/compensation/compensator.h"
#include "synthetic_motion.h"

namespace fdv {
namespace {

Calibration plain_rig() {
  Calibration c;
  c.event_camera = {320, 240, 250.0, 250.0, 160.0, 120.0, {}};
  return c;
}

RegisteredDepth flat_depth(const Calibration& c, float z, TimeNs t) {
  RegisteredDepth d;
  d.t = t;
  d.width = c.event_camera.width;
  d.height = c.event_camera.height;
  d.depth_m.assign(static_cast<std::size_t>(d.width) * d.height, z);
  return d;
}

/// 2 m on the left 150 columns, 5 m on the other 170 (the 320x240 rig): median 5 m.
RegisteredDepth near_left_depth(const Calibration& c, TimeNs t) {
  RegisteredDepth d = flat_depth(c, 5.0f, t);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 150; ++x) d.depth_m[static_cast<std::size_t>(y) * 320 + x] = 2.0f;
  return d;
}

std::vector<Event> some_events(TimeNs t0, int n) {
  std::vector<Event> ev;
  for (int i = 0; i < n; ++i)
    ev.push_back({t0 + i * (25 * kNsPerMs / n), static_cast<std::uint16_t>(100 + i % 100), static_cast<std::uint16_t>(60 + (i / 100) % 100), true});
  return ev;
}

OdometrySample moving(TimeNs t, const Eigen::Vector3d& v_W) {
  OdometrySample o;
  o.t = t;
  o.v_W = v_W;
  return o;
}

TEST(Fallback, MissingImuFallsBackToNoneAndSaysSo) {
  const Calibration c = plain_rig();
  const TimeNs t0 = kNsPerS, t1 = t0 + 25 * kNsPerMs;
  const auto ev = some_events(t0, 500);
  // Only samples long before the window: further than max_imu_gap_ns (20 ms) from it.
  const auto old_imu = test::constant_imu({0, 1, 0}, t0 - 200 * kNsPerMs, t0 - 100 * kNsPerMs, kNsPerMs);
  for (const char* m : {"rotation", "rotation_translation"}) {
    CompensationOptions opt;
    opt.method = *parse_compensation_method(m);
    auto comp = make_compensator(c, opt);
    for (std::span<const ImuSample> imu : {std::span<const ImuSample>{}, std::span<const ImuSample>(old_imu)}) {
      const RegisteredDepth d = flat_depth(c, 3.0f, t0);
      const CompensatedWindow& out = comp->compensate({ev, t0, t1, imu, moving(t0, {1, 0, 0}), &d});
      EXPECT_TRUE(out.report.imu_missing) << m;
      EXPECT_EQ(out.report.used, CompensationMethod::kNone) << m;
      EXPECT_EQ(out.report.requested, *parse_compensation_method(m));
      EXPECT_FALSE(out.report.has_omega);
      EXPECT_NE(out.report.brief().find("imu missing"), std::string::npos);
      // "none" on a camera without distortion: every event stays on its own pixel.
      ASSERT_EQ(out.size(), ev.size());
      for (std::size_t k = 0; k < ev.size(); ++k) EXPECT_EQ(out.pixel()[k], ev[k].y * 320 + ev[k].x);
    }
  }
}

TEST(Fallback, ImuGapIsFlaggedAndTheMeanStillUsed) {
  const Calibration c = plain_rig();
  const TimeNs t0 = kNsPerS, t1 = t0 + 25 * kNsPerMs;
  // 1 kHz, constant ω, but nothing between t0 + 2 ms and t0 + 40 ms (a 38 ms hole in the window).
  std::vector<ImuSample> imu;
  for (const auto& s : test::constant_imu({0.5, -1.0, 2.0}, t0 - 10 * kNsPerMs, t0 + 60 * kNsPerMs, kNsPerMs))
    if (s.t <= t0 + 2 * kNsPerMs || s.t >= t0 + 40 * kNsPerMs) imu.push_back(s);
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;
  auto comp = make_compensator(c, opt);
  const CompensatedWindow& out = comp->compensate({.events = some_events(t0, 100), .t_start = t0, .t_end = t1, .imu = imu});
  EXPECT_TRUE(out.report.imu_gap);
  EXPECT_FALSE(out.report.imu_missing);
  EXPECT_EQ(out.report.used, CompensationMethod::kRotation);
  EXPECT_EQ(out.report.imu_largest_gap_ns, 38 * kNsPerMs);
  EXPECT_NEAR((out.report.omega_E - Eigen::Vector3d(0.5, -1.0, 2.0)).norm(), 0, 1e-12);
}

TEST(Fallback, RotationTranslationWithoutOdometryOrDepthIsRotation) {
  const Calibration c = plain_rig();
  const TimeNs t0 = kNsPerS, t1 = t0 + 25 * kNsPerMs;
  const auto ev = some_events(t0, 300);
  const auto imu = test::constant_imu({0, 0.5, 0}, t0 - 5 * kNsPerMs, t1 + 5 * kNsPerMs, kNsPerMs);
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  opt.max_depth_age_ns = 100 * kNsPerMs;
  auto comp = make_compensator(c, opt);
  const RegisteredDepth fresh = flat_depth(c, 3.0f, t0);
  const RegisteredDepth stale = flat_depth(c, 3.0f, t0 - 200 * kNsPerMs);
  RegisteredDepth wrong = flat_depth(c, 3.0f, t0);
  wrong.width = 160;  // e.g. registered for another camera
  wrong.height = 120;
  wrong.depth_m.resize(160 * 120);
  RegisteredDepth all_holes = flat_depth(c, 0.0f, t0);

  auto run = [&](std::optional<OdometrySample> odo, const RegisteredDepth* d) {
    return comp->compensate({ev, t0, t1, imu, odo, d}).report;
  };
  const auto odo = moving(t0, {2, 0, 0});
  CompensationReport r = run(std::nullopt, &fresh);
  EXPECT_TRUE(r.odometry_missing);
  EXPECT_EQ(r.used, CompensationMethod::kRotation);
  r = run(odo, nullptr);
  EXPECT_TRUE(r.depth_missing);
  EXPECT_EQ(r.used, CompensationMethod::kRotation);
  r = run(odo, &stale);
  EXPECT_TRUE(r.depth_stale);
  EXPECT_EQ(r.depth_age_ns, 212'500'000);  // window middle t0 + 12.5 ms vs frame at t0 − 200 ms
  EXPECT_EQ(r.used, CompensationMethod::kRotation);
  r = run(odo, &wrong);
  EXPECT_TRUE(r.depth_wrong_size);
  EXPECT_EQ(r.used, CompensationMethod::kRotation);
  r = run(odo, &all_holes);
  EXPECT_TRUE(r.depth_missing);
  EXPECT_EQ(r.used, CompensationMethod::kRotation);
  r = run(odo, &fresh);
  EXPECT_EQ(r.used, CompensationMethod::kRotationTranslation) << r.brief();
  EXPECT_FALSE(r.depth_missing || r.depth_stale || r.depth_wrong_size || r.odometry_missing);
}

TEST(Fallback, PixelsWithoutDepthUseTheMedianAndAreCounted) {
  const Calibration c = plain_rig();
  const TimeNs t0 = 0, t1 = 25 * kNsPerMs;
  RegisteredDepth d = near_left_depth(c, t0);
  // Holes: a 5x5 block (not fillable from neighbours with radius 1 at its centre) and one pinhole.
  for (int y = 100; y < 105; ++y)
    for (int x = 200; x < 205; ++x) d.depth_m[static_cast<std::size_t>(y) * 320 + x] = 0.0f;
  d.depth_m[50 * 320 + 250] = 0.0f;
  // Events: on the block centre (3x3 core stays a hole after a radius-1 fill), the pinhole, and
  // a valid pixel.
  const std::vector<Event> ev{{1'000'000, 202, 102, true}, {2'000'000, 250, 50, true}, {3'000'000, 10, 10, true},
                              {20'000'000, 202, 102, true}};
  const auto imu = test::constant_imu(Eigen::Vector3d::Zero(), -5 * kNsPerMs, 30 * kNsPerMs, kNsPerMs);
  const OdometrySample odo = moving(0, {0, 0, 4.0});  // forward: expansion away from the centre

  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  opt.hole_fill_radius_px = 1;
  opt.missing_depth = MissingDepthPolicy::kMedianDepth;
  auto comp = make_compensator(c, opt);
  const CompensatedWindow& out = comp->compensate({ev, t0, t1, imu, odo, &d});
  ASSERT_EQ(out.size(), 4u) << out.report.brief();
  EXPECT_EQ(out.report.depth_fallback_events, 2u);  // the two block-centre events; the pinhole was filled
  EXPECT_FLOAT_EQ(out.report.fallback_depth_m, 5.0f);
  // Hand-computed expected position of the block-centre event at t = 20 ms with z = 5 m (median):
  // X0 ∝ [x; y; 1] + (1/z)·v·t  ->  u = cx + fx·x / (1 + v_z t / z).
  auto expected_u = [&](double u_raw, double z, double t) {
    const double xn = (u_raw - 160.0) / 250.0;
    return 160.0 + 250.0 * xn / (1.0 + 4.0 * t / z);
  };
  EXPECT_NEAR(out.x()[3], expected_u(202, 5.0, 0.020), 1e-3);
  // The pinhole took its neighbours' 5 m; the valid pixel its own 2 m.
  EXPECT_NEAR(out.x()[1], expected_u(250, 5.0, 0.002), 1e-3);
  EXPECT_NEAR(out.x()[2], expected_u(10, 2.0, 0.003), 1e-3);

  // Policy "rotation only": the holes get ρ = 0 (no translation), still counted.
  opt.missing_depth = MissingDepthPolicy::kRotationOnly;
  auto comp2 = make_compensator(c, opt);
  const CompensatedWindow& out2 = comp2->compensate({ev, t0, t1, imu, odo, &d});
  EXPECT_EQ(out2.report.depth_fallback_events, 2u);
  EXPECT_NEAR(out2.x()[3], 202.0, 1e-3);
  EXPECT_NEAR(out2.x()[2], expected_u(10, 2.0, 0.003), 1e-3);

  // Policy "beyond range": twice the frame's reach (its 99th percentile depth, 5 m), so 10 m.
  opt.missing_depth = MissingDepthPolicy::kBeyondRange;
  auto comp3 = make_compensator(c, opt);
  const CompensatedWindow& out3 = comp3->compensate({ev, t0, t1, imu, odo, &d});
  EXPECT_EQ(out3.report.depth_fallback_events, 2u);
  EXPECT_FLOAT_EQ(out3.report.fallback_depth_m, 10.0f);
  EXPECT_NEAR(out3.x()[3], expected_u(202, 10.0, 0.020), 1e-3);
  EXPECT_NEAR(out3.x()[1], expected_u(250, 5.0, 0.002), 1e-3);
}

// The reach of "beyond range" is the 99th percentile of the frame's depths (every pixel is sampled
// on this rig): the depth at index ⌊0.99 n⌋ of the sorted frame. A shuffled ramp of distinct
// depths, then the same with its top thousand equal (the percentile falls among them).
TEST(Fallback, TheReachIsTheNinetyNinthPercentileOfTheFramesDepths) {
  const Calibration c = plain_rig();
  for (const std::size_t equal_top : {0, 1000}) {
    RegisteredDepth frame = flat_depth(c, 0.0f, 0);
    const std::size_t n = frame.depth_m.size();
    for (std::size_t i = 0; i < n; ++i)
      frame.depth_m[i] = i + equal_top < n ? 1.0f + 1e-4f * static_cast<float>(i) : 9.5f;
    std::shuffle(frame.depth_m.begin(), frame.depth_m.end(), std::mt19937(7));
    std::vector<float> sorted = frame.depth_m;
    std::sort(sorted.begin(), sorted.end());
    CompensationOptions opt;
    opt.method = CompensationMethod::kRotationTranslation;
    opt.missing_depth = MissingDepthPolicy::kBeyondRange;
    const std::vector<Event> ev{{1'000'000, 10, 10, true}};
    const auto imu = test::constant_imu(Eigen::Vector3d::Zero(), -5 * kNsPerMs, 30 * kNsPerMs, kNsPerMs);
    const auto compensator = make_compensator(c, opt);  // owns the window `out` refers to
    const CompensatedWindow& out =
        compensator->compensate({ev, 0, 25 * kNsPerMs, imu, moving(0, {0, 0, 1.0}), &frame});
    EXPECT_EQ(out.report.fallback_depth_m, 2 * sorted[n * 99 / 100]) << out.report.brief();
  }
}

// Preparing the depth frame on its arrival (Perception does, off the window path) gives the same
// window as preparing it inside compensate(), and the window then reports it did not prepare it.
TEST(Fallback, DepthPreparedOnArrivalGivesTheSameWindow) {
  const Calibration c = plain_rig();
  const TimeNs t0 = 0, t1 = 25 * kNsPerMs;
  RegisteredDepth d = near_left_depth(c, t0);
  d.depth_m[50 * 320 + 250] = 0.0f;
  const auto ev = some_events(t0, 2000);
  const auto imu = test::constant_imu({0.2, -0.1, 0.3}, -5 * kNsPerMs, 30 * kNsPerMs, kNsPerMs);
  const OdometrySample odo = moving(0, {0.5, 0, 4.0});
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  auto inside = make_compensator(c, opt), on_arrival = make_compensator(c, opt);
  const CompensatedWindow& a = inside->compensate({ev, t0, t1, imu, odo, &d});
  EXPECT_TRUE(a.report.depth_prepared_here);
  on_arrival->prepare_depth_frame(d);
  const CompensatedWindow& b = on_arrival->compensate({ev, t0, t1, imu, odo, &d});
  EXPECT_FALSE(b.report.depth_prepared_here);
  EXPECT_EQ(b.report.used, CompensationMethod::kRotationTranslation);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 1000u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.x()[i], b.x()[i]) << i;
    ASSERT_EQ(a.y()[i], b.y()[i]) << i;
  }
  // The same frame again: already prepared. A new frame (another time stamp) is prepared again.
  EXPECT_FALSE(inside->compensate({ev, t0, t1, imu, odo, &d}).report.depth_prepared_here);
  RegisteredDepth later = d;
  later.t = t0 + 5 * kNsPerMs;
  EXPECT_TRUE(inside->compensate({ev, t0, t1, imu, odo, &later}).report.depth_prepared_here);
  // Strategies without depth ignore it; a frame of the wrong size is not prepared (compensate
  // reports it and falls back, as before).
  opt.method = CompensationMethod::kRotation;
  make_compensator(c, opt)->prepare_depth_frame(d);
  RegisteredDepth wrong = flat_depth(c, 3.0f, t0);
  wrong.width = 100;
  on_arrival->prepare_depth_frame(wrong);
  const CompensatedWindow& w = on_arrival->compensate({ev, t0, t1, imu, odo, &wrong});
  EXPECT_TRUE(w.report.depth_wrong_size);
  EXPECT_FALSE(w.report.depth_prepared_here);
}

// With overlapping windows a frame arrives while the windows before it still wait for their IMU:
// those use the frame before it, the next ones the new frame. The last two frames prepared are
// kept, so going back and forth between them prepares neither again, and each window is warped as
// with its frame alone; a third frame takes the older one's place.
TEST(Fallback, TheLastTwoDepthFramesStayPrepared) {
  const Calibration c = plain_rig();
  const TimeNs t0 = 0, t1 = 25 * kNsPerMs;
  const RegisteredDepth first = near_left_depth(c, t0);
  const RegisteredDepth second = flat_depth(c, 3.0f, t0 + 10 * kNsPerMs);
  const RegisteredDepth third = flat_depth(c, 4.0f, t0 + 20 * kNsPerMs);
  const auto ev = some_events(t0, 2000);
  const auto imu = test::constant_imu({0.2, -0.1, 0.3}, -5 * kNsPerMs, 30 * kNsPerMs, kNsPerMs);
  const OdometrySample odo = moving(0, {0.5, 0, 4.0});
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  auto warp_alone = [&](const RegisteredDepth& depth) {
    const auto alone = make_compensator(c, opt);
    const CompensatedWindow& w = alone->compensate({ev, t0, t1, imu, odo, &depth});
    return std::vector<float>(w.x().begin(), w.x().end());
  };
  auto comp = make_compensator(c, opt);
  comp->prepare_depth_frame(first);
  comp->prepare_depth_frame(second);
  for (const RegisteredDepth* depth : std::array<const RegisteredDepth*, 4>{&first, &second, &first, &second}) {
    const CompensatedWindow& w = comp->compensate({ev, t0, t1, imu, odo, depth});
    EXPECT_FALSE(w.report.depth_prepared_here) << "the frame at " << depth->t;
    ASSERT_EQ(std::vector<float>(w.x().begin(), w.x().end()), warp_alone(*depth)) << "the frame at " << depth->t;
  }
  comp->prepare_depth_frame(third);
  EXPECT_FALSE(comp->compensate({ev, t0, t1, imu, odo, &second}).report.depth_prepared_here);
  EXPECT_FALSE(comp->compensate({ev, t0, t1, imu, odo, &third}).report.depth_prepared_here);
  EXPECT_TRUE(comp->compensate({ev, t0, t1, imu, odo, &first}).report.depth_prepared_here);
}

TEST(Fallback, BurstIsDecimatedAndCounted) {
  const Calibration c = plain_rig();
  const TimeNs t0 = 0, t1 = 25 * kNsPerMs;
  // 400 k events in 1 ms (400 M ev/s), against a guard of 100 k per window.
  std::vector<Event> ev;
  ev.reserve(400'000);
  for (int i = 0; i < 400'000; ++i)
    ev.push_back({10 * kNsPerMs + i * 2'500 / 1'000, static_cast<std::uint16_t>(i % 320), static_cast<std::uint16_t>((i / 320) % 240), true});
  CompensationOptions opt;
  opt.method = CompensationMethod::kNone;
  opt.max_events_per_window = 100'000;
  auto comp = make_compensator(c, opt);
  const CompensatedWindow& out = comp->compensate({.events = ev, .t_start = t0, .t_end = t1});
  EXPECT_EQ(out.report.dropped_burst, 300'000u);
  EXPECT_EQ(out.size(), 100'000u);
  EXPECT_EQ(out.report.events_in, 400'000u);
  EXPECT_NE(out.report.brief().find("burst decimation 300000"), std::string::npos) << out.report.brief();
  // Every 4th event was kept: uniform in time order.
  EXPECT_EQ(out.pixel()[1], (4 / 320) * 320 + 4 % 320);
}

TEST(Fallback, AWindowOfOneEventPerPixelUsesTheBuffersMadeAtConstruction) {
  // No cold first window: the output buffers hold a busy window (one event per pixel) from the
  // start, so the first such window neither allocates nor faults them in.
  const Calibration c = plain_rig();
  const int n = c.event_camera.width * c.event_camera.height;
  std::vector<Event> ev;
  ev.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    ev.push_back({i * (25 * kNsPerMs / n), static_cast<std::uint16_t>(i % 320), static_cast<std::uint16_t>(i / 320), true});
  for (const CompensationMethod method : {CompensationMethod::kNone, CompensationMethod::kRotation}) {
    CompensationOptions opt;
    opt.method = method;
    auto comp = make_compensator(c, opt);
    const std::vector<ImuSample> imu = {{.t = -kNsPerMs}, {.t = 26 * kNsPerMs}};
    const float* made = comp->compensate({.events = {}, .t_start = 0, .t_end = 25 * kNsPerMs, .imu = imu}).x().data();
    const CompensatedWindow& out = comp->compensate({.events = ev, .t_start = 0, .t_end = 25 * kNsPerMs, .imu = imu});
    ASSERT_EQ(out.size(), static_cast<std::size_t>(n)) << to_string(method);
    EXPECT_EQ(out.x().data(), made) << to_string(method);
  }
}

}  // namespace
}  // namespace fdv
