#pragma once
/// The vehicle as it flies: its path (VehicleTrajectory) plus the deviation that commanded
/// accelerations add, flown by a quadrotor model (docs/SIMULATOR.md "Flying a manoeuvre").
///
///   FlownVehicle vehicle(path, config.vehicle.response, config.gravity_W_m_s2);
///   vehicle.command(from_seconds(0.45), {0, 8, 0});   // from 0.45 s on: 8 m/s² to the left
///   vehicle.command(from_seconds(0.85), {0, 0, 0});   // from 0.85 s on: back to the path's own
///   vehicle.advance_to(t1);                           // integrate before rendering up to t1
///   BodyState s = vehicle.at(t);                      // any t <= t1
///
/// Model. The commanded acceleration a_c is on top of the path's own. Its thrust direction
/// n_c = (a_c − g) / |a_c − g| (tilted at most max_tilt_deg from vertical) is followed by the
/// flown thrust direction n with a first-order lag: n turns towards n_c about n × n_c at
/// angle(n, n_c) / τ, at most max_body_rate_rad_s. The collective thrust holds the commanded
/// vertical acceleration, T = (a_c·u + |g|) / (n·u) with u the vertical, so the deviation's
/// acceleration is T n + g: a lateral command is reached as the vehicle tilts, atan(|a_c|/|g|) in
/// steady state. The tilt R_Δ (n = R_Δ u) rotates the path's own attitude: R_W_B = R_Δ R_W_B,path.
/// Near min_height_m a descent is braked (at up to |g|, from when half of that is needed to stop
/// at the floor), and at the floor a downward command is dropped; max_height_m is a ceiling with
/// the same rule upside down (braking a climb at up to |g| is cutting the thrust). The room's
/// sides (x and y), less wall_margin_m, are walls with the same rule, braking by a tilt.
///
/// A command takes effect from its time on and replaces every command scheduled at or after it.
/// A command earlier than the integrated horizon takes effect at the horizon (counted as late).
/// Before the first command takes effect, and with none, at() is the path exactly. The deviation
/// is integrated on a grid of step_s from the first command's time (a later command acts from
/// the first grid node at or after its time); between nodes position and velocity are cubic
/// Hermite, the tilt exact for the step's constant rate.
/// Thread safety: at() is const and may run on many threads; command() and advance_to() must not
/// run concurrently with it.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <vector>

#include "fdv/core/time.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/trajectory.h"

namespace fdv::sim {

/// What the vehicle model had to change in the commands it was given.
struct FlightCounters {
  std::uint64_t commands = 0;      ///< commands given
  std::uint64_t tilt_clipped = 0;  ///< commands whose thrust tilt exceeded max_tilt_deg
  std::uint64_t late = 0;          ///< commands for a time already integrated
  std::uint64_t floor_holds = 0;   ///< times the floor stopped a descent
  std::uint64_t ceiling_holds = 0;  ///< times the ceiling stopped a climb
  std::uint64_t wall_holds = 0;     ///< times a wall stopped a sideways motion
};

class FlownVehicle {
 public:
  /// `room`: the scene's room (scene.room_min_W_m / room_max_W_m), whose sides are walls; empty
  /// (the default): none.
  FlownVehicle(const VehicleTrajectory& path, const VehicleResponseConfig& response,
               const Eigen::Vector3d& gravity_W, const Eigen::AlignedBox3d& room = {});
  /// `state`'s vehicle as it is now (its commands and integrated deviation), flying on `path`
  /// (equal to the one `state` flies on): a fork of a run.
  FlownVehicle(const FlownVehicle& state, const VehicleTrajectory& path);

  /// Commanded acceleration `a_W` on top of the path's from `t` on. Throws ConfigError for a
  /// non-finite acceleration.
  void command(TimeNs t, const Eigen::Vector3d& a_W);
  /// Integrates the deviation up to `t_s` (the horizon: later commands act from there on).
  void advance_to(double t_s);
  /// The flown state at `t_s`, which must not exceed the last advance_to() once a command has
  /// taken effect.
  BodyState at(double t_s) const;
  /// The path's state at `t_s`: where the vehicle would have been without any command.
  BodyState unflown_at(double t_s) const { return path_->at(t_s); }
  /// True once a command has taken effect (the flown path may differ from the path).
  bool deviates_at(double t_s) const { return !nodes_.empty() && t_s > t0_s_; }
  const FlightCounters& counters() const { return counters_; }

 private:
  FlownVehicle(const FlownVehicle&) = default;  // only through the fork above

  /// The deviation from the path at a grid node. Over the step after it the acceleration runs
  /// linearly from `a` to `a + da` and the tilt turns at the constant rate `w_W`.
  struct Node {
    Eigen::Vector3d p = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
    Eigen::Vector3d a = Eigen::Vector3d::Zero(), da = Eigen::Vector3d::Zero();
    Eigen::Vector3d w_W = Eigen::Vector3d::Zero();
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  ///< R_Δ
  };
  /// The command in force over the step starting at node `k`, with the height band and the
  /// walls applied.
  Eigen::Vector3d command_at(std::size_t k);
  /// The acceleration left of `away` (along one axis, positive away from the limit) by one
  /// limit: the floor, the ceiling or a wall. `holding` is that limit's state, `holds` its counter.
  double hold_at_limit(double gap, double approach, double away, bool& holding,
                       std::uint64_t& holds) const;
  /// n_c, clipped to the tilt limit.
  Eigen::Vector3d thrust_direction(const Eigen::Vector3d& a_c) const;
  /// T n + g for command `a_c` with the tilt `q`.
  Eigen::Vector3d deviation_acceleration(const Eigen::Vector3d& a_c,
                                         const Eigen::Quaterniond& q) const;
  double node_time(std::size_t k) const { return t0_s_ + step_s_ * static_cast<double>(k); }

  const VehicleTrajectory* path_;  ///< not owned (a pointer, so that a fork can fly its own copy)
  VehicleResponseConfig response_;
  Eigen::Vector3d gravity_, up_;
  double step_s_;
  double t0_s_ = 0;       ///< the first command's time: node 0
  double horizon_s_ = 0;  ///< the last advance_to()
  std::vector<Node> nodes_;
  std::map<TimeNs, Eigen::Vector3d> commands_;  ///< by the time each takes effect
  Eigen::AlignedBox3d room_;
  bool floor_holding_ = false, ceiling_holding_ = false;
  bool wall_holding_[2][2] = {};  ///< [x, y][the room's min side, its max side]
  FlightCounters counters_;
};

}  // namespace fdv::sim
