#include "fdv/core/sensor_data.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "fdv/core/camera.h"

namespace fdv {

const char* why_invalid(const ImuSample& s) {
  if (!valid_time(s.t)) return "time out of range (corrupt)";
  if (!s.gyro_rad_s.allFinite() || !s.accel_m_s2.allFinite()) return "non-finite value";
  return nullptr;
}

const char* why_invalid(const OdometrySample& s) {
  if (!valid_time(s.t)) return "time out of range (corrupt)";
  if (!s.p_W_B.allFinite() || !s.q_W_B.coeffs().allFinite() || !s.v_W.allFinite() || !s.omega_B.allFinite())
    return "non-finite value";
  if (!(std::abs(s.q_W_B.norm() - 1.0) <= kUnitQuaternionTolerance)) return "quaternion is not unit length";
  return nullptr;
}

const char* why_invalid(const DepthFrame& f) {
  if (!valid_time(f.t)) return "time out of range (corrupt)";
  if (f.width < 1 || f.height < 1 || f.width > kMaxCameraSide || f.height > kMaxCameraSide)
    return "image size outside 1..4096";
  static_assert(kMaxCameraSide == 4096, "the reason above names the cap");
  if (f.depth_m.size() != static_cast<std::size_t>(f.width) * static_cast<std::size_t>(f.height))
    return "pixel count differs from width x height";
  return nullptr;
}

OdometrySample interpolate_odometry(const std::vector<OdometrySample>& samples, TimeNs t) {
  assert(!samples.empty());
  if (t <= samples.front().t) return samples.front();
  if (t >= samples.back().t) return samples.back();
  auto hi = std::lower_bound(samples.begin(), samples.end(), t,
                             [](const OdometrySample& s, TimeNs tt) { return s.t < tt; });
  return interpolate_between(*(hi - 1), *hi, t);
}

OdometrySample interpolate_between(const OdometrySample& lo, const OdometrySample& hi, TimeNs t) {
  const double a = hi.t == lo.t ? 0.0 : static_cast<double>(t - lo.t) / static_cast<double>(hi.t - lo.t);
  OdometrySample out;
  out.t = t;
  out.p_W_B = (1 - a) * lo.p_W_B + a * hi.p_W_B;
  out.q_W_B = lo.q_W_B.slerp(a, hi.q_W_B);
  out.v_W = (1 - a) * lo.v_W + a * hi.v_W;
  out.omega_B = (1 - a) * lo.omega_B + a * hi.omega_B;
  return out;
}

}  // namespace fdv
