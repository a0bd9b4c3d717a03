#include "fdv/estimation/camera_pose.h"

#include <algorithm>
#include <cstdint>

namespace fdv {

namespace {

OdometrySample extrapolate(const OdometrySample& s, TimeNs t) {
  const double dt = to_seconds(t - s.t);
  OdometrySample out = s;
  out.t = t;
  out.p_W_B = s.p_W_B + dt * s.v_W;
  const Eigen::Vector3d rot = dt * s.omega_B;  // body-frame rotation vector over dt
  if (rot.norm() > 0)
    out.q_W_B = (s.q_W_B * Eigen::Quaterniond(Eigen::AngleAxisd(rot.norm(), rot.normalized())))
                    .normalized();
  return out;
}

}  // namespace

std::optional<OdometrySample> body_state_at(const std::vector<OdometrySample>& odometry, TimeNs t,
                                            TimeNs max_extrapolation_ns) {
  if (odometry.empty()) return std::nullopt;
  // later - earlier of two times, exact even when it exceeds int64 (times from either end of it).
  const auto gap = [](TimeNs earlier, TimeNs later) {
    return static_cast<std::uint64_t>(later) - static_cast<std::uint64_t>(earlier);
  };
  const auto limit = static_cast<std::uint64_t>(std::max<TimeNs>(0, max_extrapolation_ns));
  if (t < odometry.front().t) {
    if (gap(t, odometry.front().t) > limit) return std::nullopt;
    return extrapolate(odometry.front(), t);
  }
  if (t > odometry.back().t) {
    if (gap(odometry.back().t, t) > limit) return std::nullopt;
    return extrapolate(odometry.back(), t);
  }
  return interpolate_odometry(odometry, t);
}

std::optional<Eigen::Isometry3d> camera_pose_at(const std::vector<OdometrySample>& odometry,
                                                TimeNs t, const Eigen::Isometry3d& T_B_C,
                                                TimeNs max_extrapolation_ns) {
  const auto s = body_state_at(odometry, t, max_extrapolation_ns);
  if (!s) return std::nullopt;
  return s->T_W_B() * T_B_C;
}

}  // namespace fdv
