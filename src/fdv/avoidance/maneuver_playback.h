#pragma once
/// The vehicle's acceleration set-point commanded by a sequence of dodge decisions: as the
/// changes a vehicle controller receives (to fly them: `fdv simulate --fly`, the closed loop),
/// and as the motion they add to the path the vehicle would have flown without them (replaying
/// the decisions kinematically against the truth: `fdv dodge-eval`).
///
///   std::vector<DodgeDecision> decisions = ...;        // in the order the planner made them
///   for (const SetpointChange& c : setpoint_schedule(decisions)) vehicle.command(c.t, c.acceleration_W);
///   ManeuverOffset o = commanded_offset(decisions, t);
///   Eigen::Vector3d body_W = scripted_p_W_B(t) + o.position_W;
///
/// Model: a piecewise-constant acceleration set-point on top of the path. A decision carrying a
/// manoeuvre (kDodge, kReplan, kCommit) sets its acceleration from maneuver.start_t and zero
/// after duration_s (the velocity gained is kept). kCancel sets zero from its effective_t (t +
/// response delay; t when effective_t is unset, i.e. earlier than t); kRefused changes nothing.
/// Each change replaces whatever was set from its time on. The offset is zero before the first
/// set-point takes effect. Thread-safe (pure).
#include <Eigen/Core>
#include <span>
#include <vector>

#include "fdv/avoidance/dodge_planner.h"
#include "fdv/core/time.h"

namespace fdv {

/// From `t` on, the set-point is `acceleration_W` (until the next change).
struct SetpointChange {
  TimeNs t = 0;
  Eigen::Vector3d acceleration_W = Eigen::Vector3d::Zero();  ///< [m/s²] on top of the path
};

/// The changes one decision makes, in time order; each replaces everything set from its time on.
std::vector<SetpointChange> setpoint_changes(const DodgeDecision& decision);

/// The set-point over time that `decisions` (in decision order) leave: changes in time order.
std::vector<SetpointChange> setpoint_schedule(std::span<const DodgeDecision> decisions);

struct ManeuverOffset {
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Vector3d velocity_W = Eigen::Vector3d::Zero();  ///< [m/s]
};

/// The displacement and velocity at `t` that `decisions` (in decision order) add to the path,
/// integrating the set-point exactly.
ManeuverOffset commanded_offset(std::span<const DodgeDecision> decisions, TimeNs t);

}  // namespace fdv
