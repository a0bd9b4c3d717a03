#pragma once
/// Collision risk under uncertainty: from a trajectory estimate with its (p0, v0) covariance and
/// the vehicle's state with the odometry's covariance, the probability that the object enters
/// the safety sphere within the horizon, the time to contact, and the closest approach and point
/// of passage each with its covariance.
///
///   VehicleState vehicle{odometry_now, vehicle_state_covariance(po)};
///   RiskAssessment r = assess_collision_risk(estimate, vehicle, po);
///   if (!r.risk) log(r.reason);                       // no covariance, non-finite, stale state...
///   else if (r.risk->probability > 0.5) dodge_away_from(r.risk->nominal.closest.offset_B);
///
/// Model: predict_collision's (constant vehicle velocity and attitude over the horizon, ballistic
/// object). The uncertainty is propagated linearly: the relative position at the closest approach,
/// m = d(s*), with s* the root of d·ḋ = 0, is differentiated in the 12 inputs x = (p0, v0, p_B,
/// v_B) (implicit function theorem for s*), Σ_m = J Σ_x Jᵀ. The probability is that of a Gaussian
/// miss vector, projected on the plane normal to the relative velocity at s*, falling inside the
/// disc of radius R; when s* is at an end of the horizon (receding, or still approaching at its
/// end), that the disc is crossed inside the horizon (docs/ESTIMATION.md, "Collision risk").
/// A vehicle state up to 1 ms older than the estimate's newest observation is accepted.
/// Thread-safe (pure).
#include <Eigen/Core>
#include <optional>
#include <string>

#include "fdv/core/sensor_data.h"
#include "fdv/estimation/collision.h"
#include "fdv/estimation/trajectory_estimator.h"

namespace fdv {

/// The vehicle's state and its uncertainty.
struct VehicleState {
  OdometrySample odometry;
  /// Covariance of (p_W_B, v_W) [m², m²/s²]; zero = exact.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

/// The (p_W_B, v_W) covariance that PredictionOptions' odometry sigmas give (odometry messages of
/// the datasets carry none): diagonal, odometry_position_sigma_m² and odometry_velocity_sigma_m_s².
Eigen::Matrix<double, 6, 6> vehicle_state_covariance(const PredictionOptions& options);

struct CollisionRisk {
  /// predict_collision of the mean trajectory and state (time to contact, closest approach, offset).
  CollisionPrediction nominal;
  /// Probability that the object comes within safety_radius_m of the body origin before
  /// vehicle.t + horizon_s.
  double probability = 0;
  /// Covariance of the object's position relative to the body origin at the closest approach, in
  /// W [m²] (of closest.object_W - closest.vehicle_W), and of the point of passage in B.
  Eigen::Matrix3d closest_offset_covariance_W = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d offset_covariance_B = Eigen::Matrix3d::Zero();
  /// Std of the miss distance |m| (linearised) [m] and of the time of closest approach [s].
  double miss_distance_sigma_m = 0;
  double closest_time_sigma_s = 0;
  /// Object velocity relative to the vehicle at the closest approach, in W [m/s]: a dodge moves
  /// perpendicular to it.
  Eigen::Vector3d relative_velocity_W = Eigen::Vector3d::Zero();
};

/// A risk, or the reason there is none (estimate not converged, no covariance, non-finite input,
/// vehicle state older than the estimate's newest observation). Whether a converged estimate that
/// is not usable is worth acting on is the caller's policy (the dodge's max_horizon_sigma_m): its
/// covariance weighs it here as a usable one's does.
struct RiskAssessment {
  std::optional<CollisionRisk> risk;
  std::string reason;  ///< empty when risk is set
};

/// Throws ConfigError when options are invalid; bad estimates and states give a reason instead.
RiskAssessment assess_collision_risk(const TrajectoryEstimate& estimate, const VehicleState& vehicle,
                                     const PredictionOptions& options);

/// P(|x| <= radius) for x ~ N(mean, covariance) in the plane (the disc is centred at the origin).
/// A singular covariance is allowed (a degenerate Gaussian along a line or a point). Accurate to
/// ~1e-6 (deterministic adaptive quadrature, no sampling); ~30 µs.
double gaussian_disc_probability(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance, double radius);

/// E|x| for x ~ N(mean, covariance) in the plane (the expected clearance from the origin); a
/// singular covariance is allowed. Relative accuracy ~1e-8 (deterministic quadrature); ~30 µs.
double gaussian_expected_norm(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance);

}  // namespace fdv
