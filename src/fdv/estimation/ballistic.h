#pragma once
/// The object's trajectory model (paper eq. 11): free flight under known gravity, no drag,
///   p(t) = p0 + v0·(t - t0) + ½·g·(t - t0)²,   in the world frame W [m, m/s, m/s²].
///
///   BallisticTrajectory traj{t0, p0_W, v0_W, {0, 0, -9.81}};
///   Eigen::Vector3d p = traj.position(t);         // t in ns, any time (past or future)
///   BallisticTrajectory same = traj.anchored_at(t1);  // same curve, parameters at t1
///
/// Thread-safe (value type).
#include <Eigen/Core>

#include "fdv/core/time.h"

namespace fdv {

struct BallisticTrajectory {
  TimeNs t0 = 0;
  Eigen::Vector3d p0_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d v0_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d gravity_W = Eigen::Vector3d(0, 0, -9.81);

  Eigen::Vector3d position(TimeNs t) const {
    const double tau = to_seconds(t - t0);
    return p0_W + tau * v0_W + 0.5 * tau * tau * gravity_W;
  }
  Eigen::Vector3d velocity(TimeNs t) const { return v0_W + to_seconds(t - t0) * gravity_W; }
  /// The same curve with its parameters given at t (p0 = p(t), v0 = v(t)).
  BallisticTrajectory anchored_at(TimeNs t) const {
    return {t, position(t), velocity(t), gravity_W};
  }
};

}  // namespace fdv
