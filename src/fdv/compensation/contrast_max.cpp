#include "fdv/compensation/contrast_max.h"

#include <ceres/first_order_function.h>
#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

namespace fdv {

WarpContrastObjective::WarpContrastObjective(int width, int height, double cx, double cy, double blur_sigma_px)
    : width_(width), height_(height), cx_(cx), cy_(cy), sigma_(blur_sigma_px) {
  iwe_.create(height, width, CV_32F);
}

void WarpContrastObjective::set_events(std::span<const float> u, std::span<const float> v, std::span<const float> t_s) {
  u_.assign(u.begin(), u.end());
  v_.assign(v.begin(), v.end());
  t_.assign(t_s.begin(), t_s.end());
  wu_.resize(u_.size());
  wv_.resize(u_.size());
}

void WarpContrastObjective::warp(const std::array<double, 4>& h, float u, float v, float t_s, float& u_out,
                                 float& v_out) const {
  const float du = u - static_cast<float>(cx_), dv = v - static_cast<float>(cy_);
  u_out = u - t_s * static_cast<float>(h[0] + h[2] * du - h[3] * dv);
  v_out = v - t_s * static_cast<float>(h[1] + h[2] * dv + h[3] * du);
}

double WarpContrastObjective::evaluate(const std::array<double, 4>& h, std::array<double, 4>* grad) {
  iwe_.setTo(0);
  float* H = iwe_.ptr<float>();
  const int w = width_, hgt = height_;
  const std::size_t n = u_.size();
  // Bilinear voting; corners outside the image are skipped (consistently in the gradient).
  for (std::size_t k = 0; k < n; ++k) {
    float uw, vw;
    warp(h, u_[k], v_[k], t_[k], uw, vw);
    wu_[k] = uw;
    wv_[k] = vw;
    const float fx0 = std::floor(uw), fy0 = std::floor(vw);
    if (!(fx0 >= -1.0f && fx0 < static_cast<float>(w) && fy0 >= -1.0f && fy0 < static_cast<float>(hgt))) continue;
    const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
    const float a = uw - fx0, b = vw - fy0;
    const bool x0_in = x0 >= 0, x1_in = x0 + 1 < w, y0_in = y0 >= 0, y1_in = y0 + 1 < hgt;
    if (y0_in) {
      float* row = H + static_cast<std::size_t>(y0) * w;
      if (x0_in) row[x0] += (1 - a) * (1 - b);
      if (x1_in) row[x0 + 1] += a * (1 - b);
    }
    if (y1_in) {
      float* row = H + static_cast<std::size_t>(y0 + 1) * w;
      if (x0_in) row[x0] += (1 - a) * b;
      if (x1_in) row[x0 + 1] += a * b;
    }
  }
  cv::GaussianBlur(iwe_, smooth_, cv::Size(0, 0), sigma_, sigma_, cv::BORDER_CONSTANT);
  const double P = static_cast<double>(w) * hgt;
  const double F = cv::norm(smooth_, cv::NORM_L2SQR) / P;
  if (!grad) return F;
  cv::GaussianBlur(smooth_, smooth2_, cv::Size(0, 0), sigma_, sigma_, cv::BORDER_CONSTANT);
  const float* A = smooth2_.ptr<float>();
  double g0 = 0, g1 = 0, g2 = 0, g3 = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const float uw = wu_[k], vw = wv_[k];
    const float fx0 = std::floor(uw), fy0 = std::floor(vw);
    if (!(fx0 >= -1.0f && fx0 < static_cast<float>(w) && fy0 >= -1.0f && fy0 < static_cast<float>(hgt))) continue;
    const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
    const float a = uw - fx0, b = vw - fy0;
    auto at = [&](int x, int y) -> float {
      return (x >= 0 && x < w && y >= 0 && y < hgt) ? A[static_cast<std::size_t>(y) * w + x] : 0.0f;
    };
    const float a00 = at(x0, y0), a10 = at(x0 + 1, y0), a01 = at(x0, y0 + 1), a11 = at(x0 + 1, y0 + 1);
    const double dFdu = (1 - b) * (a10 - a00) + b * (a11 - a01);
    const double dFdv = (1 - a) * (a01 - a00) + a * (a11 - a10);
    const double dt = t_[k];
    const double du = u_[k] - cx_, dv = v_[k] - cy_;
    // ∂u'/∂h = −dt·[1, 0, du, −dv],  ∂v'/∂h = −dt·[0, 1, dv, du]
    g0 += -dt * dFdu;
    g1 += -dt * dFdv;
    g2 += -dt * (dFdu * du + dFdv * dv);
    g3 += -dt * (-dFdu * dv + dFdv * du);
  }
  const double s = 2.0 / P;
  *grad = {s * g0, s * g1, s * g2, s * g3};
  return F;
}

namespace internal {
namespace {

/// −F(h)/F(0) over scaled parameters q: q0, q1 = shift over the window [px], q2 = radial
/// displacement at radius R over the window [px] (h_z bounded by tanh), q3 = tangential
/// displacement at radius R [px]. Scaling makes all four comparable for L-BFGS.
class ScaledFocus final : public ceres::FirstOrderFunction {
 public:
  ScaledFocus(WarpContrastObjective* objective, double duration_s, double radius_px, double hz_max, double f0)
      : objective_(objective), d_(duration_s), r_(radius_px), hz_max_(hz_max), f0_(f0) {}
  std::array<double, 4> to_h(const double* q) const {
    return {q[0] / d_, q[1] / d_, hz_max_ * std::tanh(q[2] / (hz_max_ * d_ * r_)), q[3] / (d_ * r_)};
  }
  std::array<double, 4> to_q(const std::array<double, 4>& h) const {
    const double z = std::clamp(h[2] / hz_max_, -0.999, 0.999);
    return {h[0] * d_, h[1] * d_, hz_max_ * d_ * r_ * std::atanh(z), h[3] * d_ * r_};
  }
  bool Evaluate(const double* q, double* cost, double* gradient) const override {
    const std::array<double, 4> h = to_h(q);
    std::array<double, 4> g{};
    const double F = objective_->evaluate(h, gradient ? &g : nullptr);
    *cost = -F / f0_;
    if (gradient) {
      const double th = std::tanh(q[2] / (hz_max_ * d_ * r_));
      const double dh[4] = {1 / d_, 1 / d_, (1 - th * th) / (d_ * r_), 1 / (d_ * r_)};
      for (int i = 0; i < 4; ++i) gradient[i] = -g[i] * dh[i] / f0_;
    }
    return std::isfinite(F);
  }
  int NumParameters() const override { return 4; }

 private:
  WarpContrastObjective* objective_;
  double d_, r_, hz_max_, f0_;
};

struct LinearWarpKernel {
  float fx, fy, cx, cy, hx, hy, hz, th;
  void prefetch(int) const {}
  bool operator()(int, NormalizedRay r, float dt, float& u, float& v) const {
    const float u0 = fx * r.x + cx, v0 = fy * r.y + cy;
    const float du = u0 - cx, dv = v0 - cy;
    u = u0 - dt * (hx + hz * du - th * dv);
    v = v0 - dt * (hy + hz * dv + th * du);
    return true;
  }
};

}  // namespace

ContrastMaxCompensator::ContrastMaxCompensator(const Calibration& calibration, const CompensationOptions& options,
                                               std::shared_ptr<const UndistortionMap> map)
    : CompensatorBase(CompensationMethod::kContrastMax, calibration, options, std::move(map)),
      objective_(map_->width(), map_->height(), map_->camera().cx, map_->camera().cy,
                 options.contrast_max.blur_sigma_px) {}

const CompensatedWindow& ContrastMaxCompensator::compensate(const CompensationInput& in) {
  begin_window(in);
  CompensationReport& rep = out_.report;
  const ContrastMaxOptions& cm = options_.contrast_max;
  const PinholeCamera& cam = map_->camera();
  // Events for the fit: uniformly subsampled, valid ones only.
  const std::size_t n = in.events.size();
  const std::size_t stride = std::max<std::size_t>(1, (n + cm.max_fit_events - 1) / cm.max_fit_events);
  fit_u_.clear();
  fit_v_.clear();
  fit_t_.clear();
  const int w = map_->width(), h = map_->height();
  // De-quantisation: an event's true position is anywhere in its pixel. Without this dither every
  // event sits on a pixel centre at h = 0, which makes h = 0 a spurious sharp local maximum of the
  // contrast (any warp spreads the votes) and stops the line search at once. Deterministic
  // (fixed-seed generator) so that results are reproducible.
  std::minstd_rand dither(12345);
  std::uniform_real_distribution<float> half_px(-0.5f, 0.5f);
  for (std::size_t i = 0; i < n; i += stride) {
    const Event& e = in.events[i];
    if (e.t < in.t_start || e.t >= in.t_end || e.x >= w || e.y >= h) continue;
    const NormalizedRay r = map_->ray(e.x, e.y);
    if (std::isnan(r.x)) continue;
    const float du = half_px(dither), dv = half_px(dither);
    fit_u_.push_back(static_cast<float>(cam.fx * r.x + cam.cx) + du);
    fit_v_.push_back(static_cast<float>(cam.fy * r.y + cam.cy) + dv);
    fit_t_.push_back(static_cast<float>(in.t_end > in.t_start ? to_seconds(e.t - in.t_start) : 0.0));
  }
  std::array<double, 4> hsol = cm.warm_start && have_previous_ ? previous_ : std::array<double, 4>{};
  const double duration_s = to_seconds(in.t_end - in.t_start);
  if (fit_u_.size() >= 10 && duration_s > 0) {
    objective_.set_events(fit_u_, fit_v_, fit_t_);
    const double f0 = objective_.evaluate({0, 0, 0, 0}, nullptr);
    if (f0 > 0) {
      const double radius = 0.5 * std::hypot(w, h);
      auto* fn = new ScaledFocus(&objective_, duration_s, radius, cm.max_expansion_per_s, f0);
      std::array<double, 4> q = fn->to_q(hsol);
      ceres::GradientProblem problem(fn);  // takes ownership of fn
      ceres::GradientProblemSolver::Options opt;
      opt.max_num_iterations = cm.max_iterations;
      opt.logging_type = ceres::SILENT;
      opt.function_tolerance = 1e-6;
      ceres::GradientProblemSolver::Summary summary;
      ceres::Solve(opt, problem, q.data(), &summary);
      hsol = fn->to_h(q.data());
      rep.solver_iterations = static_cast<int>(summary.iterations.size());
      rep.solver_converged = summary.termination_type == ceres::CONVERGENCE;
      if (summary.IsSolutionUsable()) {
        previous_ = hsol;
        have_previous_ = true;
      }
    }
  }
  rep.warp_params = hsol;
  LinearWarpKernel k{static_cast<float>(cam.fx), static_cast<float>(cam.fy), static_cast<float>(cam.cx),
                     static_cast<float>(cam.cy), static_cast<float>(hsol[0]), static_cast<float>(hsol[1]),
                     static_cast<float>(hsol[2]), static_cast<float>(hsol[3])};
  run_warp(in, k);
  return out_;
}

Eigen::Vector2d ContrastMaxCompensator::observed_position(const Eigen::Vector2d& px, double t_s) const {
  // The warp (WarpContrastObjective::warp) is linear in (u − cx, v − cy):
  //   [U; V] = [a b; −b a]·[du; dv] − t·[h_x; h_y],  a = 1 − t·h_z, b = t·θ  ->  solve for (du, dv).
  const PinholeCamera& cam = map_->camera();
  const std::array<double, 4>& h = out_.report.warp_params;
  const double a = 1 - t_s * h[2], b = t_s * h[3], det = a * a + b * b;
  if (!(det > 0)) return px;
  const double U = px.x() - cam.cx + t_s * h[0], V = px.y() - cam.cy + t_s * h[1];
  return {cam.cx + (a * U - b * V) / det, cam.cy + (b * U + a * V) / det};
}

}  // namespace internal
}  // namespace fdv
