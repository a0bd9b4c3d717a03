#include "fdv/avoidance/maneuver_playback.h"

#include <algorithm>

namespace fdv {

std::vector<SetpointChange> setpoint_changes(const DodgeDecision& d) {
  if (d.action == DodgeAction::kRefused) return {};
  // A decision rebuilt from a row without effective_t (0) takes effect at its own time.
  const Eigen::Vector3d none = Eigen::Vector3d::Zero();
  if (d.action == DodgeAction::kCancel || !d.maneuver) return {{std::max(d.effective_t, d.t), none}};
  const DodgeManeuver& m = *d.maneuver;
  return {{m.start_t, m.acceleration_W}, {m.start_t + from_seconds(m.duration_s), none}};
}

std::vector<SetpointChange> setpoint_schedule(std::span<const DodgeDecision> decisions) {
  std::vector<SetpointChange> schedule;
  for (const DodgeDecision& d : decisions)
    for (const SetpointChange& c : setpoint_changes(d)) {
      std::erase_if(schedule, [&](const SetpointChange& s) { return s.t >= c.t; });
      schedule.push_back(c);
    }
  return schedule;
}

ManeuverOffset commanded_offset(std::span<const DodgeDecision> decisions, TimeNs t) {
  const std::vector<SetpointChange> schedule = setpoint_schedule(decisions);
  ManeuverOffset out;
  for (std::size_t i = 0; i < schedule.size(); ++i) {
    const TimeNs from = schedule[i].t;
    const TimeNs to = i + 1 < schedule.size() ? schedule[i + 1].t : t;
    if (t <= from || to <= from) continue;
    const double held_s = to_seconds(std::min(t, to) - from);
    const double coast_s = to_seconds(t - std::min(t, to));
    out.velocity_W += schedule[i].acceleration_W * held_s;
    out.position_W += schedule[i].acceleration_W * (0.5 * held_s * held_s + held_s * coast_s);
  }
  return out;
}

}  // namespace fdv
