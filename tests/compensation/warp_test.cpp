// Geometry of the warps, checked against exact synthetic data: static 3D points, a camera with
// known constant ω and v, events from exact projections. After warping, each point's events must
// land on the point's projection at t0 (undistorted grid K·xn), and must NOT with the signs flipped.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <string>
#include <tuple>

#include "fdv/compensation/compensator.h"
#include "fdv/compensation/undistortion_map.h"
#include "fdv/core/error.h"
#include "synthetic_motion.h"

namespace fdv {
namespace {

PinholeCamera test_camera() {
  return {640, 480, 400.0, 402.0, 322.5, 238.2, {-0.12, 0.02, 0.0008, -0.0006, 0.0}};
}

// A rig with every frame different, so that a missing or transposed rotation shows up.
Calibration test_rig() {
  Calibration c;
  c.event_camera = test_camera();
  // Camera looking along the body's x axis (z_E = x_B), mounted 10 cm ahead, 2 cm right, 5 cm up.
  Eigen::Matrix3d R_B_E;
  R_B_E << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  c.T_B_E.linear() = R_B_E * Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX()).toRotationMatrix();
  c.T_B_E.translation() = Eigen::Vector3d(0.10, -0.02, 0.05);
  c.R_B_I = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return c;
}

// Sensor inputs that describe the camera motion (ω_E, v_E): gyro in I, odometry in W/B.
struct Inputs {
  std::vector<ImuSample> imu;
  OdometrySample odometry;
};

Inputs inputs_for(const Calibration& c, const Eigen::Vector3d& omega_E, const Eigen::Vector3d& v_E, TimeNs t0) {
  Inputs in;
  const Eigen::Matrix3d R_B_E = c.T_B_E.linear();
  const Eigen::Vector3d omega_I = c.R_B_I.transpose() * (R_B_E * omega_E);
  in.imu = test::constant_imu(omega_I, t0 - 5 * kNsPerMs, t0 + 30 * kNsPerMs, kNsPerMs);
  in.odometry.t = t0;
  in.odometry.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  // The body velocity that gives camera velocity v_E: v_cam_B = v_B + ω_B × t_B_E.
  const Eigen::Vector3d omega_B = R_B_E * omega_E;
  const Eigen::Vector3d v_B = R_B_E * v_E - omega_B.cross(c.T_B_E.translation());
  in.odometry.v_W = in.odometry.q_W_B * v_B;
  return in;
}

struct Errors {
  double max_event_px = 0;
  std::uint64_t dropped = 0;
  std::vector<double> mean_per_point_px;  // |mean warped position − projection at t0|
  double median_point_error() const {
    std::vector<double> v = mean_per_point_px;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  }
  double max_point_error() const { return *std::max_element(mean_per_point_px.begin(), mean_per_point_px.end()); }
};

// Warps each point's events on their own (so every output event is known to be that point's) and
// compares them with K·(P/z) of the point. `input` supplies everything but the events.
Errors warp_errors(const test::SyntheticWindow& w, Compensator& comp, CompensationInput input,
                   const PinholeCamera& cam) {
  Errors e;
  std::vector<std::vector<Event>> per_point(w.points.size());
  for (std::size_t k = 0; k < w.events.size(); ++k)
    per_point[static_cast<std::size_t>(w.point_of_event[k])].push_back(w.events[k]);
  for (std::size_t i = 0; i < w.points.size(); ++i) {
    if (per_point[i].empty()) continue;
    input.events = per_point[i];
    const CompensatedWindow& out = comp.compensate(input);
    e.dropped += per_point[i].size() - out.size();
    if (out.size() == 0) continue;
    const Eigen::Vector3d& P = w.points[i];
    const Eigen::Vector2d expected(cam.fx * P.x() / P.z() + cam.cx, cam.fy * P.y() / P.z() + cam.cy);
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (std::size_t k = 0; k < out.size(); ++k) {
      const Eigen::Vector2d got(out.x()[k], out.y()[k]);
      e.max_event_px = std::max(e.max_event_px, (got - expected).norm());
      sum += got - expected;
    }
    e.mean_per_point_px.push_back((sum / static_cast<double>(out.size())).norm());
  }
  return e;
}

// Tolerances. An event is its projection rounded to a raw pixel: up to 0.5·√2 px off, ×1.25 at
// most through the undistortion's Jacobian on this lens (≤ 0.9 px). Averaged over a point's ~500
// events the rounding error cancels only as far as the point crosses many pixels: slow points
// near the rotation pole keep up to ~0.3 px of it; the median point keeps ≤ 0.1 px. The exact
// test below removes the rounding altogether.
constexpr double kEventTolPx = 1.0;
constexpr double kPointTolPx = 0.35;
constexpr double kMedianPointTolPx = 0.1;

TEST(Warp, RotationTranslationLandsEveryEventOnItsPointAtT0) {
  const Calibration calib = test_rig();
  const Eigen::Vector3d omega_E(0.8, -1.2, 2.0), v_E(1.5, -0.8, 2.0);
  const TimeNs t0 = 1'000 * kNsPerMs, dt = 25 * kNsPerMs;
  const test::SyntheticWindow w = test::make_window(calib.event_camera, omega_E, v_E, t0, dt, 50 * kNsPerUs);
  ASSERT_GT(w.events.size(), 10'000u);
  const Inputs inp = inputs_for(calib, omega_E, v_E, t0);

  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  opt.rotation_refresh_ns = 10 * kNsPerUs;  // near-continuous rotation: isolates the geometry
  opt.hole_fill_radius_px = 0;
  auto comp = make_compensator(calib, opt);
  const CompensatedWindow& out = comp->compensate({w.events, t0, t0 + dt, inp.imu, inp.odometry, &w.depth});
  EXPECT_EQ(out.report.used, CompensationMethod::kRotationTranslation) << out.report.brief();
  EXPECT_EQ(out.size(), w.events.size()) << out.report.brief();
  EXPECT_EQ(out.report.depth_fallback_events, 0u);
  EXPECT_NEAR((out.report.omega_E - omega_E).norm(), 0, 1e-9);
  EXPECT_NEAR((out.report.v_E - v_E).norm(), 0, 1e-9);
  const Errors e = warp_errors(w, *comp, {{}, t0, t0 + dt, inp.imu, inp.odometry, &w.depth}, calib.event_camera);
  EXPECT_EQ(e.dropped, 0u);
  EXPECT_LT(e.max_event_px, kEventTolPx);
  EXPECT_LT(e.max_point_error(), kPointTolPx);
  EXPECT_LT(e.median_point_error(), kMedianPointTolPx);
}

// Events that sit exactly on pixel centres: each event gets its own static point, placed at depth
// Z on the ray of its pixel at its time t (X_t = Z·[x; 1], P = R(t)·X_t + v·t in E0). With no
// rounding in the data, the warp must put every event on K·(P/z) to float precision.
TEST(Warp, RotationTranslationIsExactOnPixelCenters) {
  const Calibration calib = test_rig();
  const PinholeCamera& cam = calib.event_camera;
  const Eigen::Vector3d omega_E(-0.6, 1.4, -2.2), v_E(-1.2, 0.9, 3.0);
  const TimeNs t0 = 7 * kNsPerS, dt = 25 * kNsPerMs;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> ux(80, 560), uy(60, 420);
  std::uniform_int_distribution<TimeNs> ut(0, dt - 1);
  std::uniform_real_distribution<double> uz(2.0, 8.0);
  RegisteredDepth depth;
  depth.t = t0;
  depth.width = cam.width;
  depth.height = cam.height;
  depth.depth_m.assign(static_cast<std::size_t>(cam.width) * cam.height, 0.0f);
  std::vector<Event> ev;
  std::vector<TimeNs> times;
  for (int i = 0; i < 4000; ++i) times.push_back(ut(rng));
  std::sort(times.begin(), times.end());
  std::vector<Eigen::Vector2d> expected;
  for (TimeNs t : times) {
    int x, y;
    do {
      x = ux(rng), y = uy(rng);
    } while (depth.at(x, y) != 0);  // one event per pixel, so each pixel has one depth
    const double z = uz(rng);
    const Eigen::Vector3d X_t = cam.back_project({x, y}, z);
    const Eigen::Vector3d P = test::rotation_at(omega_E, to_seconds(t)) * X_t + v_E * to_seconds(t);
    depth.depth_m[static_cast<std::size_t>(y) * cam.width + x] = static_cast<float>(z);
    ev.push_back({t0 + t, static_cast<std::uint16_t>(x), static_cast<std::uint16_t>(y), true});
    expected.emplace_back(cam.fx * P.x() / P.z() + cam.cx, cam.fy * P.y() / P.z() + cam.cy);
  }
  const Inputs inp = inputs_for(calib, omega_E, v_E, t0);
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  opt.rotation_refresh_ns = 1 * kNsPerUs;  // R_e at the event's time to within 0.5 µs
  opt.hole_fill_radius_px = 0;
  auto comp = make_compensator(calib, opt);
  const CompensatedWindow& out = comp->compensate({ev, t0, t0 + dt, inp.imu, inp.odometry, &depth});
  ASSERT_EQ(out.size(), ev.size()) << out.report.brief();
  double worst = 0;
  for (std::size_t k = 0; k < ev.size(); ++k)
    worst = std::max(worst, (Eigen::Vector2d(out.x()[k], out.y()[k]) - expected[k]).norm());
  // float32 arithmetic on ~600 px coordinates, normalised rays from the table, and the 0.5 µs
  // rotation step (|ω|·0.5 µs·f ≈ 0.001 px).
  EXPECT_LT(worst, 0.01);
}

// The inverse the detector's centre goes through (Compensator::observed_position): every
// compensated event, taken back to its own time, must land where the sensor saw it (its raw pixel,
// undistorted). Depth is a smooth slanted surface, as around a real object, and the rotation is
// continuous (the inverse uses R(t) at t, the warp the refresh slot's R).
// observed_position of each warped event against where the camera saw it: the largest error,
// and the largest distance the warp moved an event.
struct RoundTrip {
  double worst_px = 0, moved_px = 0;
};
RoundTrip observed_round_trip(const Compensator& comp, const CompensatedWindow& out, std::span<const Event> ev,
                              const PinholeCamera& cam) {
  RoundTrip r;
  for (std::size_t k = 0; k < ev.size(); ++k) {
    const Eigen::Vector2d warped(out.x()[k], out.y()[k]);
    const Eigen::Vector2d seen = cam.undistort_pixel({ev[k].x, ev[k].y});
    r.worst_px = std::max(r.worst_px, (comp.observed_position(warped, out.t_s()[k]) - seen).norm());
    r.moved_px = std::max(r.moved_px, (warped - seen).norm());
  }
  return r;
}

TEST(Warp, ObservedPositionUndoesTheWarpOfEveryEvent) {
  const Calibration calib = test_rig();
  const PinholeCamera& cam = calib.event_camera;
  const Eigen::Vector3d omega_E(-0.6, 1.4, -2.2), v_E(-1.2, 0.9, 3.0);
  const TimeNs t0 = 3 * kNsPerS, dt = 25 * kNsPerMs;
  RegisteredDepth depth;
  depth.t = t0;
  depth.width = cam.width;
  depth.height = cam.height;
  depth.depth_m.resize(static_cast<std::size_t>(cam.width) * cam.height);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x)
      depth.depth_m[static_cast<std::size_t>(y) * cam.width + x] = static_cast<float>(2.0 + 4.0 * x / cam.width + 1.0 * y / cam.height);
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> ux(80, 560), uy(60, 420);
  std::uniform_int_distribution<TimeNs> ut(0, dt - 1);
  std::vector<TimeNs> times;
  for (int i = 0; i < 2000; ++i) times.push_back(ut(rng));
  std::sort(times.begin(), times.end());
  std::vector<Event> ev;
  for (TimeNs t : times) ev.push_back({t0 + t, static_cast<std::uint16_t>(ux(rng)), static_cast<std::uint16_t>(uy(rng)), true});
  const Inputs inp = inputs_for(calib, omega_E, v_E, t0);
  for (const char* method : {"none", "rotation", "rotation_translation"}) {
    CompensationOptions opt;
    opt.method = *parse_compensation_method(method);
    opt.rotation_refresh_ns = 1 * kNsPerUs;
    auto comp = make_compensator(calib, opt);
    const CompensatedWindow& out = comp->compensate({ev, t0, t0 + dt, inp.imu, inp.odometry, &depth});
    ASSERT_EQ(out.report.used, comp->method()) << out.report.brief();
    ASSERT_EQ(out.size(), ev.size()) << out.report.brief();
    const RoundTrip r = observed_round_trip(*comp, out, ev, cam);
    // float32 warp on ~600 px coordinates and the 0.5 µs rotation step.
    EXPECT_LT(r.worst_px, 0.01) << method;
    if (std::string(method) != "none") {
      EXPECT_GT(r.moved_px, 10.0) << method << ": the warp must have moved events";
    }
  }
}

TEST(Warp, FlippedSignsDoNotCompensate) {
  // The same data warped with −ω (rotation sign error) or −v (translation sign error): the test
  // above would catch either, because the points then miss their t0 projection by pixels.
  const Calibration calib = test_rig();
  const Eigen::Vector3d omega_E(0.8, -1.2, 2.0), v_E(1.5, -0.8, 2.0);
  const TimeNs t0 = 0, dt = 25 * kNsPerMs;
  const test::SyntheticWindow w = test::make_window(calib.event_camera, omega_E, v_E, t0, dt, 50 * kNsPerUs);
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  opt.rotation_refresh_ns = 10 * kNsPerUs;
  opt.hole_fill_radius_px = 0;
  opt.max_depth_age_ns = kNsPerS;
  for (const auto& [w_sign, v_sign] : {std::pair{-1.0, 1.0}, std::pair{1.0, -1.0}}) {
    const Inputs inp = inputs_for(calib, w_sign * omega_E, v_sign * v_E, t0);
    auto comp = make_compensator(calib, opt);
    const Errors e = warp_errors(w, *comp, {{}, t0, t0 + dt, inp.imu, inp.odometry, &w.depth}, calib.event_camera);
    EXPECT_GT(e.median_point_error(), 2.0) << "sign ω " << w_sign << ", sign v " << v_sign;
  }
}

TEST(Warp, RotationCompensatesPureRotationAtTheDefaultRefresh) {
  const Calibration calib = test_rig();
  const Eigen::Vector3d omega_E(-1.5, 0.9, 1.2), v_E = Eigen::Vector3d::Zero();
  const TimeNs t0 = 5 * kNsPerS, dt = 25 * kNsPerMs;
  const test::SyntheticWindow w = test::make_window(calib.event_camera, omega_E, v_E, t0, dt, 50 * kNsPerUs);
  const Inputs inp = inputs_for(calib, omega_E, v_E, t0);
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;  // default 1 ms refresh, R_e taken at each slot's middle
  auto comp = make_compensator(calib, opt);
  const CompensatedWindow& out = comp->compensate({w.events, t0, t0 + dt, inp.imu, std::nullopt, nullptr});
  EXPECT_EQ(out.report.used, CompensationMethod::kRotation);
  EXPECT_EQ(out.size(), w.events.size());
  const Errors e = warp_errors(w, *comp, {{}, t0, t0 + dt, inp.imu, std::nullopt, nullptr}, calib.event_camera);
  // Piecewise-constant R: within a 1 ms slot the rotation is off by at most |ω|·0.5 ms, i.e.
  // 2.1 rad/s · 0.5 ms · 402 px · (1 + r²) ≤ 0.8 px at the image edge, on top of the rounding.
  EXPECT_LT(e.max_event_px, kEventTolPx + 0.8);
  EXPECT_LT(e.max_point_error(), 0.3);  // the slot error is a ramp centred on zero: it averages out
  // ... and flipping ω breaks it.
  const Inputs wrong = inputs_for(calib, -omega_E, v_E, t0);
  EXPECT_GT(warp_errors(w, *comp, {{}, t0, t0 + dt, wrong.imu, std::nullopt, nullptr}, calib.event_camera)
                .median_point_error(),
            2.0);
}

TEST(Warp, IntegratedGyroFollowsARateThatChangesWithinTheWindow) {
  // A dodge's tilt: the rate about a fixed axis ramps from 0 to 6 rad/s within the window,
  // ω(t) = α·t, so the camera has turned by θ(t) = α·t²/2. The paper's mean rate ω̄ = α·T/2 turns
  // by ω̄·t instead, off by α·t·(T − t)/2: α·T²/12 = 12.5 mrad (about 5 px here) on average over the
  // window. The integrated gyro is exact at each slot's middle.
  const Calibration calib = test_rig();
  const Eigen::Vector3d axis_E = Eigen::Vector3d(0.4, -1.0, 0.3).normalized();
  const double alpha = 240.0;  // rad/s²
  const TimeNs t0 = 2 * kNsPerS, dt = 25 * kNsPerMs;
  const auto turned = [&](double t_s) {
    return Eigen::AngleAxisd(0.5 * alpha * t_s * t_s, axis_E).toRotationMatrix().eval();
  };
  const test::SyntheticWindow w = test::make_window_rotating(calib.event_camera, turned, Eigen::Vector3d::Zero(), t0, dt,
                                                             50 * kNsPerUs);
  // The gyro (IMU frame) every millisecond, from before the window to after it.
  const Eigen::Vector3d axis_I = calib.R_B_I.transpose() * (calib.T_B_E.linear() * axis_E);
  std::vector<ImuSample> imu;
  for (TimeNs t = t0 - 5 * kNsPerMs; t <= t0 + 30 * kNsPerMs; t += kNsPerMs)
    imu.push_back({t, axis_I * alpha * std::max(0.0, to_seconds(t - t0)), {0, 0, 9.81}});
  for (const bool integrate : {true, false}) {
    CompensationOptions opt;
    opt.method = CompensationMethod::kRotation;
    opt.rotation_refresh_ns = 10 * kNsPerUs;
    opt.integrate_gyro = integrate;
    auto comp = make_compensator(calib, opt);
    const Errors e = warp_errors(w, *comp, {{}, t0, t0 + dt, imu, std::nullopt, nullptr}, calib.event_camera);
    if (integrate) {
      EXPECT_LT(e.max_event_px, kEventTolPx);
      EXPECT_LT(e.median_point_error(), kMedianPointTolPx);
    } else {
      EXPECT_GT(e.median_point_error(), 2.0) << "the mean rate should miss a ramping rate";
    }
  }
}

TEST(Warp, ObservedPositionWithTheIntegratedGyroUndoesTheWarp) {
  // observed_position must invert the warp: the rotation interpolated between slot middles, which
  // the 1 µs refresh makes the warp's own to well under a hundredth of a pixel.
  const Calibration calib = test_rig();
  const PinholeCamera& cam = calib.event_camera;
  const TimeNs t0 = kNsPerS, dt = 25 * kNsPerMs;
  const Eigen::Vector3d axis_I(0.2, 0.9, -0.4);
  std::vector<ImuSample> imu;
  for (TimeNs t = t0 - 5 * kNsPerMs; t <= t0 + 30 * kNsPerMs; t += kNsPerMs)
    imu.push_back({t, axis_I * 200.0 * to_seconds(t - t0), {0, 0, 9.81}});
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> ux(100, 540), uy(80, 400);
  std::vector<Event> ev;
  for (TimeNs t = 0; t < dt; t += 20 * kNsPerUs)
    ev.push_back({t0 + t, static_cast<std::uint16_t>(ux(rng)), static_cast<std::uint16_t>(uy(rng)), true});
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;
  opt.integrate_gyro = true;
  opt.rotation_refresh_ns = 1 * kNsPerUs;
  auto comp = make_compensator(calib, opt);
  const CompensatedWindow& out = comp->compensate({ev, t0, t0 + dt, imu, std::nullopt, nullptr});
  ASSERT_EQ(out.size(), ev.size()) << out.report.brief();
  const RoundTrip r = observed_round_trip(*comp, out, ev, cam);
  EXPECT_LT(r.worst_px, 0.01);
  EXPECT_GT(r.moved_px, 10.0);
}

TEST(Warp, ObservedPositionWithTheIntegratedGyroIsTheMeanRatesForAConstantRate) {
  // For a constant rate the integrated rotation is exp([ω]× t) at every knot (the window's start,
  // the slots' middles, its end), and slerp between them on one axis is exact: at any time, from
  // the window's start to its end, observed_position must equal the mean rate's closed form.
  const Calibration calib = test_rig();
  const Eigen::Vector3d omega_E(1.1, -2.0, 1.6);
  const TimeNs t0 = 4 * kNsPerS, dt = 25 * kNsPerMs;
  const Inputs inp = inputs_for(calib, omega_E, Eigen::Vector3d::Zero(), t0);
  const std::vector<Event> ev{{t0 + kNsPerMs, 320, 240, true}};
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;
  auto mean_rate = make_compensator(calib, opt);
  opt.integrate_gyro = true;
  auto integrated = make_compensator(calib, opt);
  for (Compensator* comp : {mean_rate.get(), integrated.get()})
    ASSERT_EQ(comp->compensate({ev, t0, t0 + dt, inp.imu, std::nullopt, nullptr}).size(), 1u);
  for (const double t_s : {0.0, 0.0002, 0.0005, 0.0123, 0.0247, 0.0249, 0.025}) {
    const Eigen::Vector2d px(100, 400);
    EXPECT_LT((integrated->observed_position(px, t_s) - mean_rate->observed_position(px, t_s)).norm(), 1e-6)
        << "t = " << t_s;
  }
}

TEST(Warp, RotationAloneLeavesTheTranslationalFlow) {
  const Calibration calib = test_rig();
  const Eigen::Vector3d omega_E(0.3, 0.2, -0.4), v_E(2.0, 0.0, 3.0);
  const TimeNs t0 = 0, dt = 25 * kNsPerMs;
  const test::SyntheticWindow w = test::make_window(calib.event_camera, omega_E, v_E, t0, dt, 50 * kNsPerUs);
  const Inputs inp = inputs_for(calib, omega_E, v_E, t0);
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;
  auto rot = make_compensator(calib, opt);
  const CompensationInput in{{}, t0, t0 + dt, inp.imu, inp.odometry, &w.depth};
  // Mean translational displacement over the window ≈ f·|v_xy|/z·Δt/2 ≈ 402·2/4.5·0.0125 ≈ 2 px
  // plus the expansion from v_z: well above the compensated error.
  EXPECT_GT(warp_errors(w, *rot, in, calib.event_camera).median_point_error(), 1.0);
  opt.method = CompensationMethod::kRotationTranslation;
  opt.hole_fill_radius_px = 0;
  auto rt = make_compensator(calib, opt);
  EXPECT_LT(warp_errors(w, *rt, in, calib.event_camera).max_point_error(), kPointTolPx);
}

TEST(Warp, NoneIsExactlyTheUndistortion) {
  Calibration calib;
  calib.event_camera = test_camera();
  std::vector<Event> ev;
  for (int i = 0; i < 200; ++i)
    ev.push_back({i * 100'000, static_cast<std::uint16_t>((i * 37) % 640), static_cast<std::uint16_t>((i * 53) % 480), true});
  CompensationOptions opt;
  opt.method = CompensationMethod::kNone;
  auto comp = make_compensator(calib, opt);
  const CompensatedWindow& out = comp->compensate({.events = ev, .t_start = 0, .t_end = 25 * kNsPerMs});
  std::size_t k = 0;
  for (const Event& e : ev) {
    const Eigen::Vector2d u = calib.event_camera.undistort_pixel({e.x, e.y});  // core's Newton inverse
    if (!(u.x() >= -0.5 && u.x() < 639.5 && u.y() >= -0.5 && u.y() < 479.5)) continue;
    ASSERT_LT(k, out.size());
    EXPECT_NEAR(out.x()[k], u.x(), 1e-3);
    EXPECT_NEAR(out.y()[k], u.y(), 1e-3);
    EXPECT_EQ(out.pixel()[k], static_cast<int>(std::lround(u.y())) * 640 + static_cast<int>(std::lround(u.x())));
    EXPECT_NEAR(out.t_s()[k], to_seconds(e.t), 1e-8);  // float seconds: ~2 ns resolution at 25 ms
    ++k;
  }
  EXPECT_EQ(k, out.size());
  EXPECT_EQ(out.report.events_in, ev.size());
  EXPECT_EQ(out.report.events_kept + out.report.dropped_left_image, ev.size());
}

TEST(Warp, RoundsToTheNearestPixelNotDown) {
  // Camera without distortion; rotation about y by θ moves the principal ray to u = cx + fx·tan θ.
  Calibration calib;
  calib.event_camera = {64, 48, 400.0, 400.0, 32.0, 24.0, {}};
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;
  opt.rotation_refresh_ns = kNsPerMs;
  // An event at t0 + 0.5 ms falls in slot 0, whose rotation is taken at 0.5 ms: θ = ω_y·0.5 ms.
  const std::vector<Event> ev{{500'000, 32, 24, true}};
  for (const auto& [shift_px, expected_u] : {std::pair{0.7, 33}, std::pair{0.3, 32}, std::pair{-0.7, 31}, std::pair{-0.3, 32}}) {
    const double omega_y = std::atan(shift_px / 400.0) / 0.0005;
    const auto imu = test::constant_imu({0, omega_y, 0}, -kNsPerMs, 30 * kNsPerMs, kNsPerMs);
    auto comp = make_compensator(calib, opt);
    const CompensatedWindow& out = comp->compensate({.events = ev, .t_start = 0, .t_end = 25 * kNsPerMs, .imu = imu});
    ASSERT_EQ(out.size(), 1u);
    EXPECT_NEAR(out.x()[0], 32.0 + shift_px, 1e-4);
    EXPECT_EQ(out.pixel()[0], 24 * 64 + expected_u) << "shift " << shift_px;
  }
}

TEST(Warp, CountsEveryDroppedEventByReason) {
  Calibration calib;
  // Strong barrel distortion: r_d = r·(1 − 0.2 r²) peaks at r_d = 0.86 (r = 1.29), so the corners
  // (r_d = 1.0) have no inverse, and the middle of the left edge (r_d = 0.8, r = 1.0, u = −80)
  // undistorts to outside the grid.
  calib.event_camera = {640, 480, 400.0, 400.0, 320.0, 240.0, {-0.2, 0, 0, 0, 0}};
  const UndistortionMap map(calib.event_camera);
  EXPECT_GT(map.pixels_without_inverse(), 0);
  EXPECT_EQ(map.grid_index(0, 0), UndistortionMap::kNoInverse);
  const TimeNs t0 = 100 * kNsPerMs, t1 = t0 + 25 * kNsPerMs;
  std::vector<Event> ev{
      {t0 - 1, 320, 240, true},    // before the window
      {t1, 320, 240, true},        // at the (exclusive) end
      {t0 + 5, 640, 10, true},     // x outside the 640-wide sensor
      {t0 + 6, 10, 480, false},    // y outside
      {t0 + 7, 0, 0, true},        // corner: no undistortion
      {t0 + 8, 320, 240, true},    // kept
      {t0 + 9, 321, 241, true},    // kept
  };
  // A raw pixel that undistorts to outside the grid (barrel: the undistorted image is larger).
  int outside_x = -1;
  for (int x = 0; x < 640 && outside_x < 0; ++x)
    if (map.grid_index(x, 240) == UndistortionMap::kOutside) outside_x = x;
  ASSERT_GE(outside_x, 0);
  ev.push_back({t0 + 10, static_cast<std::uint16_t>(outside_x), 240, true});
  CompensationOptions opt;
  opt.method = CompensationMethod::kNone;
  auto comp = make_compensator(calib, opt);
  const CompensationReport& r = comp->compensate({.events = ev, .t_start = t0, .t_end = t1}).report;
  EXPECT_EQ(r.events_in, 8u);
  EXPECT_EQ(r.dropped_outside_window, 2u);
  EXPECT_EQ(r.dropped_outside_sensor, 2u);
  EXPECT_EQ(r.dropped_no_inverse, 1u);
  EXPECT_EQ(r.dropped_left_image, 1u);
  EXPECT_EQ(r.events_kept, 2u);
}

TEST(Warp, APinholeCamerasMapIsKInverseAndTheIdentityGrid) {
  // Without distortion the map is built without the lens solver: its rays must be what the camera
  // model gives, and each raw pixel its own grid pixel (the principal point off-centre, fx != fy).
  const PinholeCamera pinhole{346, 260, 255.5, 250.25, 170.3, 131.7, {}};
  const UndistortionMap map(pinhole);
  EXPECT_EQ(map.pixels_without_inverse(), 0);
  for (int y = 0; y < pinhole.height; ++y)
    for (int x = 0; x < pinhole.width; ++x) {
      const Eigen::Vector2d xn = pinhole.pixel_to_normalized({x, y});
      ASSERT_EQ(map.ray(x, y).x, static_cast<float>(xn.x())) << x << ", " << y;
      ASSERT_EQ(map.ray(x, y).y, static_cast<float>(xn.y())) << x << ", " << y;
      ASSERT_EQ(map.grid_index(x, y), y * pinhole.width + x) << x << ", " << y;
    }
}

TEST(Warp, ADistortedCamerasMapIsTheLensInverseAtEveryPixel) {
  // The map solves each pixel from its left neighbour's solution: it must give the camera model's
  // own inverse (solved cold, per pixel) to float precision, and no inverse at the same pixels,
  // on a lens that folds inside the image (the corners) and on a mild one with tangential terms.
  for (const PinholeCamera& camera :
       {PinholeCamera{640, 480, 400.0, 400.0, 320.0, 240.0, {-0.2, 0, 0, 0, 0}},
        PinholeCamera{346, 260, 255.5, 250.25, 170.3, 131.7, {-0.35, 0.15, 0.001, -0.0008, -0.02}}}) {
    const UndistortionMap map(camera);
    int without_inverse = 0;
    for (int y = 0; y < camera.height; ++y)
      for (int x = 0; x < camera.width; ++x) {
        const Eigen::Vector2d xn = camera.pixel_to_normalized({x, y});
        if (!xn.allFinite()) {
          ++without_inverse;
          ASSERT_EQ(map.grid_index(x, y), UndistortionMap::kNoInverse) << x << ", " << y;
          continue;
        }
        ASSERT_NEAR(map.ray(x, y).x, xn.x(), 1e-6 * std::max(1.0, std::abs(xn.x()))) << x << ", " << y;
        ASSERT_NEAR(map.ray(x, y).y, xn.y(), 1e-6 * std::max(1.0, std::abs(xn.y()))) << x << ", " << y;
        ASSERT_NE(map.grid_index(x, y), UndistortionMap::kNoInverse) << x << ", " << y;
      }
    EXPECT_EQ(map.pixels_without_inverse(), without_inverse);
  }
}

// Compensating only near some boxes of the grid (CompensationInput::near_regions) must put into
// them exactly what the full compensation puts there, event for event in the same order, and skip
// the rest: fast rotation and translation over near depth (the warp moves events up to ~60 px
// here), a gyro rate ramping to 6 rad/s within the window, and the lens alone ("none").
TEST(Warp, NearRegionsGetEveryEventTheFullWarpPutsThere) {
  const Calibration calib = test_rig();
  const TimeNs t0 = 1'000 * kNsPerMs, dt = 25 * kNsPerMs;
  const Eigen::Vector3d omega_E(0.8, -1.2, 2.0), v_E(1.5, -0.8, 2.0);
  const test::SyntheticWindow fast = test::make_window(calib.event_camera, omega_E, v_E, t0, dt, 50 * kNsPerUs);
  const Inputs motion = inputs_for(calib, omega_E, v_E, t0);
  const Eigen::Vector3d axis_E = Eigen::Vector3d(0.4, -1.0, 0.3).normalized();
  const double alpha = 240.0;  // rad/s²
  const test::SyntheticWindow tilt = test::make_window_rotating(
      calib.event_camera, [&](double t) { return Eigen::AngleAxisd(0.5 * alpha * t * t, axis_E).toRotationMatrix().eval(); },
      Eigen::Vector3d::Zero(), t0, dt, 50 * kNsPerUs);
  std::vector<ImuSample> ramp;
  const Eigen::Vector3d axis_I = calib.R_B_I.transpose() * (calib.T_B_E.linear() * axis_E);
  for (TimeNs t = t0 - 5 * kNsPerMs; t <= t0 + 30 * kNsPerMs; t += kNsPerMs)
    ramp.push_back({t, axis_I * alpha * std::max(0.0, to_seconds(t - t0)), {0, 0, 9.81}});
  // One box inside, one across the left edge, a small one in a corner.
  const std::vector<Eigen::AlignedBox2d> regions = {{Eigen::Vector2d(300, 200), Eigen::Vector2d(380, 260)},
                                                    {Eigen::Vector2d(-0.5, 100), Eigen::Vector2d(60, 300)},
                                                    {Eigen::Vector2d(600, 440), Eigen::Vector2d(639.5, 479.5)}};
  const auto in_regions = [&](float x, float y) {
    return std::any_of(regions.begin(), regions.end(), [&](const Eigen::AlignedBox2d& b) { return b.contains(Eigen::Vector2d(x, y)); });
  };
  struct Case {
    const char* name;
    CompensationMethod method;
    bool integrate_gyro;
    const test::SyntheticWindow& window;
    CompensationInput input;
  };
  const Case cases[] = {
      {"rotation_translation", CompensationMethod::kRotationTranslation, false, fast,
       {fast.events, t0, t0 + dt, motion.imu, motion.odometry, &fast.depth}},
      {"rotation, integrated ramp", CompensationMethod::kRotation, true, tilt, {tilt.events, t0, t0 + dt, ramp, std::nullopt, nullptr}},
      {"none", CompensationMethod::kNone, false, fast, {fast.events, t0, t0 + dt, motion.imu, motion.odometry, &fast.depth}}};
  // Events on the sensor's first and last columns too, which the lens or the warp puts off the
  // grid: their times count all the same.
  const auto with_border_events = [&](const std::vector<Event>& events) {
    std::vector<Event> border;
    const int w = calib.event_camera.width, h = calib.event_camera.height;
    for (int k = 0; k < 2000; ++k)
      border.push_back({t0 + k * (dt / 2000), static_cast<std::uint16_t>(k % 2 ? w - 1 - k % 3 : k % 3),
                        static_cast<std::uint16_t>((k * 7) % h), k % 2 == 0});
    std::vector<Event> all;
    std::merge(events.begin(), events.end(), border.begin(), border.end(), std::back_inserter(all),
               [](const Event& a, const Event& b) { return a.t < b.t; });
    return all;
  };
  std::size_t moved_off_grid = 0;
  for (Case c : cases) {
    const std::vector<Event> events = with_border_events(c.window.events);
    c.input.events = events;
    CompensationOptions opt;
    opt.method = c.method;
    opt.integrate_gyro = c.integrate_gyro;
    auto comp = make_compensator(calib, opt);
    using Landed = std::tuple<float, float, float, std::int32_t>;
    const auto landed = [&](const CompensatedWindow& out) {
      std::vector<Landed> v;
      for (std::size_t k = 0; k < out.size(); ++k)
        if (in_regions(out.x()[k], out.y()[k])) v.emplace_back(out.x()[k], out.y()[k], out.t_s()[k], out.pixel()[k]);
      return v;
    };
    const CompensatedWindow& whole = comp->compensate(c.input);
    moved_off_grid += events.size() - whole.size();
    const std::vector<Landed> full = landed(whole);
    CompensationInput near = c.input;
    near.near_regions = regions;
    const CompensatedWindow& out = comp->compensate(near);
    EXPECT_EQ(landed(out), full) << c.name;
    const double reach = out.report.near_regions_reach_px;
    EXPECT_GT(full.size(), 1000u) << c.name;
    const CompensationReport& r = out.report;
    EXPECT_GT(r.skipped_far_from_regions, events.size() / 3) << c.name << ": " << r.brief();
    EXPECT_EQ(r.events_in, r.events_kept + r.dropped_outside_window + r.dropped_outside_sensor + r.dropped_no_inverse +
                               r.dropped_left_image + r.dropped_burst + r.skipped_far_from_regions)
        << c.name;
    // Every event's time, as the warp writes it, those the warp moves off the grid included.
    ASSERT_EQ(out.window_t_s().size(), events.size()) << c.name;
    for (std::size_t k = 0; k < events.size(); ++k)
      ASSERT_EQ(out.window_t_s()[k], static_cast<float>(events[k].t - t0) * 1e-9f) << c.name << " " << k;
    // The reach bounds how far the warp moves an event from its undistorted pixel (every 20th event
    // warped on its own, so that its output is known to be its own). It takes the grid's farthest
    // ray and the frame's nearest depth, so it may be loose, but not by 3x here.
    double moved_px = 0;
    const PinholeCamera& cam = calib.event_camera;
    for (std::size_t k = 0; k < events.size(); k += 20) {
      CompensationInput one = c.input;
      const Event& e = events[k];
      one.events = std::span<const Event>(&e, 1);
      const CompensatedWindow& w = comp->compensate(one);
      if (w.size() != 1) continue;
      const Eigen::Vector2d lens_only = cam.undistort_pixel(Eigen::Vector2d(e.x, e.y));
      moved_px = std::max(moved_px, (Eigen::Vector2d(w.x()[0], w.y()[0]) - lens_only).norm());
    }
    EXPECT_LE(moved_px, reach) << c.name;
    if (c.method != CompensationMethod::kNone) {
      EXPECT_GT(moved_px, 0.35 * reach) << c.name;
    }
    // Out of time order: the whole window's order is reported (the sources then do not search its
    // times), and the times keep the input's order.
    std::vector<Event> swapped = events;
    std::swap(swapped[100], swapped[swapped.size() / 2]);
    CompensationInput unordered = near;
    unordered.events = swapped;
    const CompensatedWindow& shuffled = comp->compensate(unordered);
    EXPECT_EQ(shuffled.report.events_out_of_order, 2u) << c.name;  // after the swapped pair's first and second
    EXPECT_EQ(shuffled.window_t_s()[100], static_cast<float>(swapped[100].t - t0) * 1e-9f) << c.name;
    // No region: nothing is needed.
    near.near_regions = std::span<const Eigen::AlignedBox2d>{};
    const CompensatedWindow& none = comp->compensate(near);
    EXPECT_EQ(none.size(), 0u) << c.name;
    EXPECT_EQ(none.report.skipped_far_from_regions, events.size()) << c.name;
  }
  EXPECT_GT(moved_off_grid, 100u);
}

TEST(Warp, EmptyWindowIsFine) {
  Calibration calib;
  calib.event_camera = test_camera();
  for (const char* m : {"none", "rotation", "rotation_translation", "contrast_max"}) {
    CompensationOptions opt;
    opt.method = *parse_compensation_method(m);
    auto comp = make_compensator(calib, opt);
    const CompensatedWindow& out = comp->compensate({.events = {}, .t_start = 0, .t_end = 25 * kNsPerMs});
    EXPECT_EQ(out.size(), 0u) << m;
    EXPECT_EQ(out.report.events_in, 0u) << m;
  }
}

TEST(Warp, CameraVelocityIncludesTheLeverArm) {
  // Body spinning about its z axis at 2 rad/s and not translating; camera 0.1 m ahead on x_B,
  // looking along x_B. The camera moves at ω × r = (0, 0, 2) × (0.1, 0, 0) = (0, 0.2, 0) in B,
  // i.e. along −x_E (x_E = −y_B with this mounting).
  Calibration c;
  c.event_camera = test_camera();
  Eigen::Matrix3d R_B_E;
  R_B_E << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  c.T_B_E.linear() = R_B_E;
  c.T_B_E.translation() = Eigen::Vector3d(0.1, 0, 0);
  OdometrySample odo;
  odo.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d v = camera_velocity_E(c, odo, {0, 0, 2.0});
  EXPECT_NEAR(v.x(), -0.2, 1e-12);
  EXPECT_NEAR(v.y(), 0.0, 1e-12);
  EXPECT_NEAR(v.z(), 0.0, 1e-12);
  // Pure body translation 3 m/s along world x with the body yawed 90°: body −y, i.e. camera +x_E.
  odo.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  odo.v_W = {3, 0, 0};
  const Eigen::Vector3d v2 = camera_velocity_E(c, odo, Eigen::Vector3d::Zero());
  EXPECT_NEAR(v2.x(), 3.0, 1e-12);
  EXPECT_NEAR(v2.y(), 0.0, 1e-12);
  EXPECT_NEAR(v2.z(), 0.0, 1e-12);
}

TEST(CompensationMethod, NamesRoundTripAndUnknownNamesAreRejected) {
  for (auto m : {CompensationMethod::kNone, CompensationMethod::kRotation, CompensationMethod::kRotationTranslation,
                 CompensationMethod::kContrastMax})
    EXPECT_EQ(parse_compensation_method(to_string(m)), m);
  EXPECT_FALSE(parse_compensation_method("rotation+translation"));
  Calibration calib;
  calib.event_camera = test_camera();
  CompensationOptions opt;
  opt.method = static_cast<CompensationMethod>(17);  // not a method: from a bad cast
  EXPECT_THROW(make_compensator(calib, opt), ConfigError);
  opt.method = CompensationMethod::kRotation;
  opt.rotation_refresh_ns = 0;
  EXPECT_THROW(make_compensator(calib, opt), ConfigError);
}

}  // namespace
}  // namespace fdv
