#pragma once
/// 4-lane float / int32 / double vectors (GCC and clang vector extensions) for the per-pixel and
/// per-event loops of the renderer, compensation and detection.
///
///   using namespace fdv::lanes;
///   const vf x = load(&xs[i]);
///   store(&ys[i], select(x < 0, -x, x) * splat(2.0f));
///
/// 16-byte vectors map one-to-one onto baseline x86-64 SSE2 and aarch64 NEON instructions (wider
/// vectors are split lane by lane by GCC without AVX, slower than scalar code). No intrinsics and
/// no fused multiply-add (x86-64's baseline and AVX2 have none; GCC for aarch64 would fuse
/// a * b + c unless built with -ffp-contract=off, as cmake/aarch64-linux-gnu.cmake does), so the
/// results equal the scalar code's, on every machine. Comparisons give int lanes of -1 or 0.
///
/// Unaligned loads and stores go through vector types aligned like their element, not memcpy: a
/// memcpy store may alias anything, and GCC then reloads every pointer after each store.
#include <bit>
#include <cstdint>

/// FDV_AVX2_CLONES before a hot function: GCC on x86-64 builds it twice, for AVX2 and the baseline,
/// and picks one at load time. Elsewhere it builds once: clang rejects target_clones on templates
/// and beside `flatten`, and aarch64 (Jetson-class boards) has no such targets. These lanes use
/// no FMA, so on x86-64 the clones and the single build give the same results to the bit.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define FDV_AVX2_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define FDV_AVX2_CLONES
#endif

namespace fdv::lanes {

inline constexpr int kLanes = 4;
using vf = float __attribute__((vector_size(16)));
using vi = std::int32_t __attribute__((vector_size(16)));
using vd = double __attribute__((vector_size(16)));
// typedef, not `using`: clang ignores `aligned` in an alias declaration's attribute.
typedef float vf_u __attribute__((vector_size(16), aligned(4)));
typedef std::int32_t vi_u __attribute__((vector_size(16), aligned(4)));
static_assert(alignof(vf_u) == 4 && alignof(vi_u) == 4);

inline vf load(const float* p) { return *reinterpret_cast<const vf_u*>(p); }
inline vi load(const std::int32_t* p) { return *reinterpret_cast<const vi_u*>(p); }
inline void store(float* p, vf v) { *reinterpret_cast<vf_u*>(p) = v; }
inline void store(std::int32_t* p, vi v) { *reinterpret_cast<vi_u*>(p) = v; }
inline vf splat(float x) { return vf{} + x; }
inline vi splat_i(std::int32_t x) { return vi{} + x; }
/// The lanes' bit patterns, and back.
inline vi bits(vf v) { return std::bit_cast<vi>(v); }
inline vf from_bits(vi v) { return std::bit_cast<vf>(v); }
/// Per lane: m ? a : b. Bitwise, since `?:` on vectors is lowered lane by lane.
inline vi select(vi m, vi a, vi b) { return (a & m) | (b & ~m); }
inline vf select(vi m, vf a, vf b) { return from_bits(select(m, bits(a), bits(b))); }
inline vf abs(vf x) { return select(x < 0, -x, x); }
inline vf min(vf a, vf b) { return select(a < b, a, b); }
inline vf max(vf a, vf b) { return select(a > b, a, b); }
inline bool any(vi m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }
inline bool all_equal(vi v) { return v[1] == v[0] && v[2] == v[0] && v[3] == v[0]; }
inline vf to_float(vi v) { return __builtin_convertvector(v, vf); }
/// floor() for |x| < 2^31.
inline vi floor_i(vf x) {
  const vi t = __builtin_convertvector(x, vi);  // toward zero
  return t + (x < to_float(t));                 // -1 where truncation rounded up
}

}  // namespace fdv::lanes
