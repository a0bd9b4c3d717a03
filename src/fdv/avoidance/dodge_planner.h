#pragma once
/// The dodge decision (paper §V-D): when to act on a collision risk, and the escape manoeuvre, an
/// acceleration set-point with a duration, that maximises the expected clearance within the
/// vehicle's limits.
///
///   DodgeOptions o;  o.limits.max_acceleration_m_s2 = 10;  o.limits.response_delay_s = 0.05;
///   DodgePlanner planner(o, prediction_options.safety_radius_m);   // one per vehicle
///   RiskAssessment r = assess_collision_risk(estimate, vehicle, prediction_options);
///   if (r.risk)
///     if (auto d = planner.update(track_id, *r.risk, vehicle)) send_setpoint(d->maneuver);
///
/// Trigger: act when the probability reaches act_probability, or late_probability once the time to
/// contact t_c is within late_margin_s of the time the vehicle needs to clear the sphere, t_need.
/// Re-planning: until the commit, each update of the active track may replace the manoeuvre
/// (direction moved by more than replan_angle_deg, or probability by replan_probability_step) or
/// cancel it (probability below cancel_probability). Commit rule: once t_c <= t_need +
/// commit_margin_s there is no time left to change, so the manoeuvre in force is held to its end
/// and updates return nothing until then. Several tracks: the planner acts on the most threatening
/// (highest probability) one. Details and the reasons for each threshold: docs/AVOIDANCE.md.
/// Not thread-safe.
#include <Eigen/Core>
#include <limits>
#include <map>
#include <optional>
#include <string>

#include "fdv/core/time.h"
#include "fdv/estimation/collision.h"
#include "fdv/estimation/collision_risk.h"

namespace fdv {

/// What the vehicle can do.
struct VehicleLimits {
  /// Largest acceleration the dodge may command, as the norm of the set-point [m/s²] (the dodge
  /// evaluation's default lateral limit).
  double max_acceleration_m_s2 = 10.0;
  /// Per world axis (x, y, z) as well [m/s²]. The default, 1000 m/s² (100 g), leaves only the norm
  /// limit; it is finite so that a written configuration loads again (infinity is accepted too).
  Eigen::Vector3d max_acceleration_per_axis_m_s2 = Eigen::Vector3d::Constant(1e3);
  /// From the decision to the set-point taking effect [s].
  double response_delay_s = 0.05;
  /// The time constant of the vehicle's thrust tilt [s]: a quadrotor reaches a horizontal
  /// acceleration only by tilting, a first-order lag that for a small tilt costs the position
  /// what a further delay of this much would, while its collective thrust changes the vertical
  /// acceleration at once. Planned as such: a further delay of the horizontal part of the
  /// displacement the manoeuvre gains, and so of t_need (not of its start). 0: a vehicle that
  /// accelerates at once, as the kinematic replay of `fdv dodge-eval` assumes; the simulator's
  /// is 0.08 s.
  double attitude_lag_s = 0.0;
  /// Forbidden: any downward component that would bring the body below this height in W's z by
  /// the end of the manoeuvre [m]. The default, -1000 m, is no floor (-infinity is accepted too).
  double min_height_m = -1e3;
  /// Forbidden likewise: any upward component that would bring the body above this height [m].
  /// The default, 1000 m, is no ceiling (+infinity is accepted too).
  double max_height_m = 1e3;
  /// Largest tilt of the thrust from the vertical [deg]: a quadrotor accelerates by a = f + g with
  /// its thrust f along its body z axis, so each direction's acceleration is capped where f would
  /// tilt further (W's z axis up, |g| = 9.81 m/s²). 180: no cap, a vehicle that can thrust any way
  /// (also downward faster than g); the simulator's quadrotor tilts at most 60.
  double max_tilt_deg = 180.0;
  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): YAML section `dodge.limits`.
template <class V>
void describe(V& v, VehicleLimits& o) {
  v("max_acceleration_m_s2", o.max_acceleration_m_s2, "m/s²", "largest commanded acceleration (norm)");
  v("max_acceleration_per_axis_m_s2", o.max_acceleration_per_axis_m_s2, "m/s²",
    "largest commanded acceleration along W's x, y, z (1000 = none)");
  v("response_delay_s", o.response_delay_s, "s", "from the decision to the set-point taking effect");
  v("attitude_lag_s", o.attitude_lag_s, "s", "thrust tilt time constant, planned as a further delay of the horizontal part (0 = none)");
  v("min_height_m", o.min_height_m, "m", "no downward manoeuvre below this height in W (-1000 = no floor)");
  v("max_height_m", o.max_height_m, "m",
    "no upward manoeuvre above this height in W (1000 = no ceiling)");
  v("max_tilt_deg", o.max_tilt_deg, "deg", "largest thrust tilt from the vertical (180 = none)");
}

struct DodgeOptions {
  VehicleLimits limits;
  /// Trigger: act at once from this probability of entering the safety sphere (even odds).
  double act_probability = 0.5;
  /// Trigger: act from this lower probability once waiting longer would make the escape
  /// impossible (t_c <= t_need + late_margin_s).
  double late_probability = 0.15;
  /// How long before the last moment the late trigger fires [s]: a few estimator updates.
  double late_margin_s = 0.1;
  /// t_need is the time to gain radius + clear_sigmas·σ_miss − the nominal miss at the maneuver's
  /// acceleration, plus the response delay.
  double clear_sigmas = 1.0;
  /// Commit once t_c <= t_need + commit_margin_s [s]: a changed set-point would take effect too
  /// late to help (about one response delay).
  double commit_margin_s = 0.05;
  /// Cancel an uncommitted manoeuvre when the active track's probability drops below this.
  double cancel_probability = 0.05;
  /// Re-plan when the best direction moves by more than this [deg] ...
  double replan_angle_deg = 20.0;
  /// ... where a new direction is best only when its expected clearance beats that of the
  /// direction in force by this much [m]: near a tie (a dead-centre throw) the estimate's jitter
  /// would otherwise swing the set-point from side to side and waste the time it has.
  double replan_gain_m = 0.1;
  /// ... or the probability changes by at least this since the manoeuvre was set.
  double replan_probability_step = 0.2;
  /// The manoeuvre is held until the nominal closest approach plus this [s].
  double duration_margin_s = 0.1;
  /// Candidate directions, evenly spaced in the plane normal to the relative velocity.
  int directions = 72;
  /// Estimates decided on: the usable ones, and also converged ones whose only fault is a
  /// position σ at the usable horizon above estimation.max_position_sigma_m, up to this [m]. The
  /// risk's probability weighs that σ, so a wide estimate acts only on a likely contact.
  double max_horizon_sigma_m = 3.0;
  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): YAML section `dodge`.
template <class V>
void describe(V& v, DodgeOptions& o) {
  v.section("limits", o.limits, "what the vehicle can do");
  v("act_probability", o.act_probability, "-", "act at once from this probability of contact");
  v("late_probability", o.late_probability, "-", "act from this probability when time runs out");
  v("late_margin_s", o.late_margin_s, "s", "late trigger: t_c <= t_need + this");
  v("clear_sigmas", o.clear_sigmas, "-", "t_need clears radius + this many σ of the miss distance");
  v("commit_margin_s", o.commit_margin_s, "s", "commit: t_c <= t_need + this");
  v("cancel_probability", o.cancel_probability, "-", "cancel an uncommitted manoeuvre below this probability");
  v("replan_angle_deg", o.replan_angle_deg, "deg", "re-plan when the best direction moves more than this");
  v("replan_gain_m", o.replan_gain_m, "m", "a new direction is best only when it adds this much expected clearance");
  v("replan_probability_step", o.replan_probability_step, "-", "re-plan when the probability moves this much");
  v("duration_margin_s", o.duration_margin_s, "s", "hold the set-point until the closest approach + this");
  v("directions", o.directions, "-", "candidate directions in the plane normal to the relative velocity");
  v("max_horizon_sigma_m", o.max_horizon_sigma_m, "m",
    "also decide on converged estimates not usable only for a horizon σ up to this");
}

/// An acceleration set-point held for a duration, starting after the response delay.
struct DodgeManeuver {
  Eigen::Vector3d acceleration_W = Eigen::Vector3d::Zero();  ///< [m/s²], within the limits
  TimeNs start_t = 0;      ///< decision time + response delay
  double duration_s = 0;   ///< how long the set-point is held
  /// Predicted, under the risk's Gaussian: the expected clearance (E|miss| - radius) and the
  /// probability of still entering the safety sphere with the manoeuvre.
  double expected_clearance_m = 0;
  double probability_after = 0;
};

enum class DodgeAction {
  kDodge,    ///< first trigger: start the manoeuvre
  kReplan,   ///< a new manoeuvre replaces the active one (not yet committed)
  kCommit,   ///< the active manoeuvre is held to its end from now on
  kCancel,   ///< the threat went away before the commit: set-point back to zero
  kRefused,  ///< no decision possible (bad input): reason says why
};
const char* to_string(DodgeAction a);

/// One decision: a row of dodge.jsonl.
struct DodgeDecision {
  TimeNs t = 0;  ///< time of the vehicle state the decision was made on
  int track_id = -1;
  DodgeAction action = DodgeAction::kDodge;
  double probability = 0;        ///< the risk's probability
  double time_to_contact_s = 0;  ///< nominal; infinity when the mean misses
  double miss_distance_m = 0;    ///< nominal
  /// The set-point in force after this decision (none after kCancel; a kRefused row leaves the
  /// one in force unchanged and repeats it).
  std::optional<DodgeManeuver> maneuver;
  bool committed = false;
  std::string reason;  ///< why this decision, in words (thresholds and figures)
  /// When the decision's change of set-point takes effect: t + response delay.
  TimeNs effective_t = 0;
  /// t_need: the response delay, the attitude lag and the time to clear the sphere at the
  /// manoeuvre's acceleration [s]; infinity when the manoeuvre cannot clear it.
  double time_needed_s = 0;
};

/// What the planner computes from one risk, before its state (trigger, re-plan, commit) is applied.
struct DodgePlan {
  DodgeManeuver maneuver;  ///< the best manoeuvre, were the decision made now
  /// t_c: the nominal time to contact, or to the closest approach when the mean misses [s].
  double time_to_act_on_s = 0;
  double clear_m = 0;        ///< radius + clear_sigmas·σ_miss − nominal miss, at least 0 [m]
  double time_needed_s = 0;  ///< t_need = delay + attitude lag + sqrt(2·clear_m / |a|) [s]
  bool trigger = false;      ///< the trigger policy says act
  bool commit = false;       ///< t_c <= t_need + commit_margin_s
  std::string why;           ///< the trigger's figures in words
};

/// The plan for `risk` at `vehicle` (pure): the manoeuvre maximising the expected clearance over
/// options.directions candidates, and the trigger figures. `risk` and `vehicle` must be finite.
/// `in_force`: the acceleration of the manoeuvre in force, if any; its direction is kept unless
/// the best beats it by options.replan_gain_m.
DodgePlan plan_dodge(const CollisionRisk& risk, const VehicleState& vehicle, const DodgeOptions& options,
                     double safety_radius_m, const std::optional<Eigen::Vector3d>& in_force = std::nullopt);

/// Whether plan_dodge's trigger can be set for `risk`, whatever the manoeuvre: the object does not
/// recede and its probability reaches act_probability or late_probability. When not, a planner
/// with no manoeuvre in force (or one for another track) decides nothing and needs no plan.
bool may_trigger(const CollisionRisk& risk, const DodgeOptions& options);

class DodgePlanner {
 public:
  /// Throws ConfigError when the options (limits) or the radius are invalid. `safety_radius_m` must
  /// be the PredictionOptions' the risks are computed with.
  explicit DodgePlanner(DodgeOptions options, double safety_radius_m = PredictionOptions{}.safety_radius_m);

  /// One risk of one track at vehicle state `vehicle` (time-ordered per planner). Returns a
  /// decision when one is made (trigger, re-plan, commit, cancel, refusal), nothing otherwise.
  /// A non-finite risk or state, or a state older than the previous one, gives kRefused.
  std::optional<DodgeDecision> update(int track_id, const CollisionRisk& risk, const VehicleState& vehicle);

  /// The manoeuvre in force, if any.
  const std::optional<DodgeDecision>& active() const { return active_; }
  const DodgeOptions& options() const { return options_; }

 private:
  DodgeDecision decide(DodgeAction action, int track_id, const CollisionRisk& risk, TimeNs t,
                       const DodgePlan& plan, std::optional<DodgeManeuver> maneuver, std::string reason) const;

  DodgeOptions options_;
  double safety_radius_m_;
  std::optional<DodgeDecision> active_;
  std::map<int, double> last_probability_;  ///< per track, its latest risk's probability
  std::optional<TimeNs> last_t_;
};

}  // namespace fdv
