#pragma once
/// The vehicle's motion commanded by a sequence of dodge decisions, relative to the path it would
/// have flown without them: for replaying the decisions against the truth (`fdv dodge-eval`).
///
///   std::vector<DodgeDecision> decisions = ...;        // in the order the planner made them
///   ManeuverOffset o = commanded_offset(decisions, t);
///   Eigen::Vector3d body_W = scripted_p_W_B(t) + o.position_W;
///
/// Model: piecewise-constant acceleration, integrated exactly. A decision carrying a manoeuvre
/// (kDodge, kReplan, kCommit) sets its acceleration from maneuver.start_t for duration_s, replacing
/// whatever was set from then on; after the duration the acceleration is zero (the velocity gained
/// is kept). kCancel sets zero from its effective_t (t + response delay; t when effective_t is
/// unset, i.e. earlier than t); kRefused changes nothing.
/// The offset is zero before the first set-point takes effect. Thread-safe (pure).
#include <Eigen/Core>
#include <span>

#include "fdv/avoidance/dodge_planner.h"
#include "fdv/core/time.h"

namespace fdv {

struct ManeuverOffset {
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Vector3d velocity_W = Eigen::Vector3d::Zero();  ///< [m/s]
};

/// The displacement and velocity at `t` that `decisions` (in decision order) add to the path.
ManeuverOffset commanded_offset(std::span<const DodgeDecision> decisions, TimeNs t);

}  // namespace fdv
