#pragma once
/// The "contrast_max" baseline (BetterFlow-like): a global 4-parameter warp of the window found
/// by optimisation, with no IMU, odometry or depth.
///
/// Model (Mitrokhin et al. 2018): on the undistorted grid, with d = (u − cx, v − cy),
///     u' = u − (t − t0)·(h_x + h_z·d_u − θ·d_v)
///     v' = v − (t − t0)·(h_y + h_z·d_v + θ·d_u)
/// h_x, h_y: image shift [px/s]; h_z: expansion [1/s]; θ: rotation about the optical axis [rad/s].
/// Objective (Gallego et al. 2018, contrast maximisation, instead of Mitrokhin's timestamp-gradient
/// error — see docs/DETECTION.md for why): the focus F(h) = mean over pixels of (G_σ ∗ H(h))²,
/// H = image of warped events with bilinear voting. Maximised with ceres::GradientProblemSolver
/// (L-BFGS) using the exact analytic gradient below.
#include <array>
#include <opencv2/core.hpp>
#include <span>
#include <vector>

#include "fdv/compensation/compensator_base.h"

namespace fdv {

/// F(h) and dF/dh for a fixed set of events. Not thread-safe (scratch images).
class WarpContrastObjective {
 public:
  /// Grid size and the model's centre (the principal point); σ of the Gaussian smoothing [px].
  WarpContrastObjective(int width, int height, double cx, double cy, double blur_sigma_px);
  /// Events as undistorted-grid positions [px] and times relative to t0 [s]; copied.
  void set_events(std::span<const float> u, std::span<const float> v, std::span<const float> t_s);
  std::size_t size() const { return u_.size(); }
  /// F(h) = (1/P)·Σ_p ((G_σ ∗ H(h))_p)², P = width·height; writes dF/dh into `grad` if non-null.
  /// h = {h_x, h_y, h_z, θ}. The image is smoothed with zero borders, which keeps the gradient
  /// exact (G_σ is self-adjoint): dF/dh = (2/P)·Σ_k ∇(G_σ∗G_σ∗H)(x'_k)·∂x'_k/∂h, with ∇ the
  /// derivative of bilinear interpolation (exact wherever no warped event sits on a pixel edge).
  double evaluate(const std::array<double, 4>& h, std::array<double, 4>* grad);
  /// The warped position of one event.
  void warp(const std::array<double, 4>& h, float u, float v, float t_s, float& u_out, float& v_out) const;

 private:
  int width_, height_;
  double cx_, cy_, sigma_;
  std::vector<float> u_, v_, t_;
  std::vector<float> wu_, wv_;  ///< warped positions of the last evaluation
  cv::Mat iwe_, smooth_, smooth2_;
};

namespace internal {

class ContrastMaxCompensator final : public CompensatorBase {
 public:
  ContrastMaxCompensator(const Calibration& calibration, const CompensationOptions& options,
                         std::shared_ptr<const UndistortionMap> map);
  const CompensatedWindow& compensate(const CompensationInput& input) override;
  Eigen::Vector2d observed_position(const Eigen::Vector2d& px, double t_s) const override;

 private:
  WarpContrastObjective objective_;
  std::array<double, 4> previous_{};  ///< last window's solution (warm start)
  bool have_previous_ = false;
  std::vector<float> fit_u_, fit_v_, fit_t_;
};

}  // namespace internal
}  // namespace fdv
