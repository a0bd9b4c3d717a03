#pragma once
/// Pieces the presets share (presets.cpp, random_throw.cpp): the panel layout and a ball's spin.
///
///   Rng rng = Rng::stream(seed, RngStream::kScenario, 1);
///   add_panels(config, rng, /*x_side_min=*/12.0, /*x_overhead_min=*/12.0);
///   ball.spin_W_rad_s = random_spin(rng);
#include <Eigen/Core>

#include "fdv/sim/random.h"
#include "fdv/sim/scenario_config.h"

namespace fdv::sim {

/// Free-standing panels facing the flight direction (+x), left, right of or above the flight
/// corridor (|y| < 1.2 m, z < 2.7 m stays free), plus banners on the side walls. Side panels
/// start at x_side_min so that they never hide a ball crossing nearer than that.
void add_panels(ScenarioConfig& c, Rng& rng, double x_side_min, double x_overhead_min);
/// A spin of 8-20 rad/s about a uniformly random axis [rad/s, W].
Eigen::Vector3d random_spin(Rng& rng);

}  // namespace fdv::sim
