#pragma once
/// Fast, smooth float log and exp for the renderer's per-pixel loop, per value and per 4 lanes.
///
///   const float l = fast_log(x);                    // ln x
///   const lanes::vf e = fast_exp(lanes::splat(l));  // x in every lane
///
/// Both split off the binary exponent and approximate the mantissa part with a polynomial that
/// is exact at both ends of its interval, so the result is continuous (no steps that a DVS
/// pixel could mistake for a brightness change) and monotonic. Errors: |fast_log(x) - ln x| <
/// 3e-6 for normal positive x; |fast_exp(x) / e^x - 1| < 2e-7 for |x| < 80 (fitted by least
/// squares on 4000 points; see docs/SIMULATOR.md). Intended for log intensities, where the
/// contrast thresholds are ~0.25.
#include <bit>
#include <cstdint>

#include "fdv/core/lanes.h"

namespace fdv::sim {

/// ln(x) for x > 0 (finite, normal).
inline float fast_log(float x) {
  const auto bits = std::bit_cast<std::uint32_t>(x);
  const float e = static_cast<float>(static_cast<int>(bits >> 23) - 127);
  const float t = std::bit_cast<float>((bits & 0x007FFFFFu) | 0x3F800000u) - 1.0f;  // [0, 1)
  // log2(1 + t) = t + t (1 - t) (a0 + a1 t + a2 t² + a3 t³ + a4 t⁴)
  const float poly =
      0.442501684f +
      t * (-0.275166449f + t * (0.180576484f + t * (-0.0942558371f + t * 0.0251255737f)));
  return (e + t + t * (1.0f - t) * poly) * 0.693147181f;
}

/// e^x, clamped to the normal float range.
inline float fast_exp(float x) {
  float y = x * 1.44269504f;  // log2(e)
  y = y < -126.0f ? -126.0f : (y > 127.0f ? 127.0f : y);
  int n = static_cast<int>(y);
  n -= y < static_cast<float>(n);
  const float f = y - static_cast<float>(n);  // [0, 1)
  // 2^f = 1 + f + f (1 - f) (b0 + b1 f + b2 f² + b3 f³)
  const float poly =
      -0.306846411f + f * (-0.0667022217f + f * (-0.010843654f + f * -0.00189521151f));
  const float two_f = 1.0f + f + f * (1.0f - f) * poly;
  return std::bit_cast<float>(static_cast<std::uint32_t>(n + 127) << 23) * two_f;
}

/// Lane-wise fast_log, the same polynomial.
inline lanes::vf fast_log(lanes::vf x) {
  using namespace lanes;
  const vi bits = std::bit_cast<vi>(x);
  const vf e = to_float((bits >> 23) - 127);
  const vi mbits = (bits & 0x007FFFFF) | 0x3F800000;
  const vf t = std::bit_cast<vf>(mbits) - 1.0f;
  const vf poly =
      0.442501684f +
      t * (-0.275166449f + t * (0.180576484f + t * (-0.0942558371f + t * 0.0251255737f)));
  return (e + t + t * (1.0f - t) * poly) * 0.693147181f;
}

/// Lane-wise fast_exp, the same polynomial.
inline lanes::vf fast_exp(lanes::vf x) {
  using namespace lanes;
  vf y = x * 1.44269504f;
  y = max(min(y, splat(127.0f)), splat(-126.0f));
  const vi n = floor_i(y);
  const vf f = y - to_float(n);
  const vf poly = -0.306846411f + f * (-0.0667022217f + f * (-0.010843654f + f * -0.00189521151f));
  const vf two_f = 1.0f + f + f * (1.0f - f) * poly;
  const vi scale_bits = (n + 127) << 23;
  return std::bit_cast<vf>(scale_bits) * two_f;
}

}  // namespace fdv::sim
