#include "fdv/pipeline/sensor_buffers.h"

#include <algorithm>

namespace fdv {

bool ImuBuffer::push(const ImuSample& s) {
  if (!samples_.empty() && s.t < samples_.back().t) return false;
  samples_.push_back(s);
  while (samples_.size() > 2 && samples_.front().t < s.t - horizon_ns_) samples_.pop_front();
  return true;
}

std::optional<ImuWindowMean> ImuBuffer::mean_gyro(TimeNs t0, TimeNs t1) const {
  if (samples_.empty() || t1 < t0) return std::nullopt;
  // Samples that bracket the interval: the last one at or before t0 through the first at or after t1.
  auto first = std::upper_bound(samples_.begin(), samples_.end(), t0,
                                [](TimeNs t, const ImuSample& s) { return t < s.t; });
  if (first != samples_.begin()) --first;
  auto last = std::lower_bound(samples_.begin(), samples_.end(), t1,
                               [](const ImuSample& s, TimeNs t) { return s.t < t; });
  if (last == samples_.end()) --last;
  ImuWindowMean out;
  // Coverage: distance from the interval's ends to the nearest samples counts as a gap too.
  out.largest_gap_ns = std::max<TimeNs>({0, first->t - t0, t1 - last->t});
  for (auto it = first; it != last; ++it) out.largest_gap_ns = std::max(out.largest_gap_ns, (it + 1)->t - it->t);
  if (std::abs(first->t - t0) > max_gap_ns_ && std::abs(last->t - t1) > max_gap_ns_ && first == last)
    return std::nullopt;
  out.gap = out.largest_gap_ns > max_gap_ns_;
  out.samples = static_cast<int>(last - first) + 1;
  if (first == last || t1 == t0) {
    out.gyro_rad_s = first->gyro_rad_s;
    return out;
  }
  // Integrate the piecewise-linear signal over [t0, t1] (clamped to the ends).
  Eigen::Vector3d integral = Eigen::Vector3d::Zero();
  auto value_at = [](const ImuSample& a, const ImuSample& b, TimeNs t) -> Eigen::Vector3d {
    if (b.t == a.t) return a.gyro_rad_s;
    const double w = static_cast<double>(t - a.t) / static_cast<double>(b.t - a.t);
    return (1 - w) * a.gyro_rad_s + w * b.gyro_rad_s;
  };
  if (t0 < first->t) integral += first->gyro_rad_s * static_cast<double>(first->t - t0);
  if (t1 > last->t) integral += last->gyro_rad_s * static_cast<double>(t1 - last->t);
  for (auto it = first; it != last; ++it) {
    const ImuSample& a = *it;
    const ImuSample& b = *(it + 1);
    const TimeNs lo = std::max(a.t, t0), hi = std::min(b.t, t1);
    if (hi <= lo) continue;
    integral += 0.5 * (value_at(a, b, lo) + value_at(a, b, hi)) * static_cast<double>(hi - lo);
  }
  out.gyro_rad_s = integral / static_cast<double>(t1 - t0);
  return out;
}

bool OdometryBuffer::push(const OdometrySample& s) {
  if (!samples_.empty() && s.t < samples_.back().t) return false;
  samples_.push_back(s);
  while (samples_.size() > 2 && samples_.front().t < s.t - horizon_ns_) samples_.pop_front();
  return true;
}

std::optional<OdometrySample> OdometryBuffer::at(TimeNs t) const {
  if (samples_.empty()) return std::nullopt;
  const OdometrySample& lo = samples_.front();
  const OdometrySample& hi = samples_.back();
  if (t < lo.t - max_extrapolation_ns_ || t > hi.t + max_extrapolation_ns_) return std::nullopt;
  if (t >= lo.t && t <= hi.t) {
    auto it = std::lower_bound(samples_.begin(), samples_.end(), t,
                               [](const OdometrySample& x, TimeNs tt) { return x.t < tt; });
    if (it == samples_.begin()) return *it;
    return interpolate_between(*(it - 1), *it, t);
  }
  OdometrySample s = t < lo.t ? lo : hi;  // constant-velocity extrapolation, attitude held
  s.p_W_B += s.v_W * to_seconds(t - s.t);
  s.t = t;
  return s;
}

}  // namespace fdv
