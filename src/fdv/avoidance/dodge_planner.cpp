#include "fdv/avoidance/dodge_planner.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include "fdv/core/error.h"

namespace fdv {

namespace {

/// Candidates whose expected clearances differ by less than this are equal [m]: the quadrature's
/// noise is far below it, and a millimetre of clearance means nothing to a vehicle.
constexpr double kClearanceTie_m = 1e-4;

std::string bad_probability(const char* key, double p) {
  return fmt::format("{} must be in [0, 1] (got {})", key, p);
}
bool is_probability(double p) { return p >= 0 && p <= 1; }

std::string bad_duration(const char* key, double s) {
  return std::isfinite(s) && s >= 0 ? std::string() : fmt::format("{} must be finite and >= 0 (got {})", key, s);
}

/// Why `risk` or `vehicle` cannot be decided on; empty when both are finite.
std::string non_finite(const CollisionRisk& risk, const VehicleState& vehicle) {
  const OdometrySample& o = vehicle.odometry;
  if (!o.p_W_B.allFinite() || !o.v_W.allFinite() || !o.q_W_B.coeffs().allFinite())
    return "non-finite vehicle state (position, velocity or attitude)";
  if (!vehicle.covariance.allFinite()) return "non-finite vehicle state covariance";
  const ClosestApproach& c = risk.nominal.closest;
  if (!std::isfinite(risk.probability) || !is_probability(risk.probability))
    return fmt::format("risk probability {} is not in [0, 1]", risk.probability);
  if (!c.object_W.allFinite() || !c.vehicle_W.allFinite() || !std::isfinite(c.time_from_now_s) ||
      !std::isfinite(c.miss_distance_m) || std::isnan(risk.nominal.time_to_contact_s))
    return "non-finite nominal closest approach";
  if (!risk.closest_offset_covariance_W.allFinite() || !std::isfinite(risk.miss_distance_sigma_m))
    return "non-finite closest-approach covariance";
  if (!risk.relative_velocity_W.allFinite()) return "non-finite relative velocity";
  if (risk.relative_velocity_W.norm() < 1e-9) return "zero relative velocity: no passage to dodge";
  return {};
}

/// Orthonormal basis (rows) of the plane normal to the relative velocity: the first axis
/// horizontal when the relative velocity is not vertical, the second then pointing up.
Eigen::Matrix<double, 2, 3> dodge_plane(const Eigen::Vector3d& relative_velocity_W) {
  const Eigen::Vector3d n = relative_velocity_W.normalized();
  Eigen::Vector3d e1 = n.cross(Eigen::Vector3d::UnitZ());
  if (e1.norm() < 1e-6) e1 = n.cross(Eigen::Vector3d::UnitX());
  e1.normalize();
  Eigen::Vector3d e2 = e1.cross(n);
  if (e2.z() < 0) e2 = -e2;
  Eigen::Matrix<double, 2, 3> E;
  E.row(0) = e1.transpose();
  E.row(1) = e2.transpose();
  return E;
}

/// The gravity the thrust works against: W's z axis is up.
constexpr double kGravity_m_s2 = 9.81;

/// The largest acceleration s along unit `u` whose thrust f = s·u + |g|·up tilts at most θ from up.
/// Along that ray the tilt grows with s towards u's own angle α from up, so only α > θ caps s: in
/// the triangle (0, |g|·up, f) the law of sines gives s ≤ |g| sin θ / sin(α − θ). Straight down
/// (α = π) that is |g| for any θ: free fall, no thrust.
double max_acceleration_by_tilt(const Eigen::Vector3d& u, double max_tilt_deg) {
  const double theta = max_tilt_deg * std::numbers::pi / 180;
  const double alpha = std::acos(std::clamp(u.z(), -1.0, 1.0));
  if (alpha <= theta) return std::numeric_limits<double>::infinity();
  return kGravity_m_s2 * std::sin(theta) / std::sin(alpha - theta);
}

/// The largest acceleration along unit `u` within the limits: the norm, each axis, the thrust
/// tilt, and the floor and ceiling (the height at the manoeuvre's end, `end_s` from now, with the
/// current vertical velocity).
double max_acceleration_along(const Eigen::Vector3d& u, const VehicleLimits& limits, const OdometrySample& vehicle,
                              double end_s) {
  double a = std::min(limits.max_acceleration_m_s2, max_acceleration_by_tilt(u, limits.max_tilt_deg));
  for (int i = 0; i < 3; ++i)
    if (std::abs(u(i)) > 0) a = std::min(a, limits.max_acceleration_per_axis_m_s2(i) / std::abs(u(i)));
  const double held_s = std::max(0.0, end_s - limits.response_delay_s);
  if (u.z() != 0 && held_s > 0) {
    const double drifted_m = vehicle.p_W_B.z() + vehicle.v_W.z() * end_s;
    const double room_m =
        u.z() < 0 ? drifted_m - limits.min_height_m : limits.max_height_m - drifted_m;
    a = std::min(a, std::max(0.0, room_m) / (0.5 * std::abs(u.z()) * held_s * held_s));
  }
  return a;
}

/// E·Δ, the body's displacement in the dodge plane `after_delay_s` after the set-point `a` takes
/// effect: its vertical part at once (a quadrotor changes its collective thrust without turning),
/// its horizontal part only after the attitude lag (it must tilt first), as a further delay.
/// Written as the whole of `a` at once minus what the lag holds back, exactly zero without a lag.
Eigen::Vector2d displacement_in_plane(const Eigen::Matrix<double, 2, 3>& E, const Eigen::Vector3d& a,
                                      double after_delay_s, double attitude_lag_s) {
  const double at_once_s2 = 0.5 * std::pow(std::max(0.0, after_delay_s), 2);
  const double held_back_s2 = at_once_s2 - 0.5 * std::pow(std::max(0.0, after_delay_s - attitude_lag_s), 2);
  return E * a * at_once_s2 - E * Eigen::Vector3d(a.x(), a.y(), 0) * held_back_s2;
}

/// The time after the delay by which the displacement of `a` (in the plane of E, where `a` lies)
/// reaches `clear_m`: it grows with time, reaching it between sqrt(2·clear/|a|) (all of `a`
/// vertical) and the attitude lag later (all horizontal).
double time_to_displace(const Eigen::Matrix<double, 2, 3>& E, const Eigen::Vector3d& a, double clear_m,
                        double attitude_lag_s) {
  const double direct_s = std::sqrt(2 * clear_m / a.norm());
  double lo = direct_s, hi = direct_s + attitude_lag_s;
  for (int i = 0; i < 60 && hi - lo > 1e-12; ++i) {
    const double mid = 0.5 * (lo + hi);
    (displacement_in_plane(E, a, mid, attitude_lag_s).norm() < clear_m ? lo : hi) = mid;
  }
  return hi;
}

/// Nodes of the angular rule below: its error on a kinked integrand (a near-degenerate Gaussian
/// far from the origin) is O(1/N²), below 1e-5 relative at 256; smooth ones converge exponentially.
constexpr int kCauchyNodes = 256;

/// E|x| for x ~ N(mean, covariance) in the plane, by Cauchy's formula |x| = ¼ ∮ |x·e(φ)| dφ: the
/// expectation of each projection is that of a 1D Gaussian, s·sqrt(2/π)·exp(-m²/2s²) + m·erf(m/s√2),
/// and the periodic integral over φ is a trapezoidal sum. Agrees with gaussian_expected_norm
/// (adaptive quadrature, ~1000x slower). The directions e(φ) and the projected σ s = sqrt(e·Σe)
/// depend on the covariance alone: made once, they serve every candidate's mean.
class ExpectedNorm {
 public:
  explicit ExpectedNorm(const Eigen::Matrix2d& covariance) {
    for (int k = 0; k < kCauchyNodes; ++k) {
      const double phi = std::numbers::pi * k / kCauchyNodes;  // half the circle: |x·e| is even in φ + π
      e_[k] = Eigen::Vector2d(std::cos(phi), std::sin(phi));
      s_[k] = std::sqrt(std::max(0.0, e_[k].dot(covariance * e_[k])));
    }
  }
  double operator()(const Eigen::Vector2d& mean) const {
    double sum = 0;
    for (int k = 0; k < kCauchyNodes; ++k) {
      const double m = mean.dot(e_[k]), s = s_[k];
      sum += s > 1e-12
                 ? s * std::sqrt(2 / std::numbers::pi) * std::exp(-0.5 * m * m / (s * s)) +
                       m * std::erf(m / (s * std::numbers::sqrt2))
                 : std::abs(m);
    }
    return 0.5 * std::numbers::pi * sum / kCauchyNodes;
  }

 private:
  std::array<Eigen::Vector2d, kCauchyNodes> e_;
  std::array<double, kCauchyNodes> s_;
};

}  // namespace

const char* to_string(DodgeAction a) {
  switch (a) {
    case DodgeAction::kDodge: return "dodge";
    case DodgeAction::kReplan: return "replan";
    case DodgeAction::kCommit: return "commit";
    case DodgeAction::kCancel: return "cancel";
    case DodgeAction::kRefused: return "refused";
  }
  return "?";
}

std::string VehicleLimits::validate() const {
  if (!std::isfinite(max_acceleration_m_s2) || !(max_acceleration_m_s2 > 0))
    return fmt::format("max_acceleration_m_s2 must be finite and > 0 (got {})", max_acceleration_m_s2);
  for (int i = 0; i < 3; ++i)
    if (!(max_acceleration_per_axis_m_s2(i) > 0))
      return fmt::format("max_acceleration_per_axis_m_s2[{}] must be > 0 (got {})", i,
                         max_acceleration_per_axis_m_s2(i));
  if (auto err = bad_duration("response_delay_s", response_delay_s); !err.empty()) return err;
  if (auto err = bad_duration("attitude_lag_s", attitude_lag_s); !err.empty()) return err;
  if (std::isnan(min_height_m)) return "min_height_m must be a number (got nan)";
  if (!(max_height_m > min_height_m))
    return fmt::format("max_height_m must be above min_height_m ({}) (got {})", min_height_m,
                       max_height_m);
  if (!(max_tilt_deg > 0 && max_tilt_deg <= 180))
    return fmt::format("max_tilt_deg must be in (0, 180] (got {})", max_tilt_deg);
  return {};
}

std::string DodgeOptions::validate() const {
  if (auto err = limits.validate(); !err.empty()) return "limits." + err;
  for (const auto& [key, p] : {std::pair{"act_probability", act_probability},
                               std::pair{"late_probability", late_probability},
                               std::pair{"cancel_probability", cancel_probability}})
    if (!is_probability(p)) return bad_probability(key, p);
  if (!(cancel_probability < late_probability && late_probability <= act_probability))
    return fmt::format("cancel_probability < late_probability <= act_probability must hold (got {}, {}, {})",
                       cancel_probability, late_probability, act_probability);
  for (const auto& [key, s] : {std::pair{"late_margin_s", late_margin_s}, std::pair{"commit_margin_s", commit_margin_s},
                               std::pair{"duration_margin_s", duration_margin_s},
                               std::pair{"clear_sigmas", clear_sigmas}})
    if (auto err = bad_duration(key, s); !err.empty()) return err;
  if (!(replan_angle_deg > 0 && replan_angle_deg <= 180))
    return fmt::format("replan_angle_deg must be in (0, 180] (got {})", replan_angle_deg);
  if (!std::isfinite(replan_gain_m) || replan_gain_m < 0)
    return fmt::format("replan_gain_m must be finite and >= 0 (got {})", replan_gain_m);
  if (!(replan_probability_step > 0 && replan_probability_step <= 1))
    return fmt::format("replan_probability_step must be in (0, 1] (got {})", replan_probability_step);
  if (directions < 4 || directions > 3600)
    return fmt::format("directions must be in [4, 3600] (got {})", directions);
  if (!(max_horizon_sigma_m > 0 && std::isfinite(max_horizon_sigma_m)))
    return fmt::format("max_horizon_sigma_m must be finite and > 0 (got {})", max_horizon_sigma_m);
  return {};
}

DodgePlan plan_dodge(const CollisionRisk& risk, const VehicleState& vehicle, const DodgeOptions& options,
                     double safety_radius_m, const std::optional<Eigen::Vector3d>& in_force) {
  const VehicleLimits& limits = options.limits;
  const ClosestApproach& closest = risk.nominal.closest;
  const double R = safety_radius_m;
  const double delay_s = limits.response_delay_s;
  const double closest_s = std::max(0.0, closest.time_from_now_s);
  const double end_s = closest_s + options.duration_margin_s;

  // The miss vector at the closest approach in the plane normal to the relative velocity: its
  // mean and covariance. A manoeuvre moving the body by Δ by then shifts the mean by −Δ.
  const Eigen::Matrix<double, 2, 3> E = dodge_plane(risk.relative_velocity_W);
  const Eigen::Vector2d miss = E * (closest.object_W - closest.vehicle_W);
  const Eigen::Matrix2d miss_cov = E * risk.closest_offset_covariance_W * E.transpose();
  // Δ by the closest approach, the attitude lag delaying its horizontal part (VehicleLimits).
  const double after_delay_s = closest_s - delay_s, lag_s = limits.attitude_lag_s;

  const ExpectedNorm expected_norm(miss_cov);
  std::vector<Eigen::Vector3d> candidates(options.directions);
  std::vector<double> scores(options.directions);
  for (int k = 0; k < options.directions; ++k) {
    const double theta = 2 * std::numbers::pi * k / options.directions;
    const Eigen::Vector3d u = std::cos(theta) * E.row(0).transpose() + std::sin(theta) * E.row(1).transpose();
    candidates[k] = max_acceleration_along(u, limits, vehicle.odometry, end_s) * u;
    scores[k] = expected_norm(miss - displacement_in_plane(E, candidates[k], after_delay_s, lag_s)) - R;
  }
  // Near-ties (e.g. a dead-ahead threat with isotropic uncertainty) go to the most upward
  // direction: away from the ground, as the paper's hovering vehicle does.
  const double best_score = *std::max_element(scores.begin(), scores.end());
  Eigen::Vector3d best_a = Eigen::Vector3d::Zero();
  double best_z = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < options.directions; ++k) {
    if (scores[k] >= best_score - kClearanceTie_m && candidates[k].z() > best_z + 1e-9) {
      best_a = candidates[k];
      best_z = best_a.z();
    }
  }
  // Hysteresis: the candidate nearest the direction in force stays unless the best beats it by
  // replan_gain_m.
  if (in_force && in_force->norm() > 0) {
    int nearest = 0;
    for (int k = 1; k < options.directions; ++k)
      if (candidates[k].normalized().dot(*in_force) > candidates[nearest].normalized().dot(*in_force)) nearest = k;
    if (candidates[nearest].norm() > 0 && scores[nearest] >= best_score - options.replan_gain_m)
      best_a = candidates[nearest];
  }
  DodgePlan plan;
  DodgeManeuver& m = plan.maneuver;
  m.acceleration_W = best_a;
  m.start_t = vehicle.odometry.t + from_seconds(delay_s);
  m.duration_s = std::max(0.0, end_s - delay_s);
  const Eigen::Vector2d shifted = miss - displacement_in_plane(E, best_a, after_delay_s, lag_s);
  m.expected_clearance_m = expected_norm(shifted) - R;
  m.probability_after = gaussian_disc_probability(shifted, miss_cov, R);

  // The trigger: t_c against the time needed to put the passage outside the sphere.
  plan.time_to_act_on_s = risk.nominal.contact ? std::max(0.0, risk.nominal.time_to_contact_s) : closest_s;
  plan.clear_m = std::max(0.0, R + options.clear_sigmas * risk.miss_distance_sigma_m - miss.norm());
  const double accel = best_a.norm();
  plan.time_needed_s = plan.clear_m == 0 ? delay_s
                       : accel > 0       ? delay_s + time_to_displace(E, best_a, plan.clear_m, lag_s)
                                         : std::numeric_limits<double>::infinity();
  const double p = risk.probability;
  const double t_c = plan.time_to_act_on_s;
  plan.commit = t_c <= plan.time_needed_s + options.commit_margin_s;
  const std::string figures = fmt::format("t_c {:.3f} s, t_need {:.3f} s (clear {:.2f} m at {:.1f} m/s²)", t_c,
                                          plan.time_needed_s, plan.clear_m, accel);
  if (closest.receding) {
    plan.why = fmt::format("p {:.3f} but the object recedes", p);
  } else if (p >= options.act_probability) {
    plan.trigger = true;
    plan.why = fmt::format("p {:.3f} >= act {:.2f}; {}", p, options.act_probability, figures);
  } else if (p >= options.late_probability && t_c <= plan.time_needed_s + options.late_margin_s) {
    plan.trigger = true;
    plan.why = fmt::format("p {:.3f} >= late {:.2f} and {} <= t_need + {:.2f} s", p, options.late_probability,
                           figures, options.late_margin_s);
  } else {
    plan.why = fmt::format("p {:.3f}; {}", p, figures);
  }
  return plan;
}

bool may_trigger(const CollisionRisk& risk, const DodgeOptions& options) {
  const double p = risk.probability;
  return !risk.nominal.closest.receding && (p >= options.act_probability || p >= options.late_probability);
}

DodgePlanner::DodgePlanner(DodgeOptions options, double safety_radius_m)
    : options_(std::move(options)), safety_radius_m_(safety_radius_m) {
  if (auto err = options_.validate(); !err.empty()) throw ConfigError("DodgeOptions: " + err);
  if (!std::isfinite(safety_radius_m_) || !(safety_radius_m_ >= 0))
    throw ConfigError(fmt::format("DodgePlanner: safety_radius_m must be finite and >= 0 (got {})", safety_radius_m_));
}

DodgeDecision DodgePlanner::decide(DodgeAction action, int track_id, const CollisionRisk& risk, TimeNs t,
                                   const DodgePlan& plan, std::optional<DodgeManeuver> maneuver,
                                   std::string reason) const {
  DodgeDecision d;
  d.t = t;
  d.track_id = track_id;
  d.action = action;
  d.probability = risk.probability;
  d.time_to_contact_s = risk.nominal.time_to_contact_s;
  d.miss_distance_m = risk.nominal.closest.miss_distance_m;
  d.maneuver = std::move(maneuver);
  d.reason = std::move(reason);
  d.effective_t = t + from_seconds(options_.limits.response_delay_s);
  d.time_needed_s = plan.time_needed_s;
  if (d.maneuver) {
    const DodgeManeuver& m = *d.maneuver;
    d.reason += fmt::format("; a [{:.2f}, {:.2f}, {:.2f}] m/s² for {:.3f} s, E clearance {:.3f} m, p after {:.3f}",
                            m.acceleration_W.x(), m.acceleration_W.y(), m.acceleration_W.z(), m.duration_s,
                            m.expected_clearance_m, m.probability_after);
  }
  return d;
}

std::optional<DodgeDecision> DodgePlanner::update(int track_id, const CollisionRisk& risk,
                                                  const VehicleState& vehicle) {
  const TimeNs t = vehicle.odometry.t;
  auto refuse = [&](std::string why) {
    DodgeDecision d;
    d.t = t;
    d.track_id = track_id;
    d.action = DodgeAction::kRefused;
    // The risk's figures where finite (0 and infinity stand for the others: rows hold no NaN).
    d.probability = std::isfinite(risk.probability) ? risk.probability : 0.0;
    d.time_to_contact_s = std::isnan(risk.nominal.time_to_contact_s) ? std::numeric_limits<double>::infinity()
                                                                      : risk.nominal.time_to_contact_s;
    d.miss_distance_m = std::isfinite(risk.nominal.closest.miss_distance_m) ? risk.nominal.closest.miss_distance_m : 0.0;
    if (active_) d.maneuver = active_->maneuver;
    d.committed = active_ && active_->committed;
    d.reason = std::move(why);
    d.effective_t = t;
    return d;
  };
  if (auto why = non_finite(risk, vehicle); !why.empty()) return refuse(why);
  if (last_t_ && t < *last_t_)
    return refuse(fmt::format("vehicle state at {:.6f} s is older than the previous update's ({:.6f} s)",
                              to_seconds(t), to_seconds(*last_t_)));
  last_t_ = t;
  last_probability_[track_id] = risk.probability;

  // A manoeuvre that has run its course is no longer in force.
  if (active_ && active_->maneuver &&
      t >= active_->maneuver->start_t + from_seconds(active_->maneuver->duration_s))
    active_.reset();
  if (active_ && active_->committed) return std::nullopt;
  // The plan (72 candidates' expected clearances) only where it can change the outcome.
  if ((!active_ || active_->track_id != track_id) && !may_trigger(risk, options_)) return std::nullopt;

  const DodgePlan plan = plan_dodge(risk, vehicle, options_, safety_radius_m_,
                                    active_ && active_->track_id == track_id && active_->maneuver
                                        ? std::optional<Eigen::Vector3d>(active_->maneuver->acceleration_W)
                                        : std::nullopt);
  auto set = [&](DodgeAction action, std::string reason) {
    DodgeDecision d = decide(action, track_id, risk, t, plan, plan.maneuver, std::move(reason));
    d.committed = plan.commit;
    if (plan.commit) d.reason += "; committed (t_c <= t_need + commit margin)";
    active_ = d;
    return d;
  };

  if (!active_) {
    if (!plan.trigger) return std::nullopt;
    return set(DodgeAction::kDodge, plan.why);
  }
  const int active_track = active_->track_id;
  if (track_id != active_track) {
    const double active_p = last_probability_[active_track];
    if (!plan.trigger || !(risk.probability > active_p)) return std::nullopt;
    return set(DodgeAction::kReplan, fmt::format("track {} (p {:.3f}) is more threatening than track {} (p {:.3f}); {}",
                                                 track_id, risk.probability, active_track, active_p, plan.why));
  }
  if (risk.probability < options_.cancel_probability) {
    DodgeDecision d = decide(DodgeAction::kCancel, track_id, risk, t, plan, std::nullopt,
                             fmt::format("p {:.3f} < cancel {:.2f}", risk.probability, options_.cancel_probability));
    active_.reset();
    return d;
  }
  const Eigen::Vector3d& a_old = active_->maneuver->acceleration_W;
  const Eigen::Vector3d& a_new = plan.maneuver.acceleration_W;
  const double cos_angle = a_old.norm() > 0 && a_new.norm() > 0 ? a_old.dot(a_new) / (a_old.norm() * a_new.norm()) : 1.0;
  const double angle_deg = std::acos(std::clamp(cos_angle, -1.0, 1.0)) * 180 / std::numbers::pi;
  const double dp = std::abs(risk.probability - active_->probability);
  std::string replan_why;
  if (angle_deg > options_.replan_angle_deg)
    replan_why = fmt::format("direction moved {:.0f} deg > {:.0f}", angle_deg, options_.replan_angle_deg);
  else if (dp >= options_.replan_probability_step)
    replan_why = fmt::format("p moved {:.3f} -> {:.3f}", active_->probability, risk.probability);

  if (plan.commit) {
    if (!replan_why.empty()) return set(DodgeAction::kCommit, replan_why + ", re-planned; " + plan.why);
    DodgeDecision d = decide(DodgeAction::kCommit, track_id, risk, t, plan, active_->maneuver,
                             "t_c <= t_need + commit margin: holding the manoeuvre; " + plan.why);
    d.committed = true;
    d.effective_t = active_->effective_t;
    active_ = d;
    return d;
  }
  if (!replan_why.empty()) return set(DodgeAction::kReplan, replan_why + "; " + plan.why);
  return std::nullopt;
}

}  // namespace fdv
