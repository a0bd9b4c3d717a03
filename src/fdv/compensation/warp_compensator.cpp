#include "fdv/compensation/warp_compensator.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace fdv::internal {
namespace {

/// Rotation only: X ∝ (K·R_s)·[x; y; 1].
struct RotationKernel {
  const float* slots;
  float slots_per_s;
  int last_slot;
  void prefetch(int) const {}
  bool operator()(int, NormalizedRay r, float dt, float& u, float& v) const {
    const int s = std::min(static_cast<int>(dt * slots_per_s), last_slot);
    const float* m = slots + 9 * s;
    const float X = m[0] * r.x + m[1] * r.y + m[2];
    const float Y = m[3] * r.x + m[4] * r.y + m[5];
    const float Z = m[6] * r.x + m[7] * r.y + m[8];
    if (!(Z > 1e-6f)) return false;
    const float iz = 1.0f / Z;
    u = X * iz;
    v = Y * iz;
    return true;
  }
};

/// Rotation and translation: X ∝ (K·R_s)·[x; y; 1] + ρ·(t − t0)·(K·v).
/// inv_depth holds ρ per raw pixel with the sign bit set where the missing-depth policy was
/// applied (one table, one lookup per event).
struct RotationTranslationKernel {
  const float* slots;
  float slots_per_s;
  int last_slot;
  const float* inv_depth;
  float kv[3];
  std::uint64_t fallback_events = 0;
  void prefetch(int raw) const { __builtin_prefetch(inv_depth + raw); }
  bool operator()(int raw, NormalizedRay r, float dt, float& u, float& v) {
    const int s = std::min(static_cast<int>(dt * slots_per_s), last_slot);
    const float* m = slots + 9 * s;
    const float stored = inv_depth[raw];
    fallback_events += std::signbit(stored);
    const float rho_dt = std::fabs(stored) * dt;
    const float X = m[0] * r.x + m[1] * r.y + m[2] + rho_dt * kv[0];
    const float Y = m[3] * r.x + m[4] * r.y + m[5] + rho_dt * kv[1];
    const float Z = m[6] * r.x + m[7] * r.y + m[8] + rho_dt * kv[2];
    if (!(Z > 1e-6f)) return false;
    const float iz = 1.0f / Z;
    u = X * iz;
    v = Y * iz;
    return true;
  }
};

}  // namespace

WarpCompensator::WarpCompensator(CompensationMethod method, const Calibration& calibration,
                                 const CompensationOptions& options, std::shared_ptr<const UndistortionMap> map)
    : CompensatorBase(method, calibration, options, std::move(map)) {}

void WarpCompensator::build_rotation_slots(const Eigen::Vector3d& omega_E, TimeNs duration_ns) {
  const TimeNs refresh = options_.rotation_refresh_ns;
  const int n = static_cast<int>(std::max<TimeNs>(1, (duration_ns + refresh - 1) / refresh));
  slots_.resize(static_cast<std::size_t>(n) * 9);  // grows once, then reused
  const PinholeCamera& cam = map_->camera();
  for (int s = 0; s < n; ++s) {
    const TimeNs a = s * refresh, b = std::min<TimeNs>((s + 1) * refresh, duration_ns);
    const double t_mid = 0.5 * to_seconds(a + std::max(a, b));
    // Rodrigues' formula (Eigen's AngleAxis): rotation by angle |ω|·t about ω/|ω|.
    const double angle = omega_E.norm() * t_mid;
    const Eigen::Matrix3d R = angle > 0 ? Eigen::AngleAxisd(angle, omega_E.normalized()).toRotationMatrix()
                                        : Eigen::Matrix3d::Identity();
    float* m = slots_.data() + 9 * s;
    for (int c = 0; c < 3; ++c) {
      m[c] = static_cast<float>(cam.fx * R(0, c) + cam.cx * R(2, c));
      m[3 + c] = static_cast<float>(cam.fy * R(1, c) + cam.cy * R(2, c));
      m[6 + c] = static_cast<float>(R(2, c));
    }
  }
  slots_per_s_ = static_cast<float>(1e9 / static_cast<double>(refresh));
  last_slot_ = n - 1;
}

bool WarpCompensator::prepare_depth(const RegisteredDepth& depth) {
  if (&depth == depth_key_ && depth.depth_m.data() == depth_data_key_ && depth.t == depth_t_key_) return depth_usable_;
  depth_key_ = &depth;
  depth_data_key_ = depth.depth_m.data();
  depth_t_key_ = depth.t;
  const int w = depth.width, h = depth.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  inv_raw_.create(h, w, CV_32F);
  median_scratch_.clear();
  // Median of the valid depths (strided so that at most ~50 k values are sorted).
  const std::size_t stride = std::max<std::size_t>(1, n / 50'000);
  for (std::size_t i = 0; i < n; ++i) {
    const float z = depth.depth_m[i];
    const bool valid = z > 0 && std::isfinite(z);
    inv_raw_.ptr<float>()[i] = valid ? 1.0f / z : 0.0f;
    if (valid && i % stride == 0) median_scratch_.push_back(z);
  }
  if (median_scratch_.empty()) {
    depth_usable_ = false;
    return false;
  }
  auto mid = median_scratch_.begin() + static_cast<std::ptrdiff_t>(median_scratch_.size() / 2);
  std::nth_element(median_scratch_.begin(), mid, median_scratch_.end());
  fallback_depth_m_ = *mid;
  // Pinholes: the nearest surface among the neighbours (largest inverse depth).
  const int r = options_.hole_fill_radius_px;
  if (r > 0) {
    cv::dilate(inv_raw_, inv_dilated_, cv::getStructuringElement(cv::MORPH_RECT, {2 * r + 1, 2 * r + 1}));
  }
  const float fallback_rho =
      options_.missing_depth == MissingDepthPolicy::kMedianDepth ? 1.0f / fallback_depth_m_ : 0.0f;
  inv_depth_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    float rho = inv_raw_.ptr<float>()[i];
    if (rho == 0 && r > 0) rho = inv_dilated_.ptr<float>()[i];
    inv_depth_[i] = rho == 0 ? -fallback_rho : rho;  // −0.0f still carries the sign bit
  }
  depth_usable_ = true;
  return true;
}

const CompensatedWindow& WarpCompensator::compensate(const CompensationInput& in) {
  const ImuWindowSummary imu = begin_window(in);
  CompensationReport& rep = out_.report;
  CompensationMethod used = method_;
  if (used != CompensationMethod::kNone && !imu.available) {
    rep.imu_missing = true;
    used = CompensationMethod::kNone;
  }
  if (used == CompensationMethod::kRotationTranslation) {
    const TimeNs t_mid = in.t_start_ns + (in.t_end_ns - in.t_start_ns) / 2;
    if (!rep.has_velocity) {
      rep.odometry_missing = true;
    } else if (!in.depth || in.depth->empty()) {
      rep.depth_missing = true;
    } else if (in.depth->width != map_->width() || in.depth->height != map_->height() ||
               in.depth->depth_m.size() != static_cast<std::size_t>(map_->width()) * map_->height()) {
      rep.depth_wrong_size = true;
    } else if ((rep.depth_age_ns = std::abs(t_mid - in.depth->t)) > options_.max_depth_age_ns) {
      rep.depth_stale = true;
    } else if (!prepare_depth(*in.depth)) {
      rep.depth_missing = true;  // a frame without a single valid depth
    }
    if (rep.odometry_missing || rep.depth_missing || rep.depth_wrong_size || rep.depth_stale)
      used = CompensationMethod::kRotation;
  }
  rep.used = used;
  const PinholeCamera& cam = map_->camera();
  if (used == CompensationMethod::kNone) {
    IdentityKernel k{static_cast<float>(cam.fx), static_cast<float>(cam.fy), static_cast<float>(cam.cx),
                     static_cast<float>(cam.cy)};
    run_warp(in, k);
    return out_;
  }
  build_rotation_slots(rep.omega_E, in.t_end_ns - in.t_start_ns);
  if (used == CompensationMethod::kRotation) {
    RotationKernel k{slots_.data(), slots_per_s_, last_slot_};
    run_warp(in, k);
    return out_;
  }
  const Eigen::Vector3d& v = rep.v_E;
  RotationTranslationKernel k{slots_.data(), slots_per_s_, last_slot_, inv_depth_.data(),
                              {static_cast<float>(cam.fx * v.x() + cam.cx * v.z()),
                               static_cast<float>(cam.fy * v.y() + cam.cy * v.z()), static_cast<float>(v.z())}};
  run_warp(in, k);
  rep.depth_fallback_events = k.fallback_events;
  if (options_.missing_depth == MissingDepthPolicy::kMedianDepth) rep.fallback_depth_m = fallback_depth_m_;
  return out_;
}

}  // namespace fdv::internal
