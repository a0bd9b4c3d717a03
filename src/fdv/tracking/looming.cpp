#include "fdv/tracking/looming.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "fdv/core/error.h"

namespace fdv {

std::string LoomingOptions::validate() const {
  if (min_detections < 2) return "min_detections must be >= 2";
  if (fit_detections < min_detections) return "fit_detections must be >= min_detections";
  if (!(size_sigma_px >= 0) || !(size_sigma_fraction >= 0) || size_sigma_px + size_sigma_fraction <= 0)
    return "size_sigma_px and size_sigma_fraction must be >= 0, not both 0";
  if (!(min_rate_sigmas >= 0) || !std::isfinite(min_rate_sigmas)) return "min_rate_sigmas must be finite and >= 0";
  return {};
}

LoomingFit::LoomingFit(LoomingOptions options) : options_(options) {
  if (const auto why = options_.validate(); !why.empty()) throw ConfigError("looming: " + why);
}

bool LoomingFit::add(TimeNs t, double width_px, double height_px) {
  const double size = std::min(width_px, height_px);
  if (!std::isfinite(size) || size <= 0) return false;
  if (!sizes_.empty() && t < sizes_.back().t) return false;
  sizes_.push_back({t, size});
  while (static_cast<int>(sizes_.size()) > options_.fit_detections) sizes_.pop_front();
  return true;
}

std::optional<Looming> LoomingFit::at(TimeNs t) const {
  if (static_cast<int>(sizes_.size()) < options_.min_detections) return std::nullopt;
  // Weighted least squares of y = 1/θ on (1, t − t_ref): normal equations AᵀWA x = AᵀW y.
  const TimeNs t_ref = sizes_.back().t;
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  for (const Size& s : sizes_) {
    const double sigma_theta = options_.size_sigma_px + options_.size_sigma_fraction * s.size_px;
    const double sigma_y = sigma_theta / (s.size_px * s.size_px);
    const double w = 1.0 / (sigma_y * sigma_y);
    const Eigen::Vector2d a(1.0, to_seconds(s.t - t_ref));
    normal += w * a * a.transpose();
    rhs += w * a / s.size_px;
  }
  const Eigen::LDLT<Eigen::Matrix2d> ldlt(normal);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0)) return std::nullopt;
  const Eigen::Vector2d x = ldlt.solve(rhs);
  const Eigen::Matrix2d covariance = ldlt.solve(Eigen::Matrix2d::Identity());
  // y(t) and its gradient with respect to (y₀, ẏ).
  const Eigen::Vector2d a(1.0, to_seconds(t - t_ref));
  const double y = a.dot(x), rate = x(1);
  if (!(y > 0)) return std::nullopt;  // extrapolated past contact
  Looming out;
  out.t = t;
  out.detections = static_cast<int>(sizes_.size());
  out.size_px = 1.0 / y;
  out.size_sigma_px = std::sqrt(std::max(0.0, a.dot(covariance * a))) / (y * y);  // |dθ/dy| = 1/y²
  const double rate_sigma = std::sqrt(std::max(0.0, covariance(1, 1)));
  if (std::abs(rate) > options_.min_rate_sigmas * rate_sigma && rate != 0) {
    out.tau_s = -y / rate;
    // τ = −y/ẏ with y = y₀ + ẏ s: ∂τ/∂y₀ = −1/ẏ, ∂τ/∂ẏ = −s/ẏ + y/ẏ² .
    const Eigen::Vector2d grad(-1.0 / rate, -a(1) / rate + y / (rate * rate));
    out.tau_sigma_s = std::sqrt(std::max(0.0, grad.dot(covariance * grad)));
  }
  return out;
}

}  // namespace fdv
