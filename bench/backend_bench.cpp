// Back-end timings: trajectory estimator solve (20 observations), tracker update, depth
// registration of a 640x480 frame into the event camera, depth segmentation on a 640x480
// registered frame; the dodge's collision risk and manoeuvre choice per estimate.
//   build-*/bench/backend_bench --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
// Target: estimator update with 20 observations, median <= 0.2 ms.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "fdv/core/sensor_data.h"
#include "fdv/avoidance/dodge_planner.h"
#include "fdv/depth/depth_registration.h"
#include "fdv/depth/depth_segmentation.h"
#include "fdv/estimation/collision_risk.h"
#include "fdv/estimation/trajectory_estimator.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/tracking/tracker.h"

namespace fdv {
namespace {

constexpr double kFocal = 536.3;

/// A Table II-like throw: vehicle forward at 2 m/s, camera looking forward (E: x right, y down,
/// z forward), ball ~6 m ahead thrown across at 12 m/s; 14 event + 6 depth observations over 0.35 s
/// with 1.5 px and D435 depth noise.
struct Throw {
  std::vector<EventObservation> events;
  std::vector<DepthMeasurement> depths;
};

Throw make_throw(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  const BallisticTrajectory ball{0, {6.0, 1.8, 1.6}, {-1.0, -12.0, 2.0}, {0, 0, -9.81}};
  Eigen::Matrix3d R_B_E;
  R_B_E << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  auto T_W_E = [&](TimeNs t) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R_B_E;
    T.translation() = Eigen::Vector3d(2.0 * to_seconds(t), 0, 1.5);
    return T;
  };
  Throw th;
  for (int k = 0; k < 14; ++k) {
    const TimeNs t = k * 25 * kNsPerMs;
    const Eigen::Isometry3d T = T_W_E(t);
    const Eigen::Vector3d X = T.inverse() * ball.position(t);
    th.events.push_back(
        {t, X.head<2>() / X.z() + 1.5 / kFocal * Eigen::Vector2d(n01(rng), n01(rng)), T, 0.0});
  }
  for (int i = 0; i < 6; ++i) {
    const TimeNs t = (10 + 55 * i) * kNsPerMs;
    const Eigen::Isometry3d T = T_W_E(t);
    const double z = (T.inverse() * ball.position(t)).z();
    const double sigma = DepthNoiseModel{}.sigma_m(z);
    th.depths.push_back({t, z + sigma * n01(rng), sigma, T});
  }
  return th;
}

EstimatorOptions estimator_options(bool covariance) {
  EstimatorOptions o;
  o.event_focal_px = kFocal;
  o.compute_covariance = covariance;
  return o;
}

// The streaming case: 19 observations already solved, the 20th arrives, re-solve (warm start).
void BM_EstimatorUpdate20(benchmark::State& state) {
  const Throw th = make_throw(1);
  const bool covariance = state.range(0) != 0;
  TrajectoryEstimator base(estimator_options(covariance));
  for (const auto& e : th.events) base.add(e);
  for (std::size_t i = 0; i + 1 < th.depths.size(); ++i) base.add(th.depths[i]);
  base.solve();
  int iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    TrajectoryEstimator est = base;  // copy: 19 observations and the previous estimate
    state.ResumeTiming();
    est.add(th.depths.back());
    const TrajectoryEstimate& e = est.solve();
    benchmark::DoNotOptimize(e.trajectory.p0_W);
    iterations += e.iterations;
  }
  state.counters["lm_iterations"] =
      benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_EstimatorUpdate20)
    ->Arg(1)
    ->Arg(0)
    ->ArgName("covariance")
    ->Unit(benchmark::kMicrosecond);

// Cold: a fresh estimator given all 20 observations at once (linear initialisation, then LM).
void BM_EstimatorColdSolve20(benchmark::State& state) {
  const Throw th = make_throw(2);
  for (auto _ : state) {
    TrajectoryEstimator est(estimator_options(true));
    for (const auto& e : th.events) est.add(e);
    for (const auto& d : th.depths) est.add(d);
    benchmark::DoNotOptimize(est.solve().trajectory.p0_W);
  }
}
BENCHMARK(BM_EstimatorColdSolve20)->Unit(benchmark::kMicrosecond);

// One tracker update (one detection per window, one live track; a new throw every 40 windows).
void BM_TrackerUpdate(benchmark::State& state) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n01(0, 1);
  Tracker tracker;
  TimeNs t = 0;
  int k = 0;
  std::vector<TrackerDetection> d(1);
  for (auto _ : state) {
    const double s = 0.025 * (k % 40);
    d[0].t = t;
    d[0].center_px = {100 + 1200 * s + 1.5 * n01(rng),
                      300 - 300 * s + 500 * s * s + 1.5 * n01(rng)};
    d[0].box_size_px = {24, 24};
    if (k % 40 == 39) t += 200 * kNsPerMs;  // gap: the track is deleted, a new one starts
    benchmark::DoNotOptimize(tracker.update(t, d).assignments.data());
    t += 25 * kNsPerMs;
    ++k;
  }
}
BENCHMARK(BM_TrackerUpdate)->Unit(benchmark::kMicrosecond);

// Depth segmentation on a registered 640x480 frame: wall at 7 m, ball (r = 0.1 m) at the given
// distance, D435 noise, 3 % holes. The ROI is twice the ball's box (distance 4 m: 54x54 px;
// 1.5 m: 143x143 px).
void BM_DepthSegmentation640x480(benchmark::State& state) {
  const double zc = static_cast<double>(state.range(0)) / 10.0;
  const PinholeCamera cam{640, 480, kFocal, kFocal, 320.0, 240.0, {}};
  const Eigen::Vector3d c(0.2, -0.1, zc);
  const double r = 0.1;
  std::mt19937 rng(4);
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  DepthFrame f{0, 640, 480, std::vector<float>(640 * 480)};
  const DepthNoiseModel noise;
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1);
      double z = 7.0;
      const double b = d.dot(c), a = d.squaredNorm(), disc = b * b - a * (c.squaredNorm() - r * r);
      if (disc >= 0) z = (b - std::sqrt(disc)) / a;
      z += noise.sigma_m(z) * n01(rng);
      f.depth_m[static_cast<std::size_t>(v) * 640 + u] =
          u01(rng) < 0.03 ? 0.0f : static_cast<float>(z);
    }
  DepthQuery q;
  q.center_px = cam.project(c);
  q.box_size_px = Eigen::Vector2d::Constant(2 * kFocal * r / zc);
  DepthSegmentationOptions o;
  o.object_radius_m = r;
  for (auto _ : state) {
    const DepthSegmentation s = segment_object_depth(depth_view(f), cam, q, o);
    if (!s.observation) state.SkipWithError(s.reason.c_str());
    benchmark::DoNotOptimize(s.observation);
  }
}
BENCHMARK(BM_DepthSegmentation640x480)
    ->Arg(40)
    ->Arg(15)
    ->ArgName("distance_dm")
    ->Unit(benchmark::kMicrosecond);

// Depth registration (per depth frame, 30 Hz): the simulated rig's D435-like depth camera
// (640x480) into its 640x480 event camera; a slanted wall 3-7 m away, D435 noise, 3 % holes.
// plain:1 = the plain reference (register_frame_plain), for the speed-up in the same run;
// far_quarter:1 = the top quarter of the frame beyond the range (0): the simulated scenes' depth
// frames have ~26 % invalid pixels, 92 % of them in aligned runs of four. event_346:1 = the event
// camera at 346x260 (the same field of view): about 3.4 depth pixels land on each event pixel, and
// which of them is nearest varies from pixel to pixel.
void BM_DepthRegistration640x480(benchmark::State& state) {
  const bool plain = state.range(0) == 1, far_quarter = state.range(1) == 1;
  sim::ScenarioConfig config = sim::make_preset("fast_forward", 1);
  if (state.range(2) == 1) sim::set_event_resolution(config, 346, 260);
  const Calibration calib = config.calibration();
  const PinholeCamera& dc = *calib.depth_camera;
  std::mt19937 rng(5);
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  const DepthNoiseModel noise;
  DepthFrame f{0, dc.width, dc.height, std::vector<float>(static_cast<std::size_t>(dc.width) * dc.height)};
  for (int v = 0; v < dc.height; ++v)
    for (int u = 0; u < dc.width; ++u) {
      const double z = 3.0 + 4.0 * u / dc.width;
      f.depth_m[static_cast<std::size_t>(v) * dc.width + u] =
          u01(rng) < 0.03 ? 0.0f : static_cast<float>(z + noise.sigma_m(z) * n01(rng));
    }
  if (far_quarter) std::fill_n(f.depth_m.begin(), f.depth_m.size() / 4, 0.0f);
  const DepthRegistrar registrar(calib);
  for (auto _ : state) {
    f.t += 1;
    const DepthRegistrationResult r = plain ? registrar.register_frame_plain(f) : registrar.register_frame(f);
    if (!r.ok()) state.SkipWithError(r.rejected.c_str());
    benchmark::DoNotOptimize(r.depth.depth_m.data());
  }
}
BENCHMARK(BM_DepthRegistration640x480)
    ->ArgsProduct({{0, 1}, {0, 1}, {0, 1}})
    ->ArgNames({"plain", "far_quarter", "event_346"})
    ->Unit(benchmark::kMillisecond);

// The dodge's per-estimate cost: the collision risk of the solved 20-observation
// estimate against the vehicle (linear propagation, disc probability), then the planner's choice
// among its 72 candidate directions.
struct DodgeInputs {
  TrajectoryEstimate estimate;
  VehicleState vehicle;
};

DodgeInputs dodge_inputs() {
  const Throw th = make_throw(1);
  TrajectoryEstimator est(estimator_options(true));
  for (const auto& e : th.events) est.add(e);
  for (const auto& d : th.depths) est.add(d);
  DodgeInputs in{est.solve(), {}};
  in.vehicle.odometry.t = in.estimate.t_last;
  in.vehicle.odometry.p_W_B = {0.7, 0.0, 1.5};
  in.vehicle.odometry.v_W = {2.0, 0.0, 0.0};
  in.vehicle.covariance = vehicle_state_covariance(PredictionOptions{});
  return in;
}

void BM_CollisionRisk(benchmark::State& state) {
  const DodgeInputs in = dodge_inputs();
  for (auto _ : state) benchmark::DoNotOptimize(assess_collision_risk(in.estimate, in.vehicle, PredictionOptions{}).risk);
}
BENCHMARK(BM_CollisionRisk)->Unit(benchmark::kMicrosecond);

void BM_DodgePlan(benchmark::State& state) {
  const DodgeInputs in = dodge_inputs();
  const RiskAssessment r = assess_collision_risk(in.estimate, in.vehicle, PredictionOptions{});
  if (!r.risk) {
    state.SkipWithError(r.reason.c_str());
    return;
  }
  const DodgeOptions options;
  for (auto _ : state) benchmark::DoNotOptimize(plan_dodge(*r.risk, in.vehicle, options, 0.5).maneuver.acceleration_W);
}
BENCHMARK(BM_DodgePlan)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace fdv

BENCHMARK_MAIN();
