#include "fdv/avoidance/maneuver_playback.h"

#include <algorithm>
#include <limits>
#include <vector>

namespace fdv {

namespace {

/// Acceleration `a` over [from, to).
struct Piece {
  TimeNs from = 0, to = 0;
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
};

/// Nothing set from `t` on: later pieces go, a piece spanning `t` ends there.
void clear_from(std::vector<Piece>& pieces, TimeNs t) {
  std::erase_if(pieces, [t](const Piece& p) { return p.from >= t; });
  for (Piece& p : pieces) p.to = std::min(p.to, t);
}

}  // namespace

ManeuverOffset commanded_offset(std::span<const DodgeDecision> decisions, TimeNs t) {
  std::vector<Piece> pieces;
  for (const DodgeDecision& d : decisions) {
    if (d.action == DodgeAction::kRefused) continue;
    if (d.action == DodgeAction::kCancel || !d.maneuver) {
      // A decision rebuilt from a row without effective_t (0) takes effect at its own time.
      clear_from(pieces, std::max(d.effective_t, d.t));
      continue;
    }
    const DodgeManeuver& m = *d.maneuver;
    clear_from(pieces, m.start_t);
    pieces.push_back({m.start_t, m.start_t + from_seconds(m.duration_s), m.acceleration_W});
  }
  ManeuverOffset out;
  for (const Piece& p : pieces) {
    if (t <= p.from || p.to <= p.from) continue;
    const double held_s = to_seconds(std::min(t, p.to) - p.from);
    const double coast_s = to_seconds(t - std::min(t, p.to));
    out.velocity_W += p.a * held_s;
    out.position_W += p.a * (0.5 * held_s * held_s + held_s * coast_s);
  }
  return out;
}

}  // namespace fdv
