#include "fdv/compensation/imu_window.h"

#include <algorithm>
#include <cmath>
#include <Eigen/Geometry>
#include <limits>

namespace fdv {

ImuWindowSummary summarize_imu(std::span<const ImuSample> imu, TimeNs t0, TimeNs t1, TimeNs max_gap_ns) {
  ImuWindowSummary out;
  if (t1 < t0) return out;
  // Usable samples near the window, in order. The bracketing samples (last at/before t0 - gap,
  // first at/after t1 + gap) are not needed: beyond max_gap_ns the signal is not trusted anyway.
  const TimeNs lo = t0 - max_gap_ns, hi = t1 + max_gap_ns;
  const ImuSample* prev = nullptr;  // previous usable sample (for the piecewise-linear integral)
  const ImuSample* first = nullptr;
  Eigen::Vector3d integral = Eigen::Vector3d::Zero();  // [rad/s · ns]
  TimeNs largest_gap = 0;
  TimeNs last_t = std::numeric_limits<TimeNs>::min();
  for (const ImuSample& s : imu) {
    if (s.t < lo || s.t > hi) {
      if (s.t < last_t) ++out.samples_skipped;
      last_t = std::max(last_t, s.t);
      continue;
    }
    if (s.t < last_t || !s.gyro_rad_s.allFinite()) {
      ++out.samples_skipped;
      continue;
    }
    last_t = s.t;
    if (!first) first = &s;
    if (prev) {
      const TimeNs a = std::max(prev->t, t0), b = std::min(s.t, t1);
      if (prev->t < t1 && s.t > t0) largest_gap = std::max(largest_gap, s.t - prev->t);
      if (b > a && s.t > prev->t) {
        const double span = static_cast<double>(s.t - prev->t);
        const double wa = static_cast<double>(a - prev->t) / span, wb = static_cast<double>(b - prev->t) / span;
        const Eigen::Vector3d ga = (1 - wa) * prev->gyro_rad_s + wa * s.gyro_rad_s;
        const Eigen::Vector3d gb = (1 - wb) * prev->gyro_rad_s + wb * s.gyro_rad_s;
        integral += 0.5 * (ga + gb) * static_cast<double>(b - a);
      }
    }
    prev = &s;
    ++out.samples_used;
  }
  if (!first) return out;
  const ImuSample* last = prev;
  // Held constant before the first and after the last sample.
  if (first->t > t0) integral += first->gyro_rad_s * static_cast<double>(std::min(first->t, t1) - t0);
  if (last->t < t1) integral += last->gyro_rad_s * static_cast<double>(t1 - std::max(last->t, t0));
  largest_gap = std::max({largest_gap, first->t - t0, t1 - last->t});
  out.available = true;
  out.largest_gap_ns = largest_gap;
  out.gap = largest_gap > max_gap_ns;
  out.mean_gyro_I = t1 > t0 ? Eigen::Vector3d(integral / static_cast<double>(t1 - t0)) : first->gyro_rad_s;
  return out;
}

std::optional<Eigen::Matrix3d> imu_turn(std::span<const ImuSample> imu, TimeNs t0, TimeNs t1, TimeNs max_gap_ns) {
  if (t1 < t0) {
    const auto back = imu_turn(imu, t1, t0, max_gap_ns);
    return back ? std::optional<Eigen::Matrix3d>(back->transpose()) : std::nullopt;
  }
  constexpr TimeNs kStepNs = 5 * kNsPerMs;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  for (TimeNs a = t0; a < t1; a += kStepNs) {
    const TimeNs b = std::min(a + kStepNs, t1);
    const ImuWindowSummary s = summarize_imu(imu, a, b, max_gap_ns);
    if (!s.available) return std::nullopt;
    const Eigen::Vector3d angle = -s.mean_gyro_I * to_seconds(b - a);
    if (angle.norm() > 0) R = Eigen::AngleAxisd(angle.norm(), angle.normalized()).toRotationMatrix() * R;
  }
  return R;
}

}  // namespace fdv
