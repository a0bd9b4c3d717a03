#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "fdv/avoidance/dodge_planner.h"
#include "fdv/avoidance/maneuver_playback.h"
#include "fdv/core/error.h"
#include "fdv/core/options_yaml.h"

namespace fdv {
namespace {

constexpr double kR = 0.5;           // safety radius [m]
constexpr double kClosing = 10.0;    // closing speed along W's -x [m/s]
const Eigen::Vector3d kBody(0, 0, 1);  // hovering 1 m up

TimeNs at(double s) { return from_seconds(s); }

VehicleState hovering(double t_s) {
  VehicleState v;
  v.odometry.t = at(t_s);
  v.odometry.p_W_B = kBody;
  return v;
}

/// A ball coming head-on along W's -x, passing with mean offset `miss_W` (normal to x) from the
/// body `closest_s` from now, with an isotropic position uncertainty `sigma_m` at the closest
/// approach and the given probability (set by hand: the planner takes it as given).
CollisionRisk threat(const Eigen::Vector3d& miss_W, double closest_s, double sigma_m, double probability,
                     double now_s = 1.0) {
  CollisionRisk r;
  ClosestApproach& c = r.nominal.closest;
  c.time_from_now_s = closest_s;
  c.t = at(now_s + closest_s);
  c.vehicle_W = kBody;
  c.object_W = kBody + miss_W;
  c.miss_distance_m = miss_W.norm();
  if (c.miss_distance_m < kR) {
    r.nominal.time_to_contact_s =
        closest_s - std::sqrt(kR * kR - c.miss_distance_m * c.miss_distance_m) / kClosing;
    r.nominal.contact = at(now_s + r.nominal.time_to_contact_s);
  }
  r.probability = probability;
  r.closest_offset_covariance_W = sigma_m * sigma_m * Eigen::Matrix3d::Identity();
  r.miss_distance_sigma_m = sigma_m;
  r.relative_velocity_W = Eigen::Vector3d(-kClosing, 0, 0);
  return r;
}

/// E|x| of a 2D isotropic Gaussian N(ν, σ² I): the Rice distribution's mean,
/// σ sqrt(π/2) L½(-ν²/2σ²), with L½(x) = e^(x/2) [(1 - x) I0(-x/2) - x I1(-x/2)].
double rice_mean(double nu, double sigma) {
  const double x = -nu * nu / (2 * sigma * sigma);
  const double l_half = std::exp(x / 2) * ((1 - x) * std::cyl_bessel_i(0.0, -x / 2) - x * std::cyl_bessel_i(1.0, -x / 2));
  return sigma * std::sqrt(std::numbers::pi / 2) * l_half;
}

// Dead ahead, isotropic: every direction normal to the relative velocity is as good; the manoeuvre
// is normal to it at the full limit (the tie goes up), and its expected clearance is the Rice mean
// of the miss shifted by the displacement ½ a (t_ca − delay)².
TEST(DodgePlan, DeadAheadIsPerpendicularAtTheLimitAndScoredByTheRiceMean) {
  const DodgeOptions o;
  const DodgePlan plan = plan_dodge(threat(Eigen::Vector3d::Zero(), 0.35, 0.2, 0.9), hovering(1.0), o, kR);
  const Eigen::Vector3d& a = plan.maneuver.acceleration_W;
  EXPECT_NEAR(a.x(), 0.0, 1e-12);
  EXPECT_NEAR(a.norm(), 10.0, 1e-9);
  EXPECT_NEAR(a.z(), 10.0, 1e-9);
  const double displacement_m = 0.5 * 10.0 * 0.3 * 0.3;  // 0.45 m
  EXPECT_NEAR(plan.maneuver.expected_clearance_m, rice_mean(displacement_m, 0.2) - kR, 1e-6);
  // Before the manoeuvre, centred: P = 1 − exp(−R²/2σ²) = 0.956; after, about half of it.
  EXPECT_LT(plan.maneuver.probability_after, 0.6);
  EXPECT_GT(plan.maneuver.probability_after, 0.4);
  EXPECT_EQ(plan.maneuver.start_t, at(1.05));
  EXPECT_NEAR(plan.maneuver.duration_s, 0.35 + 0.1 - 0.05, 1e-12);
  EXPECT_TRUE(plan.trigger);
}

// The vehicle's attitude lag delays the horizontal part of a manoeuvre only: a quadrotor must tilt
// to accelerate sideways, while its collective thrust moves it up or down at once. Sideways (the
// vertical axis limited to nothing), a dead-ahead threat with a 0.08 s lag gains ½ a (t_ca − delay
// − lag)² and needs 0.08 s more; free to climb, it climbs, gaining ½ a (t_ca − delay)² and needing
// no more time than without a lag. The set-point starts after the response delay alone.
TEST(DodgePlan, TheAttitudeLagDelaysTheHorizontalPartOnly) {
  const CollisionRisk dead_ahead = threat(Eigen::Vector3d::Zero(), 0.35, 0.2, 0.9);
  DodgeOptions o;
  o.limits.max_acceleration_per_axis_m_s2.z() = 1e-9;
  const DodgePlan sideways = plan_dodge(dead_ahead, hovering(1.0), o, kR);
  o.limits.attitude_lag_s = 0.08;
  const DodgePlan sideways_lag = plan_dodge(dead_ahead, hovering(1.0), o, kR);
  EXPECT_NEAR(std::abs(sideways_lag.maneuver.acceleration_W.y()), 10.0, 1e-6);
  EXPECT_NEAR(sideways_lag.maneuver.expected_clearance_m, rice_mean(0.5 * 10.0 * 0.22 * 0.22, 0.2) - kR, 1e-6);
  EXPECT_NEAR(sideways_lag.time_needed_s - sideways.time_needed_s, 0.08, 1e-9);
  EXPECT_EQ(sideways_lag.maneuver.start_t, at(1.05));

  o.limits.max_acceleration_per_axis_m_s2.z() = 1e3;
  const DodgePlan climb_lag = plan_dodge(dead_ahead, hovering(1.0), o, kR);
  o.limits.attitude_lag_s = 0;
  const DodgePlan climb = plan_dodge(dead_ahead, hovering(1.0), o, kR);
  EXPECT_TRUE(climb_lag.maneuver.acceleration_W.isApprox(Eigen::Vector3d(0, 0, 10), 1e-9));
  EXPECT_NEAR(climb_lag.maneuver.expected_clearance_m, rice_mean(0.5 * 10.0 * 0.30 * 0.30, 0.2) - kR, 1e-6);
  EXPECT_NEAR(climb_lag.time_needed_s, climb.time_needed_s, 1e-9);

  o.limits.attitude_lag_s = -0.1;
  EXPECT_NE(o.validate().find("attitude_lag_s"), std::string::npos);
}

// A manoeuvre partly sideways, partly down (the vertical axis limited to 6 m/s²): the time it
// needs lies between none and all of the lag, where the displacement, vertical at once and
// horizontal after the lag, first reaches the gap.
TEST(DodgePlan, TheTimeNeededOfAMixedManoeuvreSolvesTheSplitDisplacement) {
  const CollisionRisk up_left = threat({0, 0.15, 0.15}, 0.5, 0.05, 0.9);
  DodgeOptions o;
  o.limits.attitude_lag_s = 0.08;
  o.limits.max_acceleration_per_axis_m_s2.z() = 6;
  const DodgePlan plan = plan_dodge(up_left, hovering(1.0), o, kR);
  const Eigen::Vector3d a = plan.maneuver.acceleration_W;
  ASSERT_LT(a.y(), -1.0);
  ASSERT_LT(a.z(), -1.0);
  const double T = plan.time_needed_s - 0.05;  // after the response delay
  const double sideways_m = 0.5 * std::hypot(a.x(), a.y()) * std::pow(T - 0.08, 2);
  const double down_m = 0.5 * std::abs(a.z()) * T * T;
  EXPECT_NEAR(std::hypot(sideways_m, down_m), plan.clear_m, 1e-9);
  const double direct_s = std::sqrt(2 * plan.clear_m / a.norm());
  EXPECT_GT(T, direct_s + 0.01) << a.transpose();
  EXPECT_LT(T, direct_s + 0.08 - 0.01);
}

// Anisotropic and degenerate uncertainty: the clearance the planner reports is the adaptive
// quadrature's (gaussian_expected_norm) at the chosen manoeuvre, and no direction between the
// planner's candidates does better by that measure.
TEST(DodgePlan, ExpectedClearanceAgreesWithTheQuadratureAndIsMaximal) {
  const DodgeOptions o;
  struct Case {
    Eigen::Vector3d miss;
    double sigma_y, sigma_z;
  };
  for (const Case& c : {Case{{0, 0.1, 0.1}, 0.4, 0.05}, Case{{0, 0.3, -0.1}, 0.02, 0.6},
                        Case{{0, 0.05, 0.0}, 0.3, 0.0}, Case{{0, 0.8, 0.6}, 0.01, 0.01}}) {
    CollisionRisk r = threat(c.miss, 0.4, 0.1, 0.7);
    r.closest_offset_covariance_W = Eigen::Vector3d(0.01, c.sigma_y * c.sigma_y, c.sigma_z * c.sigma_z).asDiagonal();
    const DodgePlan plan = plan_dodge(r, hovering(1.0), o, kR);
    const double lever_s2 = 0.5 * 0.35 * 0.35;
    const Eigen::Matrix2d cov = r.closest_offset_covariance_W.bottomRightCorner<2, 2>();
    auto clearance = [&](const Eigen::Vector3d& a) {
      return gaussian_expected_norm((c.miss - a * lever_s2).tail<2>(), cov) - kR;
    };
    const Eigen::Vector3d& a = plan.maneuver.acceleration_W;
    EXPECT_NEAR(plan.maneuver.expected_clearance_m, clearance(a), 1e-5) << c.miss.transpose();
    EXPECT_NEAR(plan.maneuver.probability_after,
                gaussian_disc_probability((c.miss - a * lever_s2).tail<2>(), cov, kR), 1e-9);
    for (int k = 0; k < 36; ++k) {
      const double theta = 2 * std::numbers::pi * (k + 0.25) / 36;
      EXPECT_LT(clearance(10 * Eigen::Vector3d(0, std::cos(theta), std::sin(theta))), clearance(a) + 2e-3)
          << c.miss.transpose() << " at " << theta;
    }
  }
}

// A ball passing 0.2 m to the left (+y, the vehicle facing +x): the dodge goes right.
TEST(DodgePlan, PassageToTheLeftDodgesRight) {
  const DodgePlan plan = plan_dodge(threat({0, 0.2, 0}, 0.4, 0.15, 0.8), hovering(1.0), DodgeOptions{}, kR);
  EXPECT_TRUE(plan.maneuver.acceleration_W.isApprox(Eigen::Vector3d(0, -10, 0), 1e-9))
      << plan.maneuver.acceleration_W.transpose();
  // Moving 0.6125 m away from a 0.2 m miss: 0.8125 m, beyond R.
  EXPECT_NEAR(plan.maneuver.expected_clearance_m, rice_mean(0.2 + 0.5 * 10 * 0.35 * 0.35, 0.15) - kR, 1e-6);
}

// A ball passing 0.2 m above: the dodge goes down, unless min_height forbids it; a lower floor
// allows the part of the descent it leaves room for.
TEST(DodgePlan, MinHeightForbidsDown) {
  const CollisionRisk r = threat({0, 0, 0.2}, 0.4, 0.15, 0.8);
  DodgeOptions o;
  EXPECT_TRUE(plan_dodge(r, hovering(1.0), o, kR).maneuver.acceleration_W.isApprox(Eigen::Vector3d(0, 0, -10), 1e-9));

  o.limits.min_height_m = 1.0;  // the current height: no descent at all
  const Eigen::Vector3d a = plan_dodge(r, hovering(1.0), o, kR).maneuver.acceleration_W;
  EXPECT_GE(a.z(), -1e-9) << a.transpose();
  EXPECT_NEAR(a.norm(), 10.0, 1e-9);

  o.limits.min_height_m = 0.8;  // 0.2 m of room by the manoeuvre's end, 0.45 s from now
  const DodgePlan plan = plan_dodge(r, hovering(1.0), o, kR);
  const double held_s = 0.4 + 0.1 - 0.05;
  const double z_end = kBody.z() + 0.5 * plan.maneuver.acceleration_W.z() * held_s * held_s;
  EXPECT_LT(plan.maneuver.acceleration_W.z(), 0.0);
  EXPECT_GE(z_end, 0.8 - 1e-9);

  // A vehicle already sinking at 1 m/s towards a floor 0.3 m below: no room to go down.
  VehicleState sinking = hovering(1.0);
  sinking.odometry.v_W = {0, 0, -1};
  o.limits.min_height_m = 0.7;
  EXPECT_GE(plan_dodge(r, sinking, o, kR).maneuver.acceleration_W.z(), -1e-9);
}

// The same ball passing 0.2 m below: the dodge goes up, unless max_height forbids it; a higher
// ceiling allows the part of the climb it leaves room for.
TEST(DodgePlan, MaxHeightForbidsUp) {
  const CollisionRisk r = threat({0, 0, -0.2}, 0.4, 0.15, 0.8);
  DodgeOptions o;
  EXPECT_TRUE(plan_dodge(r, hovering(1.0), o, kR)
                  .maneuver.acceleration_W.isApprox(Eigen::Vector3d(0, 0, 10), 1e-9));

  o.limits.max_height_m = kBody.z();  // the current height: no climb at all
  const Eigen::Vector3d a = plan_dodge(r, hovering(1.0), o, kR).maneuver.acceleration_W;
  EXPECT_LE(a.z(), 1e-9) << a.transpose();
  EXPECT_NEAR(a.norm(), 10.0, 1e-9);

  o.limits.max_height_m = kBody.z() + 0.2;  // 0.2 m of room by the manoeuvre's end
  const DodgePlan plan = plan_dodge(r, hovering(1.0), o, kR);
  const double held_s = 0.4 + 0.1 - 0.05;
  const double z_end = kBody.z() + 0.5 * plan.maneuver.acceleration_W.z() * held_s * held_s;
  EXPECT_GT(plan.maneuver.acceleration_W.z(), 0.0);
  EXPECT_LE(z_end, kBody.z() + 0.2 + 1e-9);

  // A vehicle already climbing at 1 m/s towards a ceiling 0.3 m above: no room to go up.
  VehicleState climbing = hovering(1.0);
  climbing.odometry.v_W = {0, 0, 1};
  o.limits.max_height_m = kBody.z() + 0.3;
  EXPECT_LE(plan_dodge(r, climbing, o, kR).maneuver.acceleration_W.z(), 1e-9);
}

// A per-axis limit of 3 m/s² on y: the passage is to the left, the dodge still goes right, within
// 3 m/s² on y and 10 m/s² in norm, and uses z for the rest.
TEST(DodgePlan, PerAxisLimitRespected) {
  DodgeOptions o;
  o.limits.max_acceleration_per_axis_m_s2 = {std::numeric_limits<double>::infinity(), 3.0,
                                             std::numeric_limits<double>::infinity()};
  const Eigen::Vector3d a = plan_dodge(threat({0, 0.2, 0}, 0.4, 0.15, 0.8), hovering(1.0), o, kR).maneuver.acceleration_W;
  EXPECT_LE(std::abs(a.y()), 3.0 + 1e-9);
  EXPECT_LE(a.norm(), 10.0 + 1e-9);
  EXPECT_LT(a.y(), 0.0);
  EXPECT_GT(std::abs(a.z()), 1.0);
}

/// The angle of the thrust f = a − g from the vertical for a commanded acceleration a [deg].
double thrust_tilt_deg(const Eigen::Vector3d& a) {
  const Eigen::Vector3d f = a - Eigen::Vector3d(0, 0, -9.81);
  return std::atan2(f.head<2>().norm(), f.z()) * 180 / std::numbers::pi;
}

// A quadrotor's thrust tilt (VehicleLimits::max_tilt_deg). Straight down it can only fall (|g|),
// which still beats any other dodge of a ball passing just above. Sideways 10 m/s² tilts 45.55°,
// within 60°: nothing changes. A passage up and to the left asks for a dodge down and to the
// right, whose full 10 m/s² would tilt 68.8°: capped, the plan stays within 60°. With 30° and a
// passage to the left, the plan rises as little as it must to keep the full 10 m/s²: the best
// direction is where the tilt's cap meets the norm's.
TEST(DodgePlan, TheThrustTiltCapsEachDirection) {
  DodgeOptions o;
  o.limits.max_tilt_deg = 60;
  const CollisionRisk above = threat({0, 0, 0.2}, 0.4, 0.15, 0.8);
  EXPECT_TRUE(plan_dodge(above, hovering(1.0), o, kR).maneuver.acceleration_W.isApprox(Eigen::Vector3d(0, 0, -9.81), 1e-9));

  const CollisionRisk left = threat({0, 0.2, 0}, 0.4, 0.15, 0.8);
  const Eigen::Vector3d sideways = plan_dodge(left, hovering(1.0), o, kR).maneuver.acceleration_W;
  EXPECT_TRUE(sideways.isApprox(Eigen::Vector3d(0, -10, 0), 1e-9)) << sideways.transpose();
  EXPECT_NEAR(thrust_tilt_deg(sideways), 45.55, 0.01);  // atan(10 / 9.81)

  const CollisionRisk up_left = threat({0, 0.15, 0.15}, 0.4, 0.15, 0.8);
  const Eigen::Vector3d free = plan_dodge(up_left, hovering(1.0), DodgeOptions{}, kR).maneuver.acceleration_W;
  EXPECT_NEAR(thrust_tilt_deg(free), 68.8, 0.1) << free.transpose();
  const Eigen::Vector3d capped = plan_dodge(up_left, hovering(1.0), o, kR).maneuver.acceleration_W;
  EXPECT_LT(capped.y(), 0.0);
  EXPECT_LT(capped.z(), 0.0);
  EXPECT_LE(thrust_tilt_deg(capped), 60.0 + 1e-9) << capped.transpose();

  o.limits.max_tilt_deg = 30;
  o.directions = 3600;
  const Eigen::Vector3d kink = plan_dodge(left, hovering(1.0), o, kR).maneuver.acceleration_W;
  EXPECT_LT(kink.y(), 0.0);
  EXPECT_GT(kink.z(), 0.0);
  EXPECT_NEAR(kink.norm(), 10.0, 1e-9) << kink.transpose();
  EXPECT_LE(thrust_tilt_deg(kink), 30.0 + 1e-9);
  EXPECT_GE(thrust_tilt_deg(kink), 29.8) << kink.transpose();
}

// The trigger: high probability acts; low probability with time left does not; a probability
// above late_probability acts once t_c <= t_need + late_margin_s.
TEST(DodgePlan, TriggerPolicy) {
  const DodgeOptions o;
  EXPECT_TRUE(plan_dodge(threat({0, 0.1, 0}, 0.8, 0.2, 0.8), hovering(1.0), o, kR).trigger);
  EXPECT_FALSE(plan_dodge(threat({0, 0.9, 0}, 0.8, 0.2, 0.02), hovering(1.0), o, kR).trigger);

  // Miss 0.6 m, σ 0.3 m: clear 0.5 + 0.3 − 0.6 = 0.2 m at 10 m/s²: t_need = 0.05 + sqrt(0.04) = 0.25 s.
  const DodgePlan far = plan_dodge(threat({0, 0.6, 0}, 0.8, 0.3, 0.2), hovering(1.0), o, kR);
  EXPECT_NEAR(far.clear_m, 0.2, 1e-12);
  EXPECT_NEAR(far.time_needed_s, 0.25, 1e-9);
  EXPECT_NEAR(far.time_to_act_on_s, 0.8, 1e-12);  // the mean misses: t_c is the closest approach
  EXPECT_FALSE(far.trigger);
  const DodgePlan late = plan_dodge(threat({0, 0.6, 0}, 0.34, 0.3, 0.2), hovering(1.0), o, kR);
  EXPECT_TRUE(late.trigger) << late.why;
  // Below late_probability, even with no time left: no.
  EXPECT_FALSE(plan_dodge(threat({0, 0.6, 0}, 0.34, 0.3, 0.1), hovering(1.0), o, kR).trigger);
  // An object already receding: nothing to dodge.
  CollisionRisk receding = threat({0, 0.3, 0}, 0.0, 0.1, 0.9);
  receding.nominal.closest.receding = true;
  EXPECT_FALSE(plan_dodge(receding, hovering(1.0), o, kR).trigger);
}

// may_trigger, by which the planner skips the plan, never says no where the plan triggers: over a
// sweep of probabilities, misses, times to the closest approach and spreads, and for a receding
// object. Where it says no, a planner with nothing in force decides nothing.
TEST(DodgePlan, NoPlanIsSkippedThatWouldTrigger) {
  const DodgeOptions o;
  int triggered = 0, skipped = 0;
  for (const double p : {0.0, 0.05, 0.1, 0.149, 0.15, 0.3, 0.49, 0.5, 0.9})
    for (const double miss : {0.0, 0.3, 0.6, 1.2})
      for (const double closest_s : {0.05, 0.2, 0.34, 0.8})
        for (const double sigma : {0.05, 0.3}) {
          for (const bool receding : {false, true}) {
            CollisionRisk risk = threat({0, miss, 0}, closest_s, sigma, p);
            risk.nominal.closest.receding = receding;
            const bool trigger = plan_dodge(risk, hovering(1.0), o, kR).trigger;
            triggered += trigger;
            if (trigger) {
              EXPECT_TRUE(may_trigger(risk, o)) << "p " << p << " miss " << miss << " at " << closest_s;
            }
            if (may_trigger(risk, o)) continue;
            ++skipped;
            DodgePlanner planner(o, kR);
            EXPECT_FALSE(planner.update(1, risk, hovering(1.0)));
          }
        }
  EXPECT_GT(triggered, 20);
  EXPECT_GT(skipped, 100);
}

// Dodge at 0.8 s from the closest approach, nothing while the threat is unchanged, commit once
// t_c <= t_need + commit_margin_s, and nothing after the commit however the risk changes.
TEST(DodgePlanner, CommitsWhenNoTimeIsLeftAndThenHolds) {
  DodgePlanner planner{DodgeOptions{}, kR};
  const Eigen::Vector3d miss(0, 0.1, 0);
  const auto first = planner.update(1, threat(miss, 0.8, 0.2, 0.8, 1.0), hovering(1.0));
  ASSERT_TRUE(first);
  EXPECT_EQ(first->action, DodgeAction::kDodge);
  EXPECT_FALSE(first->committed);
  ASSERT_TRUE(first->maneuver);
  EXPECT_LT(first->maneuver->acceleration_W.y(), -9.99);
  EXPECT_EQ(first->effective_t, at(1.05));
  EXPECT_FALSE(planner.update(1, threat(miss, 0.6, 0.2, 0.8, 1.2), hovering(1.2)));

  // clear = 0.5 + 0.2 − 0.1 = 0.6 m: t_need = 0.05 + sqrt(0.12) = 0.396 s; contact at
  // 0.3 − sqrt(0.24)/10 = 0.251 s <= t_need + 0.05.
  const auto commit = planner.update(1, threat(miss, 0.3, 0.2, 0.8, 1.5), hovering(1.5));
  ASSERT_TRUE(commit);
  EXPECT_EQ(commit->action, DodgeAction::kCommit);
  EXPECT_TRUE(commit->committed);
  EXPECT_NEAR(commit->time_needed_s, 0.05 + std::sqrt(0.12), 1e-9);
  ASSERT_TRUE(commit->maneuver);
  EXPECT_EQ(commit->maneuver->start_t, first->maneuver->start_t);  // held, not re-planned

  EXPECT_FALSE(planner.update(1, threat(miss, 0.25, 0.2, 0.01, 1.55), hovering(1.55)));
  EXPECT_FALSE(planner.update(1, threat(-miss, 0.2, 0.2, 0.99, 1.6), hovering(1.6)));
  EXPECT_FALSE(planner.update(2, threat(-miss, 0.3, 0.2, 0.99, 1.6), hovering(1.6)));
  ASSERT_TRUE(planner.active());
  EXPECT_TRUE(planner.active()->committed);
  // The manoeuvre ends at 1.05 + 0.85 s: then the planner is free again.
  const auto after = planner.update(2, threat(-miss, 0.5, 0.2, 0.99, 1.95), hovering(1.95));
  ASSERT_TRUE(after);
  EXPECT_EQ(after->action, DodgeAction::kDodge);
  EXPECT_EQ(after->track_id, 2);
}

// A first trigger already inside the commit time is committed at once.
TEST(DodgePlanner, LateFirstTriggerIsCommittedAtOnce) {
  DodgePlanner planner{DodgeOptions{}, kR};
  const auto d = planner.update(1, threat({0, 0.1, 0}, 0.2, 0.2, 0.9), hovering(1.0));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->action, DodgeAction::kDodge);
  EXPECT_TRUE(d->committed);
}

TEST(DodgePlanner, CancelsWhenTheThreatGoesAway) {
  DodgePlanner planner{DodgeOptions{}, kR};
  ASSERT_TRUE(planner.update(1, threat({0, 0.1, 0}, 0.9, 0.2, 0.8, 1.0), hovering(1.0)));
  EXPECT_FALSE(planner.update(1, threat({0, 0.1, 0}, 0.85, 0.2, 0.7, 1.05), hovering(1.05)));  // step 0.1 < 0.2
  const auto cancel = planner.update(1, threat({0, 1.5, 0}, 0.8, 0.2, 0.01, 1.1), hovering(1.1));
  ASSERT_TRUE(cancel);
  EXPECT_EQ(cancel->action, DodgeAction::kCancel);
  EXPECT_FALSE(cancel->maneuver);
  EXPECT_EQ(cancel->effective_t, at(1.15));
  EXPECT_FALSE(planner.active());
}

// The passage moves from the left to the right of the body: the direction flips, a re-plan.
TEST(DodgePlanner, ReplansWhenTheBestDirectionMoves) {
  DodgePlanner planner{DodgeOptions{}, kR};
  ASSERT_TRUE(planner.update(1, threat({0, 0.2, 0}, 0.9, 0.2, 0.7, 1.0), hovering(1.0)));
  const auto replan = planner.update(1, threat({0, -0.2, 0}, 0.85, 0.2, 0.7, 1.05), hovering(1.05));
  ASSERT_TRUE(replan);
  EXPECT_EQ(replan->action, DodgeAction::kReplan);
  EXPECT_GT(replan->maneuver->acceleration_W.y(), 9.99);
  EXPECT_EQ(replan->maneuver->start_t, at(1.1));
}

// Near a tie the direction in force stays: a passage 2 cm to the left (dodge right, -y) then 2 cm
// to the right gains the other side under 0.1 m of expected clearance, so nothing is re-planned;
// with replan_gain_m 0 the same jitter swings the set-point to the other side.
TEST(DodgePlanner, KeepsTheDirectionInForceNearATie) {
  DodgePlanner planner{DodgeOptions{}, kR};
  const auto first = planner.update(1, threat({0, 0.02, 0}, 0.9, 0.2, 0.9, 1.0), hovering(1.0));
  ASSERT_TRUE(first);
  const Eigen::Vector3d a_first = first->maneuver->acceleration_W;
  const DodgePlan other_side = plan_dodge(threat({0, -0.02, 0}, 0.85, 0.2, 0.9, 1.05), hovering(1.05), DodgeOptions{}, kR);
  EXPECT_LT(other_side.maneuver.acceleration_W.dot(a_first), 0.0);  // the best alone is the other side
  EXPECT_FALSE(planner.update(1, threat({0, -0.02, 0}, 0.85, 0.2, 0.9, 1.05), hovering(1.05)));
  DodgeOptions no_hysteresis;
  no_hysteresis.replan_gain_m = 0;
  DodgePlanner swinging{no_hysteresis, kR};
  ASSERT_TRUE(swinging.update(1, threat({0, 0.02, 0}, 0.9, 0.2, 0.9, 1.0), hovering(1.0)));
  const auto swung = swinging.update(1, threat({0, -0.02, 0}, 0.85, 0.2, 0.9, 1.05), hovering(1.05));
  ASSERT_TRUE(swung);
  EXPECT_EQ(swung->action, DodgeAction::kReplan);
}

// Two tracks: the planner acts on the more probable one and ignores the less probable.
TEST(DodgePlanner, TheMostThreateningTrackWins) {
  DodgePlanner planner{DodgeOptions{}, kR};
  ASSERT_TRUE(planner.update(1, threat({0, 0.2, 0}, 0.9, 0.2, 0.6, 1.0), hovering(1.0)));
  const auto to2 = planner.update(2, threat({0, -0.2, 0}, 0.9, 0.2, 0.9, 1.01), hovering(1.01));
  ASSERT_TRUE(to2);
  EXPECT_EQ(to2->action, DodgeAction::kReplan);
  EXPECT_EQ(to2->track_id, 2);
  EXPECT_GT(to2->maneuver->acceleration_W.y(), 9.99);  // away from track 2's passage
  EXPECT_FALSE(planner.update(1, threat({0, 0.2, 0}, 0.88, 0.2, 0.6, 1.02), hovering(1.02)));
  EXPECT_FALSE(planner.update(3, threat({0, 0.2, 0}, 0.88, 0.2, 0.55, 1.02), hovering(1.02)));
  EXPECT_EQ(planner.active()->track_id, 2);
}

TEST(DodgePlanner, RefusesNonFiniteInputWithoutNaNSetPoints) {
  DodgePlanner planner{DodgeOptions{}, kR};
  CollisionRisk nan_risk = threat({0, 0.1, 0}, 0.5, 0.2, 0.8);
  nan_risk.probability = std::nan("");
  const auto d = planner.update(1, nan_risk, hovering(1.0));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->action, DodgeAction::kRefused);
  EXPECT_NE(d->reason.find("probability"), std::string::npos) << d->reason;
  EXPECT_FALSE(d->maneuver);
  EXPECT_EQ(d->probability, 0.0);  // rows hold no NaN
  EXPECT_TRUE(std::isfinite(d->miss_distance_m));

  VehicleState nan_state = hovering(1.0);
  nan_state.odometry.v_W.x() = std::numeric_limits<double>::infinity();
  const auto s = planner.update(1, threat({0, 0.1, 0}, 0.5, 0.2, 0.8), nan_state);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->action, DodgeAction::kRefused);
  EXPECT_NE(s->reason.find("vehicle state"), std::string::npos) << s->reason;

  // With a manoeuvre in force, a refusal repeats it unchanged (finite) and playback ignores it.
  const auto dodge = planner.update(1, threat({0, 0.1, 0}, 0.8, 0.2, 0.8), hovering(1.0));
  ASSERT_TRUE(dodge);
  CollisionRisk nan_cov = threat({0, 0.1, 0}, 0.7, 0.2, 0.8, 1.1);
  nan_cov.closest_offset_covariance_W(1, 1) = std::nan("");
  const auto r = planner.update(1, nan_cov, hovering(1.1));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->action, DodgeAction::kRefused);
  ASSERT_TRUE(r->maneuver);
  EXPECT_TRUE(r->maneuver->acceleration_W.allFinite());
  EXPECT_EQ(r->maneuver->acceleration_W, dodge->maneuver->acceleration_W);

  // A state older than the previous update.
  const auto old = planner.update(1, threat({0, 0.1, 0}, 0.8, 0.2, 0.8, 0.9), hovering(0.9));
  ASSERT_TRUE(old);
  EXPECT_EQ(old->action, DodgeAction::kRefused);
  EXPECT_NE(old->reason.find("older"), std::string::npos) << old->reason;
}

TEST(DodgeOptions, InvalidLimitsNameTheKey) {
  auto error_of = [](DodgeOptions o) -> std::string {
    try {
      DodgePlanner planner(o);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  DodgeOptions o;
  o.limits.max_acceleration_m_s2 = -1;
  EXPECT_NE(error_of(o).find("limits.max_acceleration_m_s2"), std::string::npos) << error_of(o);
  o = {};
  o.limits.max_acceleration_m_s2 = std::numeric_limits<double>::infinity();
  EXPECT_NE(error_of(o).find("limits.max_acceleration_m_s2"), std::string::npos);
  o = {};
  o.limits.max_acceleration_per_axis_m_s2.z() = std::nan("");
  EXPECT_NE(error_of(o).find("limits.max_acceleration_per_axis_m_s2[2]"), std::string::npos) << error_of(o);
  o = {};
  o.limits.max_acceleration_per_axis_m_s2.x() = 0;
  EXPECT_NE(error_of(o).find("limits.max_acceleration_per_axis_m_s2[0]"), std::string::npos);
  o = {};
  o.limits.response_delay_s = -0.01;
  EXPECT_NE(error_of(o).find("limits.response_delay_s"), std::string::npos);
  o = {};
  o.limits.min_height_m = std::nan("");
  EXPECT_NE(error_of(o).find("limits.min_height_m"), std::string::npos);
  o = {};
  o.limits.min_height_m = 2.0;
  o.limits.max_height_m = 1.5;
  EXPECT_EQ(error_of(o),
            "DodgeOptions: limits.max_height_m must be above min_height_m (2) (got 1.5)");
  o.limits.max_height_m = std::nan("");
  EXPECT_NE(error_of(o).find("limits.max_height_m"), std::string::npos);
  o = {};
  o.limits.max_tilt_deg = 0;
  EXPECT_NE(error_of(o).find("limits.max_tilt_deg"), std::string::npos) << error_of(o);
  o.limits.max_tilt_deg = 181;
  EXPECT_NE(error_of(o).find("limits.max_tilt_deg"), std::string::npos);
  o.limits.max_tilt_deg = std::nan("");
  EXPECT_NE(error_of(o).find("limits.max_tilt_deg"), std::string::npos);
  o = {};
  o.late_probability = 0.01;  // below cancel_probability
  EXPECT_NE(error_of(o).find("cancel_probability < late_probability"), std::string::npos);
  // Unlimited axes and no floor are valid.
  o = {};
  o.limits.max_acceleration_per_axis_m_s2.setConstant(std::numeric_limits<double>::infinity());
  o.limits.min_height_m = -std::numeric_limits<double>::infinity();
  o.limits.max_height_m = std::numeric_limits<double>::infinity();
  EXPECT_EQ(error_of(o), "");
  EXPECT_THROW(DodgePlanner(DodgeOptions{}, std::nan("")), ConfigError);
}

// The defaults written as YAML load back to the same values (finite "no limit" defaults), and the
// limits are the nested section `limits`.
TEST(DodgeOptions, YamlRoundTrip) {
  DodgeOptions o;
  o.limits.max_acceleration_per_axis_m_s2 = {5, 6, 7};
  o.act_probability = 0.6;
  const std::string text = options_to_yaml(o);
  DodgeOptions back;
  YamlLoader load(YAML::Load(text), "dodge.yaml", {.validate = true});
  describe(load, back);
  load.check_unknown();
  EXPECT_EQ(back.limits.max_acceleration_per_axis_m_s2, o.limits.max_acceleration_per_axis_m_s2);
  EXPECT_EQ(back.act_probability, 0.6);
  EXPECT_EQ(back.limits.min_height_m, o.limits.min_height_m);
  EXPECT_EQ(back.limits.max_height_m, o.limits.max_height_m);
  EXPECT_NE(options_markdown(DodgeOptions{}).find("| `limits.max_acceleration_m_s2` | 10 |"), std::string::npos);
}

// End to end on a ballistic throw (no simulator): the risk of assess_collision_risk, the planner's
// decision, and the set-point flown against the true trajectory. The ball passes 0.2 m to the left
// of a hovering body 0.8 s after release; deciding at 0.2 s, the dodge goes right and the true
// closest approach then lies outside the safety sphere: 0.2 + ½·10·0.55² = 1.71 m at the passage,
// 1.54 m a little earlier while the body is still on its way (docs/AVOIDANCE.md, Limitations).
TEST(DodgePlanner, EscapesABallisticThrowWithTheRiskModule) {
  const Eigen::Vector3d g(0, 0, -9.81);
  const double pass_s = 0.8;
  const Eigen::Vector3d passage = kBody + Eigen::Vector3d(0, 0.2, 0);
  const Eigen::Vector3d v0(-kClosing, 0, -0.5 * g.z() * pass_s);  // level again at the passage
  const Eigen::Vector3d p0 = passage - v0 * pass_s - 0.5 * g * pass_s * pass_s;
  const BallisticTrajectory truth{0, p0, v0, g};

  TrajectoryEstimate estimate;
  estimate.usable = estimate.converged = true;
  estimate.method = EstimateMethod::kFusion;
  estimate.trajectory = truth;
  Eigen::Matrix<double, 6, 1> sigma;
  sigma << 0.03, 0.03, 0.03, 0.05, 0.05, 0.05;
  estimate.covariance = Eigen::Matrix<double, 6, 6>(sigma.array().square().matrix().asDiagonal());
  estimate.t_first = 0;
  estimate.t_last = at(0.2);

  const PredictionOptions po;
  VehicleState vehicle = hovering(0.2);
  vehicle.covariance = vehicle_state_covariance(po);
  const RiskAssessment assessed = assess_collision_risk(estimate, vehicle, po);
  ASSERT_TRUE(assessed.risk) << assessed.reason;
  EXPECT_GT(assessed.risk->probability, 0.5);

  DodgePlanner planner(DodgeOptions{}, po.safety_radius_m);
  const auto d = planner.update(1, *assessed.risk, vehicle);
  ASSERT_TRUE(d);
  ASSERT_EQ(d->action, DodgeAction::kDodge) << d->reason;
  EXPECT_LT(d->maneuver->acceleration_W.y(), -9.0) << d->maneuver->acceleration_W.transpose();
  EXPECT_LT(d->maneuver->probability_after, 0.01);

  const std::vector<DodgeDecision> flown{*d};
  double closest_m = std::numeric_limits<double>::infinity();
  for (TimeNs t = at(0.2); t <= at(1.2); t += kNsPerMs)
    closest_m = std::min(closest_m, (truth.position(t) - (kBody + commanded_offset(flown, t).position_W)).norm());
  EXPECT_GT(closest_m, 1.5);
  EXPECT_NEAR((truth.position(at(pass_s)) - kBody).norm(), 0.2, 1e-9);  // without the dodge: a hit
}

// Playback against hand-integrated values: a dodge −y at 10 m/s² from 1.05 s, replaced at 1.15 s
// by +z at 5 m/s² (0.2 s), cancelled from 1.3 s; a refusal in between changes nothing.
TEST(ManeuverPlayback, PiecewiseConstantAccelerationIntegratedExactly) {
  std::vector<DodgeDecision> d(4);
  d[0].t = at(1.0);
  d[0].action = DodgeAction::kDodge;
  d[0].maneuver = DodgeManeuver{.acceleration_W = {0, -10, 0}, .start_t = at(1.05), .duration_s = 0.3};
  d[0].effective_t = at(1.05);
  d[1].t = at(1.08);
  d[1].action = DodgeAction::kRefused;
  d[1].maneuver = DodgeManeuver{.acceleration_W = {100, 100, 100}, .start_t = at(1.0), .duration_s = 9};
  d[2].t = at(1.1);
  d[2].action = DodgeAction::kReplan;
  d[2].maneuver = DodgeManeuver{.acceleration_W = {0, 0, 5}, .start_t = at(1.15), .duration_s = 0.2};
  d[2].effective_t = at(1.15);
  d[3].t = at(1.25);
  d[3].action = DodgeAction::kCancel;
  d[3].effective_t = at(1.3);

  const ManeuverOffset before = commanded_offset(d, at(1.04));
  EXPECT_EQ(before.position_W, Eigen::Vector3d::Zero());
  EXPECT_EQ(before.velocity_W, Eigen::Vector3d::Zero());

  // 1.2 s: −y for 0.1 s then coasting 0.05 s; +z for 0.05 s.
  const ManeuverOffset mid = commanded_offset(d, at(1.2));
  EXPECT_TRUE(mid.velocity_W.isApprox(Eigen::Vector3d(0, -1.0, 0.25), 1e-9)) << mid.velocity_W.transpose();
  EXPECT_TRUE(mid.position_W.isApprox(Eigen::Vector3d(0, -10 * (0.005 + 0.1 * 0.05), 0.5 * 5 * 0.0025), 1e-9))
      << mid.position_W.transpose();

  // 1.5 s: −y 0.1 s + 0.35 s coast; +z 0.15 s (cancelled at 1.3 s) + 0.2 s coast.
  const ManeuverOffset end = commanded_offset(d, at(1.5));
  EXPECT_TRUE(end.velocity_W.isApprox(Eigen::Vector3d(0, -1.0, 0.75), 1e-9));
  EXPECT_TRUE(end.position_W.isApprox(
      Eigen::Vector3d(0, -10 * (0.005 + 0.1 * 0.35), 5 * (0.5 * 0.15 * 0.15 + 0.15 * 0.2)), 1e-9))
      << end.position_W.transpose();

  // A cancel rebuilt without effective_t takes effect at its own time, 1.25 s: +z for 0.1 s.
  std::vector<DodgeDecision> no_effective_t = d;
  no_effective_t[3].effective_t = 0;
  EXPECT_NEAR(commanded_offset(no_effective_t, at(1.5)).velocity_W.z(), 0.5, 1e-9);

  // Without the cancel, the replan's set-point runs its full 0.2 s.
  const ManeuverOffset uncancelled = commanded_offset(std::span(d).first(3), at(1.5));
  EXPECT_NEAR(uncancelled.velocity_W.z(), 1.0, 1e-9);

  // What a vehicle controller receives: −y from 1.05 s, +z from 1.15 s (the replan dropped the
  // dodge's end at 1.35 s), zero from the cancel at 1.3 s (which dropped the replan's end at
  // 1.35 s); the refusal adds nothing.
  const std::vector<SetpointChange> schedule = setpoint_schedule(d);
  ASSERT_EQ(schedule.size(), 3u);
  EXPECT_EQ(schedule[0].t, at(1.05));
  EXPECT_EQ(schedule[0].acceleration_W, Eigen::Vector3d(0, -10, 0));
  EXPECT_EQ(schedule[1].t, at(1.15));
  EXPECT_EQ(schedule[1].acceleration_W, Eigen::Vector3d(0, 0, 5));
  EXPECT_EQ(schedule[2].t, at(1.3));
  EXPECT_EQ(schedule[2].acceleration_W, Eigen::Vector3d::Zero());
  EXPECT_TRUE(setpoint_changes(d[1]).empty());
}

}  // namespace
}  // namespace fdv
