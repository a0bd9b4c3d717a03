#include "fdv/compensation/warp_compensator.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "fdv/compensation/imu_window.h"
#include "fdv/core/lanes.h"
#include "fdv/core/thread_pool.h"

namespace fdv::internal {
namespace {

// The per-event loop of the three IMU / odometry driven strategies (reference_warp.h is the plain
// version it is tested against). Why it looks like this (docs/BENCHMARKS.md has the figures):
//  - events are taken four at a time; the arithmetic runs on 4-lane GCC vector extensions
//    (baseline SSE2, no FMA: lane results equal the scalar code's, operation for operation);
//  - events are time-sorted, so a whole quad nearly always shares one refresh slot: its K·R_s
//    is broadcast once; a quad that straddles a slot boundary (25 per window) or holds
//    out-of-order events takes the scalar path, each event with its own slot;
//  - dropping is branch-free: every lane is written at the output position and the position
//    advances only for kept events;
//  - an AVX2 clone is chosen at run time: the same 4-lane operations in VEX form, whose
//    three-operand instructions spare most of the SSE2 build's register copies and reloads of
//    spilled constants (no FMA, checked with objdump: the results are the baseline's to the bit).
using lanes::bits;
using lanes::from_bits;
using lanes::load;
using lanes::select;
using lanes::store;
using lanes::vf;
using lanes::vi;

/// Lane-wise `a > b ? a : b`, as the scalar code writes it.
vf vmax(vf a, vf b) { return select(a > b, a, b); }

enum class Model { kNone, kRotation, kRotationTranslation };
constexpr int kMaxParts = 64;  // CompensationOptions::threads ≤ 64
/// Every how many pixels a depth frame is sampled for the missing-depth policy's depth: about 50 k
/// valid depths are sorted per frame.
std::size_t depth_sample_stride(std::size_t pixels) { return std::max<std::size_t>(1, pixels / 50'000); }

/// Everything the loop reads, for one window.
struct WarpParams {
  const Event* events = nullptr;
  std::size_t stride = 1;  ///< overload decimation: every stride-th event is visited
  const NormalizedRay* rays = nullptr;
  int width = 0, height = 0;
  TimeNs t0 = 0, duration = 0, refresh = 1;
  const float* slots = nullptr;      ///< K·R_s per slot, row-major 3x3
  const float* inv_depth = nullptr;  ///< ρ per raw pixel, sign bit = missing-depth policy applied
  float kv[3] = {0, 0, 0};           ///< K·v
  float fx = 0, fy = 0, cx = 0, cy = 0;
};

struct WarpCounts {
  std::size_t kept = 0;
  std::uint64_t outside_window = 0, outside_sensor = 0, no_inverse = 0, left = 0, out_of_order = 0, fallback = 0;
};

struct Output {
  float* x;
  float* y;
  float* t;
  std::int32_t* pixel;
};

/// One event (the scalar path): warp of ray (rx, ry) at dt with slot matrix m and stored ρ.
/// Returns whether the event is kept; u, v, pixel are written either way. Same operations, in the
/// same order, as one lane of warp_quad().
template <Model M>
bool warp_one(const WarpParams& p, [[maybe_unused]] const float* m, float rx, float ry, [[maybe_unused]] float dt,
              [[maybe_unused]] float stored_rho, float& u, float& v, std::int32_t& pixel) {
  bool front = true;
  if constexpr (M == Model::kNone) {
    u = p.fx * rx + p.cx;
    v = p.fy * ry + p.cy;
  } else {
    float X = m[0] * rx + m[1] * ry + m[2];
    float Y = m[3] * rx + m[4] * ry + m[5];
    float Z = m[6] * rx + m[7] * ry + m[8];
    if constexpr (M == Model::kRotationTranslation) {
      const float rho_dt = std::fabs(stored_rho) * dt;
      X = X + rho_dt * p.kv[0];
      Y = Y + rho_dt * p.kv[1];
      Z = Z + rho_dt * p.kv[2];
    }
    front = Z > 1e-6f;
    const float iz = 1.0f / Z;
    u = X * iz;
    v = Y * iz;
  }
  const float u_hi = static_cast<float>(p.width) - 0.5f, v_hi = static_cast<float>(p.height) - 0.5f;
  const bool keep = front && u >= -0.5f && u < u_hi && v >= -0.5f && v < v_hi;
  // Nearest pixel: in range, u + 0.5 >= 0, so truncation is floor (round half up).
  pixel = keep ? static_cast<std::int32_t>(v + 0.5f) * p.width + static_cast<std::int32_t>(u + 0.5f) : 0;
  return keep;
}

/// True when every lane of the mask is set.
bool all_set(vi m) {
#if defined(__SSE__)
  return __builtin_ia32_movmskps(from_bits(m)) == 0xF;
#else
  return (m[0] & m[1] & m[2] & m[3]) != 0;
#endif
}

/// Visits [begin, end) (visit k = event k·stride), writes the kept events from `out` on.
/// previous_t: time of the event visited before `begin` (for the out-of-order count).
/// kDecimated: false when stride = 1 (nearly always): the event addresses need no multiplication.
template <Model M, bool kDecimated>
FDV_AVX2_CLONES WarpCounts warp_range(const WarpParams& p, std::size_t begin, std::size_t end, TimeNs previous_t, Output out) {
  const std::size_t stride = kDecimated ? p.stride : 1;
  WarpCounts c;
  const int w = p.width, h = p.height;
  const auto duration = static_cast<std::uint64_t>(p.duration);
  std::size_t n = 0;
  // The refresh slot of the fast path, in absolute time [slot_t0, slot_t1) (the whole window for
  // "none"), and its K·R_s.
  TimeNs slot_t0 = 0, slot_t1 = 0;
  const float* m = p.slots;
  vf m0{}, m1{}, m2{}, m3{}, m4{}, m5{}, m6{}, m7{}, m8{};
  auto set_slot = [&](TimeNs d) {  // d in [0, duration)
    if constexpr (M == Model::kNone) {
      slot_t0 = p.t0;
      slot_t1 = p.t0 + p.duration;
    } else {
      const TimeNs s = d / p.refresh;  // never past the last slot
      slot_t0 = p.t0 + s * p.refresh;
      slot_t1 = p.t0 + std::min(p.duration, (s + 1) * p.refresh);
      m = p.slots + 9 * s;
      m0 = vf{} + m[0], m1 = vf{} + m[1], m2 = vf{} + m[2], m3 = vf{} + m[3], m4 = vf{} + m[4];
      m5 = vf{} + m[5], m6 = vf{} + m[6], m7 = vf{} + m[7], m8 = vf{} + m[8];
    }
  };
  set_slot(0);
  // The fast path converts t − t0 through int32: windows up to 2.1 s (all others take the slow path).
  const bool fast_ok = p.duration <= std::numeric_limits<std::int32_t>::max();
  const vf fx = vf{} + p.fx, fy = vf{} + p.fy, cx = vf{} + p.cx, cy = vf{} + p.cy;
  const vf kv0 = vf{} + p.kv[0], kv1 = vf{} + p.kv[1], kv2 = vf{} + p.kv[2];
  const vf u_hi = vf{} + (static_cast<float>(w) - 0.5f), v_hi = vf{} + (static_cast<float>(h) - 0.5f);
  const vf half = vf{} + 0.5f, min_z = vf{} + 1e-6f, ns_to_s = vf{} + 1e-9f;
  const vi width = vi{} + w;
  vi no_inverse{}, left{}, fallback{};

  // Slow path, one event with every check and its own slot: quads that straddle a slot boundary,
  // hold out-of-order or out-of-window events or pixels outside the sensor, and the last 0-3.
  auto one = [&](std::size_t kk) {
    const Event& e = p.events[kk * stride];
    c.out_of_order += e.t < previous_t;
    previous_t = e.t;
    // Unsigned difference: no overflow whatever the (bad) time; negative d wraps to large.
    const auto d = static_cast<TimeNs>(static_cast<std::uint64_t>(e.t) - static_cast<std::uint64_t>(p.t0));
    if (static_cast<std::uint64_t>(d) >= duration) {
      ++c.outside_window;
      return;
    }
    if (e.x >= w || e.y >= h) {
      ++c.outside_sensor;
      return;
    }
    const std::size_t raw = static_cast<std::size_t>(e.y) * w + e.x;
    const NormalizedRay r = p.rays[raw];
    if (std::isnan(r.x)) {
      ++c.no_inverse;
      return;
    }
    if (e.t < slot_t0 || e.t >= slot_t1) set_slot(d);
    const float stored = M == Model::kRotationTranslation ? p.inv_depth[raw] : 0.0f;
    const float t = static_cast<float>(d) * 1e-9f;
    float u, v;
    std::int32_t px;
    const bool keep = warp_one<M>(p, m, r.x, r.y, t, stored, u, v, px);
    c.left += !keep;
    c.fallback += M == Model::kRotationTranslation && std::signbit(stored);
    out.x[n] = u;
    out.y[n] = v;
    out.t[n] = t;
    out.pixel[n] = px;
    n += keep;
  };

  // Events arrive in time order, not pixel order: the table lookups are scattered over tables
  // larger than L2, usually cold in a running pipeline. Prefetching far enough ahead hides that
  // latency. (Written out in the loop: GCC 12 drops __builtin_prefetch inside a lambda here.)
  constexpr std::size_t kPrefetch = 64;
  const std::size_t last_pixel = static_cast<std::size_t>(w) * h - 1;
  std::size_t k = begin;
  for (; k + 4 <= end; k += 4) {
    if (k + 3 + kPrefetch < end) {
      for (std::size_t j = 0; j < 4; ++j) {
        const Event& a = p.events[(k + j + kPrefetch) * stride];
        const std::size_t r = std::min(static_cast<std::size_t>(a.y) * w + a.x, last_pixel);
        __builtin_prefetch(p.rays + r);
        if constexpr (M == Model::kRotationTranslation) __builtin_prefetch(p.inv_depth + r);
      }
    }
    const Event& e0 = p.events[k * stride];
    const Event& e1 = p.events[(k + 1) * stride];
    const Event& e2 = p.events[(k + 2) * stride];
    const Event& e3 = p.events[(k + 3) * stride];
    // Fast path: in time order (also after the previous event), all within the current slot
    // (hence within the window), all inside the sensor. Non-short-circuit: no branch per test.
    const bool fast = fast_ok & (previous_t <= e0.t) & (e0.t <= e1.t) & (e1.t <= e2.t) & (e2.t <= e3.t) &
                      (e0.t >= slot_t0) & (e3.t < slot_t1) & (e0.x < w) & (e1.x < w) & (e2.x < w) & (e3.x < w) &
                      (e0.y < h) & (e1.y < h) & (e2.y < h) & (e3.y < h);
    if (!fast) {
      for (std::size_t j = 0; j < 4; ++j) one(k + j);
      continue;
    }
    previous_t = e3.t;
    const std::size_t r0 = static_cast<std::size_t>(e0.y) * w + e0.x, r1 = static_cast<std::size_t>(e1.y) * w + e1.x;
    const std::size_t r2 = static_cast<std::size_t>(e2.y) * w + e2.x, r3 = static_cast<std::size_t>(e3.y) * w + e3.x;
    const NormalizedRay a0 = p.rays[r0], a1 = p.rays[r1], a2 = p.rays[r2], a3 = p.rays[r3];
    const vf X0{a0.x, a1.x, a2.x, a3.x}, Y0{a0.y, a1.y, a2.y, a3.y};
    // float(d) from int32 equals float(d) from int64: both are the rounding of the same integer.
    const vi d{static_cast<std::int32_t>(e0.t - p.t0), static_cast<std::int32_t>(e1.t - p.t0),
               static_cast<std::int32_t>(e2.t - p.t0), static_cast<std::int32_t>(e3.t - p.t0)};
    const vf T = __builtin_convertvector(d, vf) * ns_to_s;
    const vi has_ray = X0 == X0;  // NaN: no undistortion
    no_inverse -= ~has_ray;
    vf u, v;
    vi front = vi{} - 1;
    if constexpr (M == Model::kNone) {
      u = fx * X0 + cx;
      v = fy * Y0 + cy;
    } else {
      vf X = m0 * X0 + m1 * Y0 + m2;
      vf Y = m3 * X0 + m4 * Y0 + m5;
      vf Z = m6 * X0 + m7 * Y0 + m8;
      if constexpr (M == Model::kRotationTranslation) {
        const vi stored = bits(vf{p.inv_depth[r0], p.inv_depth[r1], p.inv_depth[r2], p.inv_depth[r3]});
        fallback -= has_ray & (stored < 0);  // sign bit: the missing-depth policy was applied
        const vf rho_dt = from_bits(stored & 0x7fffffff) * T;
        X = X + rho_dt * kv0;
        Y = Y + rho_dt * kv1;
        Z = Z + rho_dt * kv2;
      }
      front = Z > min_z;
      const vf iz = 1.0f / Z;
      u = X * iz;
      v = Y * iz;
    }
    const vi keep = has_ray & front & (u >= -half) & (u < u_hi) & (v >= -half) & (v < v_hi);
    left -= has_ray & ~keep;
    // Lanes that are not kept convert 0 (their positions may be out of the int range).
    const vi px = __builtin_convertvector(from_bits(bits(v + half) & keep), vi) * width +
                  __builtin_convertvector(from_bits(bits(u + half) & keep), vi);
    if (all_set(keep)) {  // the common case: four vector stores
      store(out.x + n, u);
      store(out.y + n, v);
      store(out.t + n, T);
      store(out.pixel + n, px);
      n += 4;
      continue;
    }
    // Branch-free compaction: every lane is written, the position advances for kept ones.
    for (int j = 0; j < 4; ++j) {
      out.x[n] = u[j];
      out.y[n] = v[j];
      out.t[n] = T[j];
      out.pixel[n] = px[j];
      n += static_cast<std::size_t>(keep[j] & 1);
    }
  }
  for (; k < end; ++k) one(k);
  for (int j = 0; j < 4; ++j) {
    c.no_inverse += static_cast<std::uint64_t>(no_inverse[j]);
    c.left += static_cast<std::uint64_t>(left[j]);
    c.fallback += static_cast<std::uint64_t>(fallback[j]);
  }
  c.kept = n;
  return c;
}

}  // namespace

WarpCompensator::WarpCompensator(CompensationMethod method, const Calibration& calibration,
                                 const CompensationOptions& options, std::shared_ptr<const UndistortionMap> map)
    : CompensatorBase(method, calibration, options, std::move(map)) {
  const PinholeCamera& cam = map_->camera();
  for (const double u : {-0.5, map_->width() - 0.5})
    for (const double v : {-0.5, map_->height() - 0.5})
      grid_max_radius_ = std::max(grid_max_radius_, std::hypot((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy));
  if (method != CompensationMethod::kRotationTranslation) return;
  // The depth frame's buffers, sized as prepare_depth sizes them (a registered frame has the event
  // camera's size), so that the first frame does not fault them in inside a window.
  const std::size_t n = static_cast<std::size_t>(map_->width()) * static_cast<std::size_t>(map_->height());
  const auto rows = static_cast<std::size_t>(2 * options.hole_fill_radius_px + 1);
  const std::size_t ring = rows * static_cast<std::size_t>(map_->width());
  raw_rho_.resize(ring);
  row_max_.resize(ring);
  for (PreparedDepth& slot : prepared_) slot.inv_depth.resize(n);
  depth_sample_.reserve(n / depth_sample_stride(n) + 1);
}

void WarpCompensator::build_rotation_slots(const Eigen::Vector3d& omega_E, const CompensationInput& in,
                                           TimeNs duration_ns) {
  const TimeNs refresh = options_.rotation_refresh_ns;
  const int n = static_cast<int>(std::max<TimeNs>(1, (duration_ns + refresh - 1) / refresh));
  slots_.resize(static_cast<std::size_t>(n) * 9);  // grows once, then reused
  auto twice_slot_middle_ns = [&](int s) {  // from the window's start
    const TimeNs a = s * refresh, b = std::min<TimeNs>((s + 1) * refresh, duration_ns);
    return a + std::max(a, b);
  };
  knots_.clear();
  if (options_.integrate_gyro) {
    // imu_turn gives how a fixed direction's IMU coordinates change, d_I(t) = R_I·d_I(t0); the warp
    // needs d_E(t0) = R_E_I·R_Iᵀ·R_E_Iᵀ·d_E(t). Integrated knot to knot: the slots' middles, then
    // the window's end (for observed_position).
    const Eigen::Matrix3d R_E_I = calibration_.R_E_I();
    Eigen::Matrix3d R_I = Eigen::Matrix3d::Identity();
    knots_.push_back({0.0, Eigen::Quaterniond::Identity()});
    TimeNs from = 0;
    for (int s = 0; s <= n; ++s) {
      const TimeNs to = s < n ? twice_slot_middle_ns(s) / 2 : duration_ns;
      const auto step = imu_turn(in.imu, in.t_start + from, in.t_start + to, options_.max_imu_gap_ns);
      if (!step) {
        knots_.clear();
        break;
      }
      R_I = *step * R_I;
      from = to;
      knots_.push_back({to_seconds(to), Eigen::Quaterniond(R_E_I * R_I.transpose() * R_E_I.transpose())});
    }
  }
  const PinholeCamera& cam = map_->camera();
  for (int s = 0; s < n; ++s) {
    Eigen::Matrix3d R;
    if (!knots_.empty()) {
      R = knots_[static_cast<std::size_t>(s) + 1].R.toRotationMatrix();
    } else {
      // Rodrigues' formula (Eigen's AngleAxis): rotation by angle |ω|·t about ω/|ω|.
      const double angle = omega_E.norm() * (0.5 * to_seconds(twice_slot_middle_ns(s)));
      R = angle > 0 ? Eigen::AngleAxisd(angle, omega_E.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
    }
    float* m = slots_.data() + 9 * s;
    for (int c = 0; c < 3; ++c) {
      m[c] = static_cast<float>(cam.fx * R(0, c) + cam.cx * R(2, c));
      m[3 + c] = static_cast<float>(cam.fy * R(1, c) + cam.cy * R(2, c));
      m[6 + c] = static_cast<float>(R(2, c));
    }
  }
}

bool WarpCompensator::depth_fits(const RegisteredDepth& depth) const {
  return depth.width == map_->width() && depth.height == map_->height() &&
         depth.depth_m.size() == static_cast<std::size_t>(map_->width()) * map_->height();
}

void WarpCompensator::prepare_depth_frame(const RegisteredDepth& depth) {
  if (method_ == CompensationMethod::kRotationTranslation && !depth.empty() && depth_fits(depth))
    prepare_depth(depth);
}

bool WarpCompensator::is_prepared(const RegisteredDepth& depth) const {
  return std::any_of(prepared_.begin(), prepared_.end(), [&](const PreparedDepth& p) { return p.made_from(depth); });
}

bool WarpCompensator::prepare_depth(const RegisteredDepth& depth) {
  for (int slot = 0; slot < static_cast<int>(prepared_.size()); ++slot)
    if (prepared_[slot].made_from(depth)) {
      in_use_ = slot;
      return prepared_[slot].usable;
    }
  // Made into the slot of the older frame (an empty slot first).
  const auto older = [](const PreparedDepth& a, const PreparedDepth& b) { return !a.key || (b.key && a.t_key < b.t_key); };
  in_use_ = older(prepared_[0], prepared_[1]) ? 0 : 1;
  PreparedDepth& made = prepared_[in_use_];
  made.key = &depth;
  made.data_key = depth.depth_m.data();
  made.t_key = depth.t;
  made.max_rho = 0;
  const int w = depth.width, h = depth.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  const float* z = depth.depth_m.data();
  // The missing-depth policy's depth from the valid depths (strided).
  depth_sample_.clear();
  const std::size_t stride = depth_sample_stride(n);
  for (std::size_t i = 0; i < n; i += stride)
    if (z[i] > 0 && std::isfinite(z[i])) depth_sample_.push_back(z[i]);
  if (depth_sample_.empty()) {
    made.usable = false;
    return false;
  }
  if (options_.missing_depth == MissingDepthPolicy::kBeyondRange) {
    // The reach: the 99th percentile, so that a few outliers do not set it.
    auto far = depth_sample_.begin() + static_cast<std::ptrdiff_t>(depth_sample_.size() * 99 / 100);
    std::nth_element(depth_sample_.begin(), far, depth_sample_.end());
    made.fallback_depth_m = 2 * *far;
  } else {
    auto mid = depth_sample_.begin() + static_cast<std::ptrdiff_t>(depth_sample_.size() / 2);
    std::nth_element(depth_sample_.begin(), mid, depth_sample_.end());
    made.fallback_depth_m = *mid;
  }
  // ρ = 1/z where valid, 0 in holes; holes take the nearest surface (largest ρ) among the neighbours
  // within hole_fill_radius_px: a grey dilation with a square window clipped at the border, as two
  // 1-D running maxima (along each row, then across the 2r + 1 rows around it), then the
  // missing-depth policy, marked by the sign bit. Vector passes over whole rows: cheaper than
  // visiting the holes one by one when much of the view is beyond the depth camera's range (a long
  // hall: tens of per cent of the pixels). One sweep down the frame: only the 2r + 1 rows in flight
  // of ρ and of their row maxima are kept (rings of rows), so the frame is read once and written once.
  const int r = options_.hole_fill_radius_px;
  const float fallback_rho =
      options_.missing_depth == MissingDepthPolicy::kRotationOnly ? 0.0f : 1.0f / made.fallback_depth_m;
  const std::size_t row_len = static_cast<std::size_t>(w);
  const int span = 2 * r + 1;
  raw_rho_.resize(static_cast<std::size_t>(span) * row_len);
  row_max_.resize(static_cast<std::size_t>(span) * row_len);
  made.inv_depth.resize(n);
  auto raw_row = [&](int y) { return raw_rho_.data() + static_cast<std::size_t>(y % span) * row_len; };
  auto max_row = [&](int y) { return row_max_.data() + static_cast<std::size_t>(y % span) * row_len; };
  // out[x] = max(out[x], in[x + shift]) over the x where x + shift is in the row.
  auto max_into = [row_len](float* out, const float* in, std::ptrdiff_t shift) {
    const std::size_t x0 = shift < 0 ? static_cast<std::size_t>(-shift) : 0;
    const std::size_t x1 = shift > 0 ? row_len - std::min(row_len, static_cast<std::size_t>(shift)) : row_len;
    std::size_t x = x0;
    for (; x + 4 <= x1; x += 4) store(out + x, vmax(load(out + x), load(in + x + shift)));
    for (; x < x1; ++x) out[x] = out[x] > in[x + shift] ? out[x] : in[x + shift];
  };
  // Row y's ρ (four pixels at a time; `z <= FLT_MAX` is false for NaN and inf) and its running maximum.
  const vf flt_max = vf{} + std::numeric_limits<float>::max(), one_f = vf{} + 1.0f;
  auto make_row = [&](int y) {
    const float* zy = z + static_cast<std::size_t>(y) * row_len;
    float* raw = raw_row(y);
    std::size_t x = 0;
    for (; x + 4 <= row_len; x += 4) {
      const vf zi = load(zy + x);
      const vi valid = (zi > 0) & (zi <= flt_max);
      store(raw + x, from_bits(bits(one_f / from_bits((bits(zi) & valid) | (bits(one_f) & ~valid))) & valid));
    }
    for (; x < row_len; ++x) raw[x] = zy[x] > 0 && zy[x] <= std::numeric_limits<float>::max() ? 1.0f / zy[x] : 0.0f;
    float* out = max_row(y);
    std::memcpy(out, raw, row_len * sizeof(float));
    for (int d = 1; d <= r; ++d) {
      max_into(out, raw, d);
      max_into(out, raw, -d);
    }
  };
  float* rho = made.inv_depth.data();
  // Not vf{} + x: 0.0f + −0.0f would lose the sign bit.
  const vf fallback{-fallback_rho, -fallback_rho, -fallback_rho, -fallback_rho}, zero{};
  vf largest{};  // max |ρ|, for the warp's reach (warp_reach_px)
  for (int y = 0; y < std::min(r, h); ++y) make_row(y);
  for (int y = 0; y < h; ++y) {
    if (y + r < h) make_row(y + r);  // into the slot of row y − r − 1, which no row from y on needs
    const float* self = raw_row(y);
    float* out = rho + static_cast<std::size_t>(y) * row_len;
    std::memcpy(out, max_row(y), row_len * sizeof(float));
    for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy)
      if (yy != y) max_into(out, max_row(yy), 0);
    // Valid: its own ρ; hole: the dilation, or the policy's −ρ (−0.0f still carries the sign bit).
    std::size_t x = 0;
    for (; x + 4 <= row_len; x += 4) {
      const vf own = load(self + x), dil = load(out + x);
      const vf rho_x = select(own != zero, own, select(dil != zero, dil, fallback));
      store(out + x, rho_x);
      largest = vmax(largest, from_bits(bits(rho_x) & 0x7fffffff));
    }
    for (; x < row_len; ++x) {
      out[x] = self[x] != 0 ? self[x] : out[x] != 0 ? out[x] : -fallback_rho;
      made.max_rho = std::max(made.max_rho, std::fabs(out[x]));
    }
  }
  for (int j = 0; j < 4; ++j) made.max_rho = std::max(made.max_rho, largest[j]);
  made.usable = true;
  return true;
}

// A turn by θ moves a ray at normalised radius r by at most tan(atan r + θ) − r (the most at the
// grid's largest r: it grows with r), to radius r'. The translation then moves it by
// ρ·dt·|v_xy − x'·v_z| / (Z + ρ·dt·v_z) ≤ s·√(1 + r'²) / (Z_min − s), with s = ρ_max·|v|·T and
// Z_min = cos θ − r·sin θ the smallest depth scale a turned ray keeps (eqs. 6-8).
double WarpCompensator::warp_reach_px(CompensationMethod used, TimeNs duration_ns) const {
  constexpr double kNoBound = std::numeric_limits<double>::infinity();
  constexpr double kRoundingPx = 1.5;  // rounding to the nearest pixel, and float error
  if (used == CompensationMethod::kNone) return kRoundingPx;
  const CompensationReport& rep = out_.report;
  const double T = to_seconds(duration_ns);
  double theta = rep.omega_E.norm() * T;
  if (!knots_.empty()) {
    theta = 0;
    for (const RotationKnot& k : knots_) theta = std::max(theta, Eigen::AngleAxisd(k.R).angle());
  }
  const double r = grid_max_radius_;
  if (!(std::atan(r) + theta < 1.4)) return kNoBound;  // rays turned near 90°: no useful bound
  const double r_turned = std::tan(std::atan(r) + theta);
  double reach = r_turned - r;
  if (used == CompensationMethod::kRotationTranslation) {
    const double s = depth_in_use().max_rho * rep.v_E.norm() * T;
    const double z_min = std::cos(theta) - r * std::sin(theta);
    if (!(z_min - s > 0.2)) return kNoBound;
    reach += s * std::sqrt(1 + r_turned * r_turned) / (z_min - s);
  }
  const PinholeCamera& cam = map_->camera();
  return reach * std::max(cam.fx, cam.fy) + kRoundingPx;
}

std::span<const Event> WarpCompensator::events_near(const CompensationInput& in,
                                                    std::span<const Eigen::AlignedBox2d> regions, double reach_px) {
  const PinholeCamera& cam = map_->camera();
  const int w = map_->width(), h = map_->height();
  // Each region grown by the reach, in raw pixels: the lens map of a lattice over it (its edges
  // included), whose bounding box grown by the map's largest stretch over half a lattice cell holds
  // the raw pixels whose rays fall inside.
  constexpr double kLatticePx = 8;
  raw_boxes_.clear();
  for (const Eigen::AlignedBox2d& region : regions) {
    // Not clipped to the grid: a ray just outside it (a raw pixel the lens puts there) may be
    // warped into it.
    const double x0 = region.min().x() - reach_px, x1 = region.max().x() + reach_px;
    const double y0 = region.min().y() - reach_px, y1 = region.max().y() + reach_px;
    if (!(x0 < x1 && y0 < y1)) continue;
    const int nx = static_cast<int>(std::ceil((x1 - x0) / kLatticePx)), ny = static_cast<int>(std::ceil((y1 - y0) / kLatticePx));
    const double dx = (x1 - x0) / nx, dy = (y1 - y0) / ny;
    Eigen::AlignedBox2d raw;
    double stretch = 1;
    lattice_row_.assign(static_cast<std::size_t>(nx) + 1, Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        const Eigen::Vector2d grid(x0 + i * dx, y0 + j * dy);
        const Eigen::Vector2d px = cam.normalized_to_pixel({(grid.x() - cam.cx) / cam.fx, (grid.y() - cam.cy) / cam.fy});
        Eigen::Vector2d& above = lattice_row_[static_cast<std::size_t>(i)];
        if (px.allFinite()) {
          raw.extend(px);
          if (above.allFinite()) stretch = std::max(stretch, (px - above).norm() / dy);
          if (i > 0 && lattice_row_[static_cast<std::size_t>(i) - 1].allFinite())
            stretch = std::max(stretch, (px - lattice_row_[static_cast<std::size_t>(i) - 1]).norm() / dx);
        }
        above = px;
      }
    if (raw.isEmpty()) continue;
    const double grow = stretch * std::hypot(dx, dy) / 2 + 1;
    raw_boxes_.push_back({static_cast<int>(std::floor(raw.min().x() - grow)), static_cast<int>(std::floor(raw.min().y() - grow)),
                          static_cast<int>(std::ceil(raw.max().x() + grow)), static_cast<int>(std::ceil(raw.max().y() + grow))});
  }
  if (raw_boxes_.empty()) {  // nothing can land near a region: no event is needed, nor their times
    out_.report.events_out_of_order = 0;
    return {};
  }
  // One branch-free pass: every event in the window and the sensor gives its time; it goes on to
  // the warp when near a region, and so do those outside the window or the sensor (the warp drops
  // and counts them).
  const std::size_t n = in.events.size();
  if (near_events_.size() < n) near_events_.resize(std::bit_ceil(n));
  const Event* events = in.events.data();
  Event* near = near_events_.data();
  float* times = out_.reserve_window_t_s(n);
  const RawBox* boxes = raw_boxes_.data();
  const std::size_t n_boxes = raw_boxes_.size();
  const auto duration = static_cast<std::uint64_t>(std::max<TimeNs>(0, in.t_end - in.t_start));
  const auto t0 = static_cast<std::uint64_t>(in.t_start);
  std::size_t n_near = 0, n_times = 0;
  std::uint64_t out_of_order = 0;
  TimeNs previous_t = std::numeric_limits<TimeNs>::min();
  for (std::size_t i = 0; i < n; ++i) {
    const Event e = events[i];
    out_of_order += e.t < previous_t;
    previous_t = e.t;
    const std::uint64_t d = static_cast<std::uint64_t>(e.t) - t0;
    const bool inside = (d < duration) & (e.x < w) & (e.y < h);
    times[n_times] = static_cast<float>(static_cast<TimeNs>(d)) * 1e-9f;  // as the warp writes t
    n_times += inside;
    bool in_box = false;
    for (std::size_t b = 0; b < n_boxes; ++b)
      in_box |= (static_cast<unsigned>(e.x - boxes[b].x0) <= static_cast<unsigned>(boxes[b].x1 - boxes[b].x0)) &
                (static_cast<unsigned>(e.y - boxes[b].y0) <= static_cast<unsigned>(boxes[b].y1 - boxes[b].y0));
    near[n_near] = e;
    n_near += !inside | in_box;
  }
  out_.set_window_t_s_size(n_times);
  out_.report.events_out_of_order = out_of_order;
  return {near, n_near};
}

double WarpCompensator::warp_inverse_depth_at(const Eigen::Vector2d& x) const {
  const Eigen::Vector2d raw = map_->camera().normalized_to_pixel(x);
  const double u = std::round(raw.x()), v = std::round(raw.y());
  if (u >= 0 && v >= 0 && u < map_->width() && v < map_->height())
    return std::fabs(depth_in_use().inv_depth[static_cast<std::size_t>(v) * map_->width() + static_cast<std::size_t>(u)]);
  return options_.missing_depth == MissingDepthPolicy::kRotationOnly ? 0.0 : 1.0 / depth_in_use().fallback_depth_m;
}

Eigen::Vector2d WarpCompensator::observed_position(const Eigen::Vector2d& px, double t_s) const {
  const CompensationReport& rep = out_.report;
  if (rep.used == CompensationMethod::kNone) return px;
  const PinholeCamera& cam = map_->camera();
  // Forward (eqs. 6-8, header): X0 = R(t)·x + ρ·v·t, px = K·X0/z0, with x = (x, y, 1) the ray seen
  // at t. Inverse: x = Rᵀ·(λ·d0 − ρ·v·t) with d0 = K⁻¹·px and λ fixed by x_z = 1.
  const Eigen::Vector3d d0((px.x() - cam.cx) / cam.fx, (px.y() - cam.cy) / cam.fy, 1.0);
  Eigen::Matrix3d Rt;
  if (!knots_.empty()) {  // the integrated gyro: slerp between the knots around t_s
    const auto after = std::upper_bound(knots_.begin(), knots_.end(), t_s,
                                        [](double t, const RotationKnot& k) { return t < k.t_s; });
    Eigen::Quaterniond R = after == knots_.end() ? knots_.back().R : knots_.front().R;
    if (after != knots_.begin() && after != knots_.end()) {
      const RotationKnot& a = *(after - 1);
      R = a.R.slerp((t_s - a.t_s) / (after->t_s - a.t_s), after->R);
    }
    Rt = R.toRotationMatrix().transpose();
  } else {
    const double angle = rep.omega_E.norm() * t_s;
    Rt = angle > 0 ? Eigen::AngleAxisd(-angle, rep.omega_E.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
  }
  const Eigen::Vector3d r0 = Rt * d0;
  if (!(r0.z() > 0)) return px;  // behind the camera at t: no image point
  Eigen::Vector3d x = r0 / r0.z();
  if (rep.used == CompensationMethod::kRotationTranslation) {
    const Eigen::Vector3d rv = Rt * rep.v_E * t_s;
    // ρ is looked up where the camera saw the point: first at the rotation-only guess, then once
    // more at the result (ρ changes little over the few pixels the translation moves it).
    for (int pass = 0; pass < 2; ++pass) {
      const double rho = warp_inverse_depth_at(x.head<2>());
      const double lambda = (1 + rho * rv.z()) / r0.z();
      if (!(lambda > 0)) return px;
      x = lambda * r0 - rho * rv;
    }
  }
  return {cam.fx * x.x() + cam.cx, cam.fy * x.y() + cam.cy};
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
    const TimeNs t_mid = in.t_start + (in.t_end - in.t_start) / 2;
    if (!rep.has_velocity) {
      rep.odometry_missing = true;
    } else if (!in.depth || in.depth->empty()) {
      rep.depth_missing = true;
    } else if (!depth_fits(*in.depth)) {
      rep.depth_wrong_size = true;
    } else if ((rep.depth_age_ns = std::abs(t_mid - in.depth->t)) > options_.max_depth_age_ns) {
      rep.depth_stale = true;
    } else if (rep.depth_prepared_here = !is_prepared(*in.depth); !prepare_depth(*in.depth)) {
      rep.depth_missing = true;  // a frame without a single valid depth
    }
    if (rep.odometry_missing || rep.depth_missing || rep.depth_wrong_size || rep.depth_stale)
      used = CompensationMethod::kRotation;
  }
  rep.used = used;

  const PinholeCamera& cam = map_->camera();
  WarpParams p;
  p.rays = map_->rays();
  p.width = map_->width();
  p.height = map_->height();
  p.t0 = in.t_start;
  p.duration = std::max<TimeNs>(0, in.t_end - in.t_start);
  p.refresh = options_.rotation_refresh_ns;
  p.fx = static_cast<float>(cam.fx), p.fy = static_cast<float>(cam.fy);
  p.cx = static_cast<float>(cam.cx), p.cy = static_cast<float>(cam.cy);
  if (used != CompensationMethod::kNone) {
    build_rotation_slots(rep.omega_E, in, p.duration);
    p.slots = slots_.data();
  }
  if (used == CompensationMethod::kRotationTranslation) {
    const Eigen::Vector3d& v = rep.v_E;
    p.inv_depth = depth_in_use().inv_depth.data();
    p.kv[0] = static_cast<float>(cam.fx * v.x() + cam.cx * v.z());
    p.kv[1] = static_cast<float>(cam.fy * v.y() + cam.cy * v.z());
    p.kv[2] = static_cast<float>(v.z());
  }
  // Near the regions only, when the warp's reach bounds where an event can go and the window is
  // not small (kMinEventsToCutNearRegions; a small one is warped whole unless nothing is needed).
  // Not in a window that fell back to "none": the caller's regions are for the camera at the
  // window's start, and the output is the camera through the window.
  std::span<const Event> events = in.events;
  bool selected = false;
  if (in.near_regions && (in.near_regions->empty() || in.events.size() >= kMinEventsToCutNearRegions) &&
      (used != CompensationMethod::kNone || method_ == CompensationMethod::kNone))
    if (const double reach = warp_reach_px(used, p.duration); std::isfinite(reach)) {
      events = events_near(in, *in.near_regions, reach);
      rep.near_regions_reach_px = reach;
      selected = true;
    }
  const std::uint64_t window_out_of_order = rep.events_out_of_order;
  rep.skipped_far_from_regions = in.events.size() - events.size();
  const std::size_t n_events = events.size();
  p.events = events.data();
  p.stride = burst_stride(n_events);
  const std::size_t visits = p.stride == 1 ? n_events : (n_events + p.stride - 1) / p.stride;
  rep.dropped_burst = n_events - visits;

  out_.reserve_events(visits);
  const Output o{out_.x_data(), out_.y_data(), out_.t_data(), out_.pixel_data()};
  // Parts of the visits, each written from its own first visit on (kept ≤ visited), then moved
  // together in order: the same output as one pass. Small windows are not worth a second thread.
  constexpr std::size_t kMinEventsPerPart = 16'384;
  const int parts = static_cast<int>(std::clamp<std::size_t>(visits / kMinEventsPerPart, 1,
                                                             static_cast<std::size_t>(options_.threads)));
  std::array<WarpCounts, kMaxParts> part_counts;
  std::array<std::size_t, kMaxParts + 1> first{};
  for (int i = 0; i <= parts; ++i) first[i] = visits * static_cast<std::size_t>(i) / static_cast<std::size_t>(parts);
  const auto warp_part = [&](int i) {
    const std::size_t b = first[i], e = first[i + 1];
    const TimeNs previous_t = b == 0 ? std::numeric_limits<TimeNs>::min() : p.events[(b - 1) * p.stride].t;
    const Output part{o.x + b, o.y + b, o.t + b, o.pixel + b};
    const auto run = [&]<Model M>() {
      part_counts[i] = p.stride == 1 ? warp_range<M, false>(p, b, e, previous_t, part)
                                     : warp_range<M, true>(p, b, e, previous_t, part);
    };
    switch (used) {
      case CompensationMethod::kRotation: run.operator()<Model::kRotation>(); break;
      case CompensationMethod::kRotationTranslation: run.operator()<Model::kRotationTranslation>(); break;
      default: run.operator()<Model::kNone>(); break;
    }
  };
  run_parts(parts, warp_part);
  WarpCounts c;
  for (int i = 0; i < parts; ++i) {
    const WarpCounts& pc = part_counts[i];
    if (i > 0 && first[i] != c.kept) {
      for (float* a : {o.x, o.y, o.t}) std::memmove(a + c.kept, a + first[i], pc.kept * sizeof(float));
      std::memmove(o.pixel + c.kept, o.pixel + first[i], pc.kept * sizeof(std::int32_t));
    }
    c.kept += pc.kept;
    c.outside_window += pc.outside_window;
    c.outside_sensor += pc.outside_sensor;
    c.no_inverse += pc.no_inverse;
    c.left += pc.left;
    c.out_of_order += pc.out_of_order;
    c.fallback += pc.fallback;
  }
  out_.set_size(c.kept);
  rep.events_kept = c.kept;
  rep.dropped_outside_window = c.outside_window;
  rep.dropped_outside_sensor = c.outside_sensor;
  rep.dropped_no_inverse = c.no_inverse;
  rep.dropped_left_image = c.left;
  // The whole window's order when a part was warped: its times are the sources' too.
  rep.events_out_of_order = selected ? window_out_of_order : c.out_of_order;
  if (used == CompensationMethod::kRotationTranslation) {
    rep.depth_fallback_events = c.fallback;
    if (options_.missing_depth != MissingDepthPolicy::kRotationOnly) rep.fallback_depth_m = depth_in_use().fallback_depth_m;
  }
  return out_;
}

}  // namespace fdv::internal
