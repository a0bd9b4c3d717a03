#pragma once
/// Prediction from a trajectory estimate: closest approach to the vehicle, miss distance, time to
/// contact with a safety sphere, and where the object passes in the body frame.
///
///   PredictionOptions po;  po.safety_radius_m = 0.5;
///   CollisionPrediction c = predict_collision(estimate.trajectory, odometry_now, po);
///   if (c.contact) brake_or_dodge(c.time_to_contact_s, c.closest.offset_B);
///
/// Model: the object follows its ballistic trajectory; the vehicle keeps its current velocity
/// v_W and attitude q_W_B from its state at `vehicle.t` (constant velocity, no rotation) over the
/// horizon. The relative position d(s) = a + b·s + ½·g·s² (s = t - vehicle.t) is a quadratic in s,
/// so |d|² is a quartic: the closest approach is at a real root of its derivative (a cubic) or at
/// an end of [0, horizon]; contact is the smallest root of |d|² - R² in [0, horizon]. Roots come
/// from Eigen's companion-matrix PolynomialSolver, polished by Newton steps. Thread-safe (pure).
#include <Eigen/Core>
#include <limits>
#include <optional>
#include <string>

#include "fdv/core/sensor_data.h"
#include "fdv/estimation/ballistic.h"

namespace fdv {

struct PredictionOptions {
  /// How far ahead to look [s]: a ballistic flight towards the vehicle from 8-10 m at 7-12 m/s
  /// lasts ~1 s; 2 s leaves margin while the constant-velocity vehicle model still means something.
  double horizon_s = 2.0;
  /// Radius of the sphere around the body origin that counts as contact [m]: the paper's vehicle
  /// is 0.57 m across (half-diagonal ~0.4 m) plus a ball radius and margin.
  double safety_radius_m = 0.5;
  /// The odometry's assumed std of position [m] and velocity [m/s] per axis, for the collision
  /// risk (collision_risk.h): the datasets' odometry messages carry no covariance; a few cm and
  /// 0.1 m/s is the order of a visual-inertial odometry's drift over the seconds of a throw.
  double odometry_position_sigma_m = 0.05;
  double odometry_velocity_sigma_m_s = 0.1;
  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): YAML section `prediction`.
template <class V>
void describe(V& v, PredictionOptions& o) {
  v("horizon_s", o.horizon_s, "s", "how far ahead to look");
  v("safety_radius_m", o.safety_radius_m, "m", "radius around the body origin that counts as contact");
  v("odometry_position_sigma_m", o.odometry_position_sigma_m, "m", "the odometry's assumed position std per axis");
  v("odometry_velocity_sigma_m_s", o.odometry_velocity_sigma_m_s, "m/s",
    "the odometry's assumed velocity std per axis");
}

struct ClosestApproach {
  TimeNs t = 0;  ///< time of closest approach (within [vehicle.t, vehicle.t + horizon])
  double time_from_now_s = 0;  ///< t - vehicle.t
  double miss_distance_m = 0;  ///< |object - body origin| at t
  Eigen::Vector3d object_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d vehicle_W = Eigen::Vector3d::Zero();
  /// Point of passage: the object relative to the body at t, in B (attitude held at q_W_B).
  Eigen::Vector3d offset_B = Eigen::Vector3d::Zero();
  bool at_horizon_end = false;  ///< still approaching when the horizon ends
  bool receding = false;        ///< closest at s = 0: the object is already moving away
};

struct CollisionPrediction {
  ClosestApproach closest;
  /// First time the distance drops to safety_radius_m (vehicle.t if already inside); none if never
  /// within the horizon.
  std::optional<TimeNs> contact;
  double time_to_contact_s = std::numeric_limits<double>::infinity();
};

/// Throws ConfigError when options are invalid.
CollisionPrediction predict_collision(const BallisticTrajectory& object,
                                      const OdometrySample& vehicle,
                                      const PredictionOptions& options);

}  // namespace fdv
