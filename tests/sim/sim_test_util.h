#pragma once
// Small scenes for the simulator tests, and a comparison of simulated streams.
#include <gtest/gtest.h>

#include "fdv/sim/scenario_config.h"
#include "fdv/sim/simulator.h"

namespace fdv::sim::test {

constexpr double kDeg = 3.141592653589793 / 180.0;  ///< radians per degree

/// A camera that does not move at all (constant motion with zero rates), no ball, no depth,
/// no noise, at a small resolution with the default field of view.
inline ScenarioConfig still_scene(int width = 64, int height = 48, double duration_s = 0.2) {
  ScenarioConfig c;
  c.name = "still";
  c.duration_s = duration_s;
  c.vehicle.motion = MotionKind::kConstant;
  c.vehicle.start_W_m = {0.0, 0.0, 1.5};
  c.depth_camera.enabled = false;
  c.event_camera.background_rate_hz = 0;
  c.event_camera.hot_pixel_fraction = 0;
  set_event_resolution(c, width, height);
  return c;
}

/// Every stream of `a` equals `b`'s, sample by sample and bit for bit.
inline void expect_same_streams(const MemorySink& a, const MemorySink& b) {
  EXPECT_TRUE(a.events == b.events);
  EXPECT_TRUE(a.labels == b.labels);
  ASSERT_EQ(a.imu.size(), b.imu.size());
  for (std::size_t i = 0; i < a.imu.size(); ++i) {
    EXPECT_EQ(a.imu[i].t, b.imu[i].t);
    EXPECT_EQ(a.imu[i].gyro_rad_s, b.imu[i].gyro_rad_s);
    EXPECT_EQ(a.imu[i].accel_m_s2, b.imu[i].accel_m_s2);
  }
  ASSERT_EQ(a.depth.size(), b.depth.size());
  for (std::size_t i = 0; i < a.depth.size(); ++i) {
    EXPECT_EQ(a.depth[i].t, b.depth[i].t);
    EXPECT_TRUE(a.depth[i].depth_m == b.depth[i].depth_m) << "depth frame " << i;
  }
  auto same_poses = [](const std::vector<OdometrySample>& x, const std::vector<OdometrySample>& y) {
    ASSERT_EQ(x.size(), y.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      EXPECT_EQ(x[i].t, y[i].t);
      EXPECT_EQ(x[i].p_W_B, y[i].p_W_B);
      EXPECT_EQ(x[i].q_W_B.coeffs(), y[i].q_W_B.coeffs());
      EXPECT_EQ(x[i].v_W, y[i].v_W);
    }
  };
  same_poses(a.odometry, b.odometry);
  same_poses(a.body, b.body);
  same_poses(a.body_unflown, b.body_unflown);
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (std::size_t i = 0; i < a.objects.size(); ++i) EXPECT_EQ(a.objects[i].p_W, b.objects[i].p_W);
}

}  // namespace fdv::sim::test
