#pragma once
/// 4-lane float / int32 / double vectors (GCC vector extensions) for the per-pixel and per-event
/// loops of compensation and detection: 16-byte vectors map onto baseline x86-64 SSE2, no FMA, so
/// results equal the scalar code's. Comparisons give int lanes of -1 (true) or 0.
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
/// The lanes' bit patterns, and back.
inline vi bits(vf v) { return std::bit_cast<vi>(v); }
inline vf from_bits(vi v) { return std::bit_cast<vf>(v); }
/// Per lane: m ? a : b.
inline vf select(vi m, vf a, vf b) { return from_bits((bits(a) & m) | (bits(b) & ~m)); }
inline bool any(vi m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }

}  // namespace fdv::lanes
