// The flown vehicle (vehicle_dynamics.h) against what a quadrotor must do: the steady tilt
// atan(a/g) of a lateral command, in the truth attitude and in the IMU; the first-order lag and
// the rate limit; the tilt limit, the floor, the ceiling and late commands; and, in the simulator,
// that a commanded run without commands renders exactly what the path run renders.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "fdv/core/error.h"
#include "fdv/sim/simulator.h"
#include "fdv/sim/vehicle_dynamics.h"
#include "sim_test_util.h"

namespace fdv::sim {
namespace {

const Eigen::Vector3d kGravity(0, 0, -9.81);
using test::kDeg;

/// Hovering still at 1.5 m, level, no vibration.
VehicleConfig still_hover() { return test::still_scene().vehicle; }

/// The angle of the body z axis from the vertical.
double tilt(const BodyState& s) {
  return std::acos(std::clamp(s.R_W_B.col(2).dot(Eigen::Vector3d::UnitZ()), -1.0, 1.0));
}

TEST(FlownVehicle, WithoutCommandsItIsThePathExactly) {
  VehicleConfig config = still_hover();
  config.motion = MotionKind::kHover;  // vibration and wander: a path with every term moving
  const VehicleTrajectory path(config, 3, kGravity);
  FlownVehicle flown(path, config.response, kGravity);
  flown.advance_to(1.0);
  for (double t = 0; t <= 1.0; t += 0.0137) {
    const BodyState a = flown.at(t), b = path.at(t);
    EXPECT_EQ(a.p_W, b.p_W);
    EXPECT_EQ(a.v_W, b.v_W);
    EXPECT_EQ(a.R_W_B, b.R_W_B);
    EXPECT_EQ(a.omega_B, b.omega_B);
  }
  EXPECT_EQ(flown.counters().commands, 0u);
}

TEST(FlownVehicle, ALateralCommandSettlesAtTheTiltAtanAOverG) {
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle flown(path, config.response, kGravity);
  const double a = 5.0;
  flown.command(from_seconds(0.1), {0, a, 0});
  flown.advance_to(1.2);
  EXPECT_EQ(flown.at(0.1).p_W, path.at(0.1).p_W);  // nothing before the command's time
  const BodyState s = flown.at(1.2);  // 14 time constants after the command
  EXPECT_NEAR(tilt(s), std::atan(a / 9.81), 1e-5);
  // Tilted towards +y (left): the body z axis leans left, i.e. a roll to the left (negative
  // roll about x in FLU).
  EXPECT_GT(s.R_W_B.col(2).y(), 0.0);
  EXPECT_NEAR((s.a_W - Eigen::Vector3d(0, a, 0)).norm(), 0.0, 1e-4);  // e^-14 of the step left
  EXPECT_NEAR(s.omega_B.norm(), 0.0, 1e-4);
  // The velocity is the integral of the acceleration: check one against the other by finite
  // differences anywhere in the manoeuvre, across grid nodes.
  for (double t = 0.1003; t < 1.2; t += 0.0731) {
    const double h = 1e-5;
    const Eigen::Vector3d dv = (flown.at(t + h).v_W - flown.at(t - h).v_W) / (2 * h);
    const Eigen::Vector3d dp = (flown.at(t + h).p_W - flown.at(t - h).p_W) / (2 * h);
    EXPECT_LT((dv - flown.at(t).a_W).norm(), 1e-3) << t;
    EXPECT_LT((dp - flown.at(t).v_W).norm(), 1e-6) << t;
  }
}

TEST(FlownVehicle, TheTiltLagsByTheTimeConstantAndTurnsNoFasterThanTheRateLimit) {
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  const double tau = config.response.attitude_time_constant_s;
  {  // a small step: a first-order response, 1 - 1/e of the way after one time constant
    FlownVehicle flown(path, config.response, kGravity);
    flown.command(0, {1.0, 0, 0});
    flown.advance_to(1.0);
    EXPECT_NEAR(tilt(flown.at(tau)) / std::atan(1.0 / 9.81), 1 - std::exp(-1.0), 0.005);
  }
  {  // a large step: the rate limit holds the tilt rate at first
    FlownVehicle flown(path, config.response, kGravity);
    flown.command(0, {15.0, 0, 0});
    flown.advance_to(1.0);
    double fastest = 0;
    for (double t = 0; t < 1.0; t += 1e-3) fastest = std::max(fastest, flown.at(t).omega_B.norm());
    EXPECT_NEAR(fastest, config.response.max_body_rate_rad_s, 1e-9);
    EXPECT_NEAR(tilt(flown.at(0.05)), 0.05 * config.response.max_body_rate_rad_s, 1e-3);
    EXPECT_NEAR(tilt(flown.at(1.0)), std::atan(15.0 / 9.81), 1e-3);
    EXPECT_EQ(flown.counters().tilt_clipped, 0u);  // 56.8° is within the 60° limit
  }
}

TEST(FlownVehicle, ACommandBeyondTheTiltLimitIsClippedAndCounted) {
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle flown(path, config.response, kGravity);
  flown.command(0, {0, -30.0, 0});
  flown.advance_to(1.5);
  const BodyState s = flown.at(1.5);
  EXPECT_NEAR(tilt(s), 60 * kDeg, 1e-6);
  // Height held: all the clipped thrust's horizontal part, g tan 60°.
  EXPECT_NEAR(s.a_W.y(), -9.81 * std::tan(60 * kDeg), 1e-6);
  EXPECT_NEAR(s.a_W.z(), 0.0, 1e-9);
  EXPECT_EQ(flown.counters().tilt_clipped, 1u);
}

TEST(FlownVehicle, TheFloorStopsADescentAndHoldsItsHeight) {
  const VehicleConfig config = still_hover();  // at 1.5 m; floor 0.5 m
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle flown(path, config.response, kGravity);
  flown.command(0, {0, 0, -8.0});
  flown.advance_to(3.0);
  double lowest = 10;
  for (double t = 0; t <= 3.0; t += 1e-3) lowest = std::min(lowest, flown.at(t).p_W.z());
  EXPECT_GT(lowest, config.response.min_height_m - 0.01);
  EXPECT_LT(lowest, config.response.min_height_m + 0.05);  // it did go down to the floor
  EXPECT_NEAR(flown.at(3.0).v_W.z(), 0.0, 0.01);
  EXPECT_EQ(flown.counters().floor_holds, 1u);
}

TEST(FlownVehicle, TheCeilingStopsAClimbAndHoldsItsHeight) {
  const VehicleConfig config = still_hover();  // at 1.5 m; ceiling 4.5 m
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle flown(path, config.response, kGravity);
  flown.command(0, {0, 0, 8.0});
  flown.advance_to(3.0);
  double highest = 0;
  for (double t = 0; t <= 3.0; t += 1e-3) highest = std::max(highest, flown.at(t).p_W.z());
  // Unbraked, the 3 m climb at 8 m/s² would reach the ceiling at 6.9 m/s.
  EXPECT_LT(highest, config.response.max_height_m + 0.01);
  EXPECT_GT(highest, config.response.max_height_m - 0.05);  // it did go up to the ceiling
  EXPECT_NEAR(flown.at(3.0).v_W.z(), 0.0, 0.01);
  EXPECT_EQ(flown.counters().ceiling_holds, 1u);
  EXPECT_EQ(flown.counters().floor_holds, 0u);
}

TEST(FlownVehicle, AWallStopsASidewaysMotionInsideTheRoom) {
  // A room 5 m to each side of the hover point; a sideways command the vehicle follows by tilting.
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  const Eigen::AlignedBox3d room(Eigen::Vector3d(-10, -5, 0), Eigen::Vector3d(60, 5, 5));
  FlownVehicle flown(path, config.response, kGravity, room);
  flown.command(0, {0, 8.0, 0});
  flown.advance_to(3.0);
  double farthest = -10;
  for (double t = 0; t <= 3.0; t += 1e-3) farthest = std::max(farthest, flown.at(t).p_W.y());
  // Unbraked, 3 s at 8 m/s² would carry it 36 m; braked by a tilt, which lags by τ, it stops
  // within the margin's 0.5 m beyond the wall's line and inside the room.
  const double wall = room.max().y() - config.response.wall_margin_m;
  EXPECT_LT(farthest, room.max().y());
  EXPECT_GT(farthest, wall - 0.05);  // it did go up to the wall
  // Stopped, the command towards the wall is dropped; the brake's tilt relaxes with the lag, so
  // the vehicle drifts back into the room at about |g|·τ (0.8 m/s), never towards the wall.
  const double drift = flown.at(3.0).v_W.y();
  EXPECT_LE(drift, 0.0);
  EXPECT_GT(drift, -9.81 * config.response.attitude_time_constant_s - 0.1);
  EXPECT_EQ(flown.counters().wall_holds, 1u);
  EXPECT_EQ(flown.counters().floor_holds + flown.counters().ceiling_holds, 0u);
}

TEST(FlownVehicle, FarFromTheWallsTheRoomChangesNothing) {
  // Bit for bit: the walls' rule only acts once a wall is near.
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle open(path, config.response, kGravity);
  FlownVehicle walled(path, config.response, kGravity,
                      Eigen::AlignedBox3d(Eigen::Vector3d(-10, -5, 0), Eigen::Vector3d(60, 5, 5)));
  for (FlownVehicle* v : {&open, &walled}) {
    v->command(from_seconds(0.1), {0, 8.0, 2.0});
    v->command(from_seconds(0.35), {0, 0, 0});
    v->advance_to(1.5);
  }
  for (double t = 0; t <= 1.5; t += 0.0137) {
    EXPECT_EQ(open.at(t).p_W, walled.at(t).p_W) << t;
    EXPECT_EQ(open.at(t).R_W_B, walled.at(t).R_W_B) << t;
  }
  EXPECT_EQ(walled.counters().wall_holds, 0u);
}

TEST(FlownVehicle, ACommandForATimeAlreadyFlownActsFromTheHorizonAndIsCounted) {
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle flown(path, config.response, kGravity);
  flown.advance_to(0.5);
  flown.command(from_seconds(0.3), {0, 5, 0});
  flown.advance_to(0.7);
  EXPECT_EQ(flown.counters().late, 1u);
  EXPECT_EQ(flown.at(0.5).p_W, path.at(0.5).p_W);
  EXPECT_GT((flown.at(0.7).p_W - path.at(0.7).p_W).norm(), 0.01);
}

TEST(FlownVehicle, ALaterCommandReplacesTheRestOfTheSchedule) {
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle replaced(path, config.response, kGravity), direct(path, config.response, kGravity);
  replaced.command(0, {0, 5, 0});
  replaced.command(from_seconds(0.4), {0, 0, 0});
  replaced.command(from_seconds(0.2), {3, 0, 0});  // drops the zero at 0.4
  direct.command(0, {0, 5, 0});
  direct.command(from_seconds(0.2), {3, 0, 0});
  replaced.advance_to(0.8);
  direct.advance_to(0.8);
  EXPECT_EQ(replaced.at(0.8).p_W, direct.at(0.8).p_W);
}

TEST(FlownVehicle, ANonFiniteCommandIsAnError) {
  const VehicleConfig config = still_hover();
  const VehicleTrajectory path(config, 1, kGravity);
  FlownVehicle flown(path, config.response, kGravity);
  EXPECT_THROW(flown.command(0, {std::nan(""), 0, 0}), ConfigError);
}

/// A small scene with a ball and depth, IMU noise off.
ScenarioConfig small_throw() {
  ScenarioConfig c = make_preset("hover_headon", 2);
  set_event_resolution(c, 64, 48);
  c.depth_camera.width = 64, c.depth_camera.height = 48;
  c.depth_camera.fx = c.depth_camera.fy = 38.6, c.depth_camera.cx = 32, c.depth_camera.cy = 24;
  c.duration_s = 0.6;
  c.threads = 2;
  return c;
}

TEST(SimFlight, ACommandedRunWithoutCommandsRendersExactlyAsThePathRun) {
  const ScenarioConfig c = small_throw();
  MemorySink path_run, commanded;
  Simulator(c).run(path_run);
  Simulator sim(c);
  sim.begin(commanded, Flight::kCommanded);
  int steps = 0;
  while (sim.step()) ++steps;
  sim.finish();
  EXPECT_EQ(steps, static_cast<int>(std::lround(c.duration_s / c.event_camera.chunk_s)));
  ASSERT_EQ(commanded.events.size(), path_run.events.size());
  EXPECT_TRUE(commanded.events == path_run.events);
  EXPECT_TRUE(commanded.labels == path_run.labels);
  ASSERT_EQ(commanded.imu.size(), path_run.imu.size());
  for (std::size_t i = 0; i < commanded.imu.size(); ++i)
    EXPECT_EQ(commanded.imu[i].accel_m_s2, path_run.imu[i].accel_m_s2);
  ASSERT_EQ(commanded.body_unflown.size(), path_run.body.size());
  ASSERT_EQ(commanded.body.size(), path_run.body.size());
  for (std::size_t i = 0; i < commanded.body.size(); ++i) {
    EXPECT_EQ(commanded.body[i].p_W_B, path_run.body[i].p_W_B);
    EXPECT_EQ(commanded.body_unflown[i].p_W_B, path_run.body[i].p_W_B);
  }
  EXPECT_TRUE(path_run.body_unflown.empty());  // only a commanded run emits it
}

// A fork at 0.25 s commanded to dodge renders what one run given the same command renders, and
// the run it was forked from goes on as if there had been no fork. The scene has every random
// stream on (pixel noise, IMU and odometry noise, depth noise) and two threads.
TEST(SimFlight, AForkFliesItsCommandExactlyAsOneRunWouldAndLeavesTheOriginalAsItWas) {
  const ScenarioConfig c = small_throw();
  const TimeNs fork_t = from_seconds(0.25), command_t = from_seconds(0.3);
  const Eigen::Vector3d dodge(0, 6, 0);

  MemorySink one_run;
  Simulator reference(c);
  reference.begin(one_run, Flight::kCommanded);
  while (reference.simulated_until() < fork_t) reference.step();
  reference.command(command_t, dodge);
  while (reference.step()) {
  }
  const SimulationSummary reference_summary = reference.finish();

  MemorySink original_sink;
  Simulator original(c);
  original.begin(original_sink, Flight::kCommanded);
  while (original.simulated_until() < fork_t) original.step();
  MemorySink fork_sink = original_sink;  // the fork's streams carry on from what was rendered
  Simulator fork(original, fork_sink);
  EXPECT_EQ(fork.simulated_until(), original.simulated_until());
  fork.command(command_t, dodge);
  while (fork.step()) {
  }
  const SimulationSummary fork_summary = fork.finish();
  test::expect_same_streams(fork_sink, one_run);
  EXPECT_EQ(fork_summary.events, reference_summary.events);
  EXPECT_EQ(fork_summary.imu, reference_summary.imu);
  EXPECT_EQ(fork_summary.flight.commands, 1u);
  EXPECT_GT(fork_sink.body.back().p_W_B.y() - fork_sink.body_unflown.back().p_W_B.y(), 0.05);

  while (original.step()) {
  }
  EXPECT_EQ(original.finish().flight.commands, 0u);
  MemorySink path_run;
  Simulator(c).run(path_run);
  path_run.body_unflown = path_run.body;  // a path run has no unflown path: it is its path
  test::expect_same_streams(original_sink, path_run);
}

TEST(SimFlight, OnlyARunCanBeForked) {
  const Simulator idle(test::still_scene(32, 24, 0.02));
  MemorySink sink;
  EXPECT_THROW(Simulator(idle, sink), ConfigError);
}

TEST(SimFlight, CallsOutOfOrderAreErrors) {
  Simulator sim(test::still_scene(32, 24, 0.02));
  MemorySink sink;
  EXPECT_THROW(sim.step(), ConfigError);
  EXPECT_THROW(sim.finish(), ConfigError);
  sim.begin(sink);  // a path run takes no command
  EXPECT_THROW(sim.command(0, {0, 1, 0}), ConfigError);
  EXPECT_THROW(sim.begin(sink), ConfigError);
  while (sim.step()) {
  }
  EXPECT_FALSE(sim.step());
  EXPECT_EQ(sim.finish().truth, 21u);  // 0, 1, ..., 20 ms
}

TEST(SimFlight, TheIMUReadsTheSteadyTiltOfALateralCommand) {
  ScenarioConfig c = test::still_scene(32, 24, 1.2);
  c.imu.gyro_noise_density = c.imu.accel_noise_density = 0;
  c.imu.gyro_random_walk = c.imu.accel_random_walk = 0;
  c.imu.gyro_bias_sigma = c.imu.accel_bias_sigma = 0;
  const double a = 6.0, t_cmd = 0.2;
  // A second at 6 m/s² sideways: wide enough a room that no wall brakes it (6 m/s needs 3.7 m).
  c.scene.room_min_W_m.y() = -50, c.scene.room_max_W_m.y() = 50;
  Simulator sim(c);
  MemorySink sink;
  sim.begin(sink, Flight::kCommanded);
  while (sim.simulated_until() < from_seconds(0.1)) sim.step();
  sim.command(from_seconds(t_cmd), {0, a, 0});  // ahead of what is rendered: not late
  while (sim.step()) {
  }
  const SimulationSummary summary = sim.finish();
  EXPECT_EQ(summary.flight.commands, 1u);
  EXPECT_EQ(summary.flight.late, 0u);
  // The gyro integrated over the manoeuvre: the tilt reached, about the body x axis.
  Eigen::Vector3d turned = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i < sink.imu.size(); ++i)
    turned += sink.imu[i - 1].gyro_rad_s * to_seconds(sink.imu[i].t - sink.imu[i - 1].t);
  EXPECT_NEAR(turned.norm(), std::atan(a / 9.81), 0.01);
  // The accelerometer, settled: the thrust alone, sqrt(a² + g²) along the IMU's z axis.
  const ImuSample& last = sink.imu.back();
  EXPECT_NEAR(last.accel_m_s2.norm(), std::hypot(a, 9.81), 1e-4);  // e^-12 of the step left
  EXPECT_NEAR(std::abs(last.accel_m_s2.z()), std::hypot(a, 9.81), 1e-4);
  // The truth: the same tilt, and the vehicle left its path.
  const Eigen::Quaterniond q = sink.body.back().q_W_B;
  EXPECT_NEAR(std::acos(q.toRotationMatrix().col(2).z()), std::atan(a / 9.81), 1e-4);
  EXPECT_GT(sink.body.back().p_W_B.y() - sink.body_unflown.back().p_W_B.y(), 1.0);
}

}  // namespace
}  // namespace fdv::sim
