#pragma once
// Small scenes for the simulator tests.
#include "fdv/sim/scenario_config.h"

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

}  // namespace fdv::sim::test
