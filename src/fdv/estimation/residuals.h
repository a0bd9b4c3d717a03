#pragma once
/// Cost functors of the trajectory estimator, over one parameter block x = (p0_W, v0_W) ∈ R⁶.
/// Both are whitened: divided by their own noise std, so a Huber threshold k means "k sigmas".
///
/// Event residual (paper eqs. 12-13), camera C = E at the observation's time t_k, τ = t_k - t0:
///   ᶜp = R_C_W·(p(t_k) - t_W_C),   r_E = ((ᶜx/ᶜz, ᶜy/ᶜz) - x_n) / σ_n
/// with x_n the detection's undistorted normalised coordinates and σ_n = σ_px / f.
/// Depth residual (paper eqs. 14-15), C = the frame whose z the depth image holds (E after
/// registration) at the depth frame's time t_i:
///   r_D = (ᶜz - d) / σ_d,   d = the object's centre depth (DepthObservation::depth_m).
/// Note: the paper writes ᵂR_E where the world-to-camera rotation R_C_W = ᵂR_Cᵀ is meant.
///
/// The event functor returns false (Ceres rejects the step) where the object would be less than
/// min_z in front of the camera: the projection is undefined there.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace fdv {

struct EventResidual {
  /// tau_s = t_k - t0 [s]; T_W_C = camera pose at t_k; xn = measured normalised coordinates.
  EventResidual(double tau_s, const Eigen::Isometry3d& T_W_C, const Eigen::Vector3d& gravity_W,
                const Eigen::Vector2d& xn, double sigma_n, double min_z_m)
      : tau(tau_s),
        R_C_W(T_W_C.linear().transpose()),
        offset_W(0.5 * tau_s * tau_s * gravity_W - T_W_C.translation()),
        x_n(xn),
        inv_sigma(1.0 / sigma_n),
        min_z(min_z_m) {}

  template <typename T>
  bool operator()(const T* x, T* r) const {
    T q[3];
    for (int i = 0; i < 3; ++i) q[i] = x[i] + tau * x[3 + i] + offset_W[i];
    T c[3];
    for (int i = 0; i < 3; ++i) c[i] = R_C_W(i, 0) * q[0] + R_C_W(i, 1) * q[1] + R_C_W(i, 2) * q[2];
    if (!(c[2] > T(min_z))) return false;
    r[0] = (c[0] / c[2] - x_n.x()) * inv_sigma;
    r[1] = (c[1] / c[2] - x_n.y()) * inv_sigma;
    return true;
  }

  static ceres::CostFunction* create(double tau_s, const Eigen::Isometry3d& T_W_C,
                                     const Eigen::Vector3d& gravity_W, const Eigen::Vector2d& xn,
                                     double sigma_n, double min_z_m) {
    return new ceres::AutoDiffCostFunction<EventResidual, 2, 6>(
        new EventResidual(tau_s, T_W_C, gravity_W, xn, sigma_n, min_z_m));
  }

  double tau;
  Eigen::Matrix3d R_C_W;
  Eigen::Vector3d offset_W;  ///< ½gτ² - t_W_C
  Eigen::Vector2d x_n;
  double inv_sigma;
  double min_z;
};

struct DepthResidual {
  DepthResidual(double tau_s, const Eigen::Isometry3d& T_W_C, const Eigen::Vector3d& gravity_W,
                double depth_m, double sigma_m)
      : tau(tau_s),
        axis_W(T_W_C.linear().col(2)),  // third row of R_C_W
        offset_W(0.5 * tau_s * tau_s * gravity_W - T_W_C.translation()),
        d(depth_m),
        inv_sigma(1.0 / sigma_m) {}

  template <typename T>
  bool operator()(const T* x, T* r) const {
    T z = T(0);
    for (int i = 0; i < 3; ++i) z += axis_W[i] * (x[i] + tau * x[3 + i] + offset_W[i]);
    r[0] = (z - d) * inv_sigma;
    return true;
  }

  static ceres::CostFunction* create(double tau_s, const Eigen::Isometry3d& T_W_C,
                                     const Eigen::Vector3d& gravity_W, double depth_m,
                                     double sigma_m) {
    return new ceres::AutoDiffCostFunction<DepthResidual, 1, 6>(
        new DepthResidual(tau_s, T_W_C, gravity_W, depth_m, sigma_m));
  }

  double tau;
  Eigen::Vector3d axis_W;    ///< the camera's optical axis in W
  Eigen::Vector3d offset_W;  ///< ½gτ² - t_W_C
  double d;
  double inv_sigma;
};

}  // namespace fdv
