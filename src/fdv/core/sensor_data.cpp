#include "fdv/core/sensor_data.h"

#include <algorithm>
#include <cassert>

namespace fdv {

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
