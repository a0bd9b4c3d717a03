// The contrast-maximisation baseline: analytic gradient vs finite differences, and recovery of a
// known image motion from events of a moving texture.
#include <gtest/gtest.h>

#include <random>

#include "fdv/compensation/compensator.h"
#include "fdv/compensation/contrast_max.h"
#include "synthetic_motion.h"

namespace fdv {
namespace {

TEST(ContrastMax, AnalyticGradientMatchesFiniteDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(20, 220), v(20, 160), t(0, 0.025f);
  std::vector<float> us, vs, ts;
  // Clustered events (a texture of 80 blobs) so that the objective has real structure.
  for (int b = 0; b < 80; ++b) {
    const float bu = u(rng), bv = v(rng);
    std::normal_distribution<float> spread(0, 1.5f);
    for (int k = 0; k < 60; ++k) {
      us.push_back(bu + spread(rng));
      vs.push_back(bv + spread(rng));
      ts.push_back(t(rng));
    }
  }
  WarpContrastObjective f(240, 180, 120.0, 90.0, 1.0);
  f.set_events(us, vs, ts);
  const std::array<double, 4> h{120.0, -60.0, 1.5, 0.8};
  std::array<double, 4> g{};
  f.evaluate(h, &g);
  // Steps: ~0.01 px of displacement over the window for each parameter.
  const double step[4] = {0.4, 0.4, 0.4 / 100.0, 0.4 / 100.0};
  for (int i = 0; i < 4; ++i) {
    std::array<double, 4> hp = h, hm = h;
    hp[static_cast<std::size_t>(i)] += step[i];
    hm[static_cast<std::size_t>(i)] -= step[i];
    const double fd = (f.evaluate(hp, nullptr) - f.evaluate(hm, nullptr)) / (2 * step[i]);
    // Bilinear voting makes F piecewise smooth (kinks where an event crosses a pixel edge), so
    // finite differences agree to about a percent, not to machine precision.
    EXPECT_NEAR(g[static_cast<std::size_t>(i)], fd, 0.02 * std::abs(fd) + 1e-12) << "parameter " << i;
  }
}

// A random texture translating across the image at a constant flow (px/s), as events in a
// camera without distortion (raw = undistorted grid).
std::vector<Event> moving_texture(const Eigen::Vector2d& flow, int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(30, width - 30), v(30, height - 30);
  std::vector<Eigen::Vector2d> pts(250);
  for (auto& p : pts) p = {u(rng), v(rng)};
  std::vector<Event> ev;
  for (TimeNs t = 0; t < 25 * kNsPerMs; t += 100 * kNsPerUs)
    for (const auto& p : pts) {
      const Eigen::Vector2d q = p + flow * to_seconds(t);
      ev.push_back({t, static_cast<std::uint16_t>(std::lround(q.x())), static_cast<std::uint16_t>(std::lround(q.y())), true});
    }
  return ev;
}

TEST(ContrastMax, RecoversAConstantImageShift) {
  Calibration c;
  c.event_camera = {240, 180, 200.0, 200.0, 120.0, 90.0, {}};
  const Eigen::Vector2d flow(300.0, -200.0);  // 7.5 px and −5 px over 25 ms
  const auto ev = moving_texture(flow, 240, 180, 11);
  CompensationOptions opt;
  opt.method = CompensationMethod::kContrastMax;
  opt.contrast_max.warm_start = false;
  auto comp = make_compensator(c, opt);
  const CompensatedWindow& out = comp->compensate({.events = ev, .t_start = 0, .t_end = 25 * kNsPerMs});
  EXPECT_EQ(out.report.used, CompensationMethod::kContrastMax);
  const auto& h = out.report.warp_params;
  // The sharpest image is the one that undoes the flow; within 5 % (the events are rounded to
  // pixels, which limits the precision of the optimum).
  EXPECT_NEAR(h[0], flow.x(), 15.0) << out.report.brief();
  EXPECT_NEAR(h[1], flow.y(), 10.0);
  EXPECT_NEAR(h[2], 0.0, 0.5);  // expansion [1/s]: ≤ 1 % over the window
  EXPECT_NEAR(h[3], 0.0, 0.5);  // rotation [rad/s]
  EXPECT_GT(out.report.solver_iterations, 0);
  // The compensated events pile up: fewer distinct pixels than without compensation.
  auto distinct = [](std::span<const std::int32_t> px) {
    std::vector<std::int32_t> v(px.begin(), px.end());
    std::sort(v.begin(), v.end());
    return std::unique(v.begin(), v.end()) - v.begin();
  };
  opt.method = CompensationMethod::kNone;
  auto none = make_compensator(c, opt);
  const auto n_none = distinct(none->compensate({.events = ev, .t_start = 0, .t_end = 25 * kNsPerMs}).pixel());
  const auto n_cm = distinct(comp->compensate({.events = ev, .t_start = 0, .t_end = 25 * kNsPerMs}).pixel());
  EXPECT_LT(n_cm * 3, n_none);
}

// The inverse of the fitted warp (Compensator::observed_position) takes every compensated event
// back to the pixel where it was seen (this camera has no distortion: raw = undistorted).
TEST(ContrastMax, ObservedPositionUndoesTheFittedWarp) {
  Calibration c;
  c.event_camera = {240, 180, 200.0, 200.0, 120.0, 90.0, {}};
  const auto ev = moving_texture({300.0, -200.0}, 240, 180, 11);
  CompensationOptions opt;
  opt.method = CompensationMethod::kContrastMax;
  auto comp = make_compensator(c, opt);
  const CompensatedWindow& out = comp->compensate({.events = ev, .t_start = 0, .t_end = 25 * kNsPerMs});
  ASSERT_EQ(out.size(), ev.size()) << out.report.brief();
  double worst = 0, moved = 0;
  for (std::size_t k = 0; k < ev.size(); ++k) {
    const Eigen::Vector2d warped(out.x()[k], out.y()[k]), seen(ev[k].x, ev[k].y);
    worst = std::max(worst, (comp->observed_position(warped, out.t_s()[k]) - seen).norm());
    moved = std::max(moved, (warped - seen).norm());
  }
  EXPECT_LT(worst, 1e-3);
  EXPECT_GT(moved, 5.0);
}

}  // namespace
}  // namespace fdv
