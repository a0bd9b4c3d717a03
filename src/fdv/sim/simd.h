#pragma once
/// 4-lane float/int vectors (GCC/Clang vector extensions) for the renderer's inner loop.
///
/// Portable: 16-byte vectors map one-to-one onto baseline x86-64 SSE2 instructions (wider
/// vectors are split lane by lane by GCC without AVX, which is slower than scalar code); no
/// target-specific flags or intrinsics are used, and IEEE results are the same as the scalar
/// code's (no fused multiply-add), so output is identical on every x86-64 machine.
/// Comparisons give int lanes of -1 (true) or 0; `select(mask, a, b)` picks per lane.
#include <bit>
#include <cstdint>
#include <cstring>

namespace fdv::sim::simd {

inline constexpr int kLanes = 4;
using vf = float __attribute__((vector_size(16)));
using vi = std::int32_t __attribute__((vector_size(16)));

inline vf load(const float* p) {
  vf v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store(float* p, vf v) { std::memcpy(p, &v, sizeof v); }
inline vf splat(float x) { return vf{} + x; }
inline vi splat_i(std::int32_t x) { return vi{} + x; }
// Bitwise blends (also fine for wider vectors, where `?:` is lowered lane by lane).
inline vi select(vi m, vi a, vi b) { return (a & m) | (b & ~m); }
inline vf select(vi m, vf a, vf b) {
  return std::bit_cast<vf>(select(m, std::bit_cast<vi>(a), std::bit_cast<vi>(b)));
}
inline vf abs(vf x) { return select(x < 0, -x, x); }
inline vf min(vf a, vf b) { return select(a < b, a, b); }
inline vf max(vf a, vf b) { return select(a > b, a, b); }
inline bool any(vi m) {
  std::int32_t r = 0;
  for (int i = 0; i < kLanes; ++i) r |= m[i];
  return r != 0;
}
inline bool all_equal(vi v) {
  for (int i = 1; i < kLanes; ++i)
    if (v[i] != v[0]) return false;
  return true;
}
inline vf to_float(vi v) { return __builtin_convertvector(v, vf); }
/// floor() for |x| < 2^31.
inline vi floor_i(vf x) {
  const vi t = __builtin_convertvector(x, vi);  // toward zero
  return t + (x < to_float(t));                 // -1 where truncation rounded up
}

/// Lane-wise version of fast_log (fast_math.h), same polynomial.
inline vf fast_log(vf x) {
  const vi bits = std::bit_cast<vi>(x);
  const vf e = to_float((bits >> 23) - 127);
  const vi mbits = (bits & 0x007FFFFF) | 0x3F800000;
  const vf t = std::bit_cast<vf>(mbits) - 1.0f;
  const vf poly =
      0.442501684f +
      t * (-0.275166449f + t * (0.180576484f + t * (-0.0942558371f + t * 0.0251255737f)));
  return (e + t + t * (1.0f - t) * poly) * 0.693147181f;
}

/// Lane-wise version of fast_exp (fast_math.h), same polynomial.
inline vf fast_exp(vf x) {
  vf y = x * 1.44269504f;
  y = max(min(y, splat(127.0f)), splat(-126.0f));
  const vi n = floor_i(y);
  const vf f = y - to_float(n);
  const vf poly = -0.306846411f + f * (-0.0667022217f + f * (-0.010843654f + f * -0.00189521151f));
  const vf two_f = 1.0f + f + f * (1.0f - f) * poly;
  const vi scale_bits = (n + 127) << 23;
  return std::bit_cast<vf>(scale_bits) * two_f;
}

}  // namespace fdv::sim::simd
