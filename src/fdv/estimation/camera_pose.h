#pragma once
/// Camera pose at an observation's own time, from odometry (the paper's eqs. 12 and 14 need
/// T_W_E at t_k and T_W_D at t_i, not "the latest pose").
///
///   std::optional<Eigen::Isometry3d> T_W_E = camera_pose_at(odometry, t, calib.T_B_E, 20 *
///   kNsPerMs);
///
/// Between samples: interpolate_odometry (linear position, slerp attitude). Beyond the ends, up
/// to max_extrapolation_ns: constant velocity v_W and constant body rate omega_B. Farther, or with
/// no samples: nothing. `odometry` must be time-sorted. Thread-safe (pure function).
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "fdv/core/sensor_data.h"

namespace fdv {

/// Body state at t (interpolated, or extrapolated within max_extrapolation_ns).
std::optional<OdometrySample> body_state_at(const std::vector<OdometrySample>& odometry, TimeNs t,
                                            TimeNs max_extrapolation_ns = 0);

/// T_W_C = T_W_B(t) · T_B_C for a camera C rigidly mounted on the body.
std::optional<Eigen::Isometry3d> camera_pose_at(const std::vector<OdometrySample>& odometry,
                                                TimeNs t, const Eigen::Isometry3d& T_B_C,
                                                TimeNs max_extrapolation_ns = 0);

}  // namespace fdv
