// The optimised warp (WarpCompensator: float tables, 4-lane arithmetic, time-sliced rotation
// slots) against the plain double-precision reference (reference_warp.h), event by event.
//
// Tolerance and why: the optimised code looks the undistorted rays up in a float table and warps
// in float; the reference undistorts each event in double. Positions agree to about 1e-4 px
// (float has 24 bits: 6e-8 relative, ~4e-5 px at 640 px, a few roundings); we require 1e-3 px.
// An event whose exact position lies within that distance of a rounding boundary (a half pixel)
// may round to either neighbour, and one that close to the image border may be kept by one and
// dropped by the other: such "ambiguous" events are counted (a handful per 100 k) and excluded;
// everything else — every drop counter, every kept event, its pixel and its time — must be equal.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "fdv/compensation/compensator.h"
#include "fdv/compensation/reference_warp.h"
#include "synthetic_motion.h"

namespace fdv {
namespace {

constexpr double kTolPx = 1e-3;
constexpr TimeNs kT0 = 1'000 * kNsPerMs, kWindow = 25 * kNsPerMs;

Calibration rig() {
  Calibration c;
  // Strong barrel distortion: the lens map folds back in the corners, so some raw pixels have no
  // undistortion (dropped as "no inverse") and both implementations must agree on which.
  c.event_camera = {640, 480, 400.0, 402.0, 322.5, 238.2, {-0.5, 0.0, 0.0008, -0.0006, 0.0}};
  Eigen::Matrix3d R_B_E;
  R_B_E << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  c.T_B_E.linear() = R_B_E;
  c.T_B_E.translation() = Eigen::Vector3d(0.10, -0.02, 0.05);
  return c;
}

// Random pixels and times over the window, time-sorted, plus the bad cases every drop counter
// covers: before / after the window, outside the sensor, a few out of time order.
std::vector<Event> random_events(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<TimeNs> t(kT0, kT0 + kWindow - 1);
  std::uniform_int_distribution<int> x(0, 639), y(0, 479);
  std::vector<Event> ev;
  for (int i = 0; i < n; ++i)
    ev.push_back({t(rng), static_cast<std::uint16_t>(x(rng)), static_cast<std::uint16_t>(y(rng)), (i & 1) != 0});
  std::sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  ev.insert(ev.begin(), {kT0 - 5, 10, 10, true});                       // before the window
  ev.push_back({kT0 + kWindow, 10, 10, true});                          // at t_end: outside
  ev[ev.size() / 3].x = 700;                                            // outside the sensor
  ev[ev.size() / 2].y = 480;
  std::swap(ev[ev.size() / 4], ev[ev.size() / 4 + 7]);                  // out of time order
  std::swap(ev[2 * ev.size() / 3], ev[2 * ev.size() / 3 + 100]);
  return ev;
}

// Registered depth 2-8 m with holes: single pixels (filled from a neighbour) and 4x4 patches
// (left to the missing-depth policy).
RegisteredDepth holey_depth(unsigned seed) {
  RegisteredDepth d;
  d.t = kT0 + kWindow / 2;
  d.width = 640;
  d.height = 480;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> z(2.0f, 8.0f);
  for (int i = 0; i < 640 * 480; ++i) d.depth_m.push_back(z(rng));
  std::uniform_int_distribution<int> x(0, 635), y(0, 475);
  for (int k = 0; k < 3000; ++k) d.depth_m[static_cast<std::size_t>(y(rng)) * 640 + x(rng)] = 0;
  for (int k = 0; k < 300; ++k) {
    const int x0 = x(rng), y0 = y(rng);
    for (int dy = 0; dy < 4; ++dy)
      for (int dx = 0; dx < 4; ++dx) d.depth_m[static_cast<std::size_t>(y0 + dy) * 640 + x0 + dx] = 0;
  }
  return d;
}

struct Motion {
  std::vector<ImuSample> imu;
  OdometrySample odometry;
};

Motion fast_motion() {
  Motion m;
  m.imu = test::constant_imu({1.5, -2.0, 3.0}, kT0 - 5 * kNsPerMs, kT0 + 30 * kNsPerMs, kNsPerMs);
  m.odometry.t = kT0;
  m.odometry.v_W = {4.0, 1.0, -0.5};
  return m;
}

bool near_half(double a) { return std::abs(a - std::floor(a) - 0.5) < kTolPx; }

// Compares the optimised window with the reference, returns the number of ambiguous events.
std::size_t expect_equivalent(const CompensatedWindow& fast, const ReferenceWarpResult& ref, const PinholeCamera& cam) {
  const CompensationReport& r = fast.report;
  EXPECT_EQ(r.dropped_outside_window, ref.dropped_outside_window);
  EXPECT_EQ(r.dropped_outside_sensor, ref.dropped_outside_sensor);
  EXPECT_EQ(r.dropped_no_inverse, ref.dropped_no_inverse);
  EXPECT_EQ(r.events_out_of_order, ref.events_out_of_order);
  EXPECT_EQ(r.depth_fallback_events, ref.depth_fallback_events);
  // Walk both lists (both keep input order); an event kept by one side only must lie within the
  // tolerance of the image border.
  std::size_t ambiguous = 0, i = 0, j = 0;
  auto near_border = [&](double u, double v) {
    return std::abs(u + 0.5) < kTolPx || std::abs(u - (cam.width - 0.5)) < kTolPx || std::abs(v + 0.5) < kTolPx ||
           std::abs(v - (cam.height - 0.5)) < kTolPx;
  };
  while (i < ref.u.size() || j < fast.size()) {
    const bool same = i < ref.u.size() && j < fast.size() && ref.t_s[i] == fast.t_s()[j] &&
                      std::abs(ref.u[i] - fast.x()[j]) < kTolPx && std::abs(ref.v[i] - fast.y()[j]) < kTolPx;
    if (same) {
      if (ref.pixel[i] != fast.pixel()[j]) {
        EXPECT_TRUE(near_half(ref.u[i]) || near_half(ref.v[i])) << "event " << ref.input_index[i];
        ++ambiguous;
      }
      ++i, ++j;
    } else if (i < ref.u.size() && near_border(ref.u[i], ref.v[i])) {
      ++ambiguous, ++i;  // kept by the reference only
    } else if (j < fast.size() && near_border(fast.x()[j], fast.y()[j])) {
      ++ambiguous, ++j;  // kept by the optimised code only
    } else {
      ADD_FAILURE() << "kept events differ at reference #" << i << ", optimised #" << j;
      return ambiguous;
    }
  }
  return ambiguous;
}

struct Case {
  const char* method;
  MissingDepthPolicy policy;
};

class ReferenceEquivalence : public ::testing::TestWithParam<Case> {};

TEST_P(ReferenceEquivalence, RandomEventsWithEveryKindOfDrop) {
  const Calibration c = rig();
  CompensationOptions opt;
  opt.method = *parse_compensation_method(GetParam().method);
  opt.missing_depth = GetParam().policy;
  auto comp = make_compensator(c, opt);
  const std::vector<Event> events = random_events(100'000, 3);
  const RegisteredDepth depth = holey_depth(4);
  const Motion m = fast_motion();
  const CompensationInput in{events, kT0, kT0 + kWindow, m.imu, m.odometry, &depth};
  const CompensatedWindow& fast = comp->compensate(in);
  ASSERT_EQ(to_string(fast.report.used), GetParam().method) << fast.report.brief();
  ASSERT_GT(fast.report.dropped_no_inverse, 0u);  // the corners are exercised
  ASSERT_GT(fast.report.dropped_left_image, 0u);
  if (fast.report.used == CompensationMethod::kRotationTranslation) {
    ASSERT_GT(fast.report.depth_fallback_events, 0u);
  }
  const ReferenceWarpResult ref = reference_warp(c.event_camera, reference_motion(fast.report, opt), in);
  const std::size_t ambiguous = expect_equivalent(fast, ref, c.event_camera);
  EXPECT_LE(ambiguous, 20u) << "of " << events.size();
  EXPECT_NEAR(static_cast<double>(fast.report.events_kept), static_cast<double>(ref.u.size()), 20.0);
}

TEST_P(ReferenceEquivalence, ExactSyntheticScene) {
  // Static points seen from a rotating and translating camera (synthetic_motion.h), every event
  // in order: the fast path of the optimised loop, slot changes every millisecond.
  const Calibration c = rig();
  CompensationOptions opt;
  opt.method = *parse_compensation_method(GetParam().method);
  opt.missing_depth = GetParam().policy;
  auto comp = make_compensator(c, opt);
  const Eigen::Vector3d omega_E(0.8, -1.1, 2.0), v_E(1.0, 0.3, 2.5);
  test::SyntheticWindow w =
      test::make_window(c.event_camera, omega_E, v_E, kT0, kWindow, 100'000, 24, 20, 2.0, 6.0);
  const Motion m = fast_motion();
  const CompensationInput in{w.events, kT0, kT0 + kWindow, m.imu, m.odometry, &w.depth};
  const CompensatedWindow& fast = comp->compensate(in);
  ASSERT_GT(fast.size(), 10'000u);
  const ReferenceWarpResult ref = reference_warp(c.event_camera, reference_motion(fast.report, opt), in);
  EXPECT_LE(expect_equivalent(fast, ref, c.event_camera), 10u);
}

INSTANTIATE_TEST_SUITE_P(Methods, ReferenceEquivalence,
                         ::testing::Values(Case{"none", MissingDepthPolicy::kMedianDepth},
                                           Case{"rotation", MissingDepthPolicy::kMedianDepth},
                                           Case{"rotation_translation", MissingDepthPolicy::kMedianDepth},
                                           Case{"rotation_translation", MissingDepthPolicy::kRotationOnly},
                                           Case{"rotation_translation", MissingDepthPolicy::kBeyondRange}),
                         [](const auto& param_info) {
                           std::string name = param_info.param.method;
                           if (param_info.param.policy == MissingDepthPolicy::kRotationOnly) name += "_rotation_only_holes";
                           if (param_info.param.policy == MissingDepthPolicy::kBeyondRange) name += "_beyond_range_holes";
                           return name;
                         });

TEST(ReferenceEquivalence, BurstDecimationVisitsTheSameEvents) {
  // Above max_events_per_window the optimised code visits every k-th event: the reference given
  // exactly those events must agree.
  const Calibration c = rig();
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;
  opt.max_events_per_window = 30'000;
  auto comp = make_compensator(c, opt);
  const std::vector<Event> events = random_events(100'000, 9);
  const Motion m = fast_motion();
  const CompensatedWindow& fast = comp->compensate({events, kT0, kT0 + kWindow, m.imu, m.odometry, nullptr});
  const std::size_t k = (events.size() + opt.max_events_per_window - 1) / opt.max_events_per_window;
  std::vector<Event> visited;
  for (std::size_t i = 0; i < events.size(); i += k) visited.push_back(events[i]);
  EXPECT_EQ(fast.report.dropped_burst, events.size() - visited.size());
  const ReferenceWarpResult ref = reference_warp(c.event_camera, reference_motion(fast.report, opt),
                                                 {visited, kT0, kT0 + kWindow, m.imu, m.odometry, nullptr});
  EXPECT_LE(expect_equivalent(fast, ref, c.event_camera), 10u);
}

}  // namespace
}  // namespace fdv

namespace fdv {
namespace {

TEST(ThreadedWarp, AnyThreadCountGivesTheSameWindowAsOne) {
  // The parts are written at their own offsets and moved together: the output must be the
  // single-threaded one, array for array and counter for counter (out-of-order events and drops
  // on the part boundaries included).
  const Calibration c = rig();
  const std::vector<Event> events = random_events(200'000, 11);
  const RegisteredDepth depth = holey_depth(12);
  const Motion m = fast_motion();
  const CompensationInput in{events, kT0, kT0 + kWindow, m.imu, m.odometry, &depth};
  for (const char* method : {"none", "rotation", "rotation_translation"}) {
    CompensationOptions opt;
    opt.method = *parse_compensation_method(method);
    auto one = make_compensator(c, opt);
    const CompensatedWindow& a = one->compensate(in);
    for (int threads : {2, 3, 7}) {
      SCOPED_TRACE(testing::Message() << method << ", " << threads << " threads");
      opt.threads = threads;
      auto many = make_compensator(c, opt);
      const CompensatedWindow& b = many->compensate(in);
      ASSERT_EQ(a.size(), b.size());
      EXPECT_TRUE(std::equal(a.x().begin(), a.x().end(), b.x().begin()));
      EXPECT_TRUE(std::equal(a.y().begin(), a.y().end(), b.y().begin()));
      EXPECT_TRUE(std::equal(a.t_s().begin(), a.t_s().end(), b.t_s().begin()));
      EXPECT_TRUE(std::equal(a.pixel().begin(), a.pixel().end(), b.pixel().begin()));
      EXPECT_EQ(a.report.brief(), b.report.brief());
      EXPECT_EQ(a.report.events_out_of_order, b.report.events_out_of_order);
    }
  }
}

}  // namespace
}  // namespace fdv
