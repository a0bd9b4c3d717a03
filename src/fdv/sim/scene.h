#pragma once
/// The static world (an axis-aligned room with axis-aligned textured panels) and the look of the
/// balls, with analytic ray casting and band-limited shading.
///
///   Scene scene(config.scene, config.balls, seed);
///   RayHit hit = scene.cast_static(origin, dir, inv_dir, scene.all_panels());   // nearest surface
///   float I = scene.static_radiance(hit, origin, dir, footprint_per_m);        // [lux-like]
///
/// Radiometry: a surface point's image irradiance is illuminance × shading × reflectance, with
/// Lambertian shading (ambient share plus one directional light) and reflectance
/// albedo · exp(contrast · g), g a sum of value-noise octaves in the surface's own coordinates.
///
/// Band limit: each octave's amplitude is faded to zero as its lattice spacing approaches the
/// pixel's footprint on the surface (full below 1/3 of the spacing, zero above 2/3), so the
/// rendered image carries no detail finer than ~1.5 pixels and point sampling does not alias.
/// The footprint is the ray-differential estimate t·(pixel size in normalised units)·|d|/|d·n| (the
/// long axis of the footprint ellipse, which blurs a little more than needed across it).
///
/// Ray conventions: `dir` is any non-normalised direction whose component along the camera's
/// optical axis is 1 (d = R_W_C (x, y, 1)); `t` is then the z-depth in that camera. Thread-safe
/// (const after construction).
#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "fdv/core/lanes.h"
#include "fdv/sim/fast_math.h"
#include "fdv/sim/scenario_config.h"

namespace fdv::sim {

inline constexpr int kMaxPanels = 64;
inline constexpr int kRoomSurfaces = 6;
inline constexpr int kNoiseSize = 128;  ///< value-noise lattice period (cells)
inline constexpr int kOctaves = 3;

struct Octave {
  float m00 = 1, m01 = 0, m10 = 0, m11 = 1;  ///< surface metres -> lattice units (rotation/scale)
  float o0 = 0, o1 = 0;                      ///< lattice offset
  float amp = 0;                             ///< amplitude (before `contrast`)
  float inv_spacing_m = 1;                   ///< 1 / lattice spacing [1/m]
};

struct Surface {
  int axis = 0;  ///< plane normal axis (0 x, 1 y, 2 z)
  int u_axis = 1, v_axis = 2;
  float coord = 0;                                                 ///< plane position along `axis`
  float umin = -1e30f, umax = 1e30f, vmin = -1e30f, vmax = 1e30f;  ///< panel bounds
  float contrast = 0;                                              ///< log-reflectance amplitude
  /// log(illuminance · shading · albedo) of the face seen by a ray with dir[axis] > 0 ([0],
  /// normal -axis) or < 0 ([1], normal +axis).
  float log_radiance[2] = {0, 0};
  Octave octave[kOctaves];
};

struct BallLook {
  int id = 1;
  float radius = 0.1f;
  float log_albedo = 0, contrast = 0;
  float wave[3][3] = {};  ///< wave vectors over the unit sphere (ball frame)
  float phase[3] = {};
  float amp[3] = {};
  float inv_wavelength_m[3] = {};  ///< 1 / (2π r / |wave|)
};

struct RayHit {
  float t = 1e30f;  ///< ray parameter (z-depth for camera rays)
  int surface = -1;
};

class Scene {
 public:
  Scene(const SceneConfig& config, const std::vector<BallConfig>& balls, std::uint64_t seed);

  std::uint64_t all_panels() const { return all_panels_; }
  int panel_count() const { return static_cast<int>(surfaces_.size()) - kRoomSurfaces; }
  const Surface& surface(int i) const { return surfaces_[i]; }
  const BallLook& ball_look(int index) const { return balls_[index]; }
  float illuminance() const { return illuminance_; }
  float ambient() const { return ambient_; }
  const float* light_dir() const { return light_; }
  Eigen::Vector3d room_min() const { return room_min_.cast<double>(); }
  Eigen::Vector3d room_max() const { return room_max_.cast<double>(); }
  /// Corners of panel `i` (0-based among panels) in W.
  std::array<Eigen::Vector3d, 4> panel_corners(int i) const;

  /// Nearest static surface along o + t·d (o inside the room). `inv` = 1/d componentwise, with
  /// zero components of d replaced by ±1e-20 (safe_inverse()); the sign of inv decides which
  /// face of the room a ray parallel to it would meet (at ~infinity).
  RayHit cast_static(const float* o, const float* d, const float* inv, std::uint64_t panels) const {
    RayHit hit;
    for (int a = 0; a < 3; ++a) {
      const bool up = inv[a] > 0;  // the sign safe_inverse() gave a zero component
      const float t = ((up ? room_max_[a] : room_min_[a]) - o[a]) * inv[a];
      if (t < hit.t) hit.t = t, hit.surface = 2 * a + (up ? 1 : 0);
    }
    while (panels) {
      const int i = __builtin_ctzll(panels);
      panels &= panels - 1;
      const Surface& s = surfaces_[kRoomSurfaces + i];
      const float t = (s.coord - o[s.axis]) * inv[s.axis];
      if (!(t > 1e-4f && t < hit.t)) continue;
      const float pu = o[s.u_axis] + t * d[s.u_axis];
      const float pv = o[s.v_axis] + t * d[s.v_axis];
      if (pu >= s.umin && pu <= s.umax && pv >= s.vmin && pv <= s.vmax)
        hit.t = t, hit.surface = kRoomSurfaces + i;
    }
    return hit;
  }

  /// Image irradiance of a static hit. `footprint_scale` = the pixel's size in normalised
  /// image units times |d|, so that the footprint on the surface is
  /// t · footprint_scale / |d_axis| (see above).
  float static_radiance(const RayHit& hit, const float* o, const float* d,
                        float footprint_scale) const {
    const Surface& s = surfaces_[hit.surface];
    const float da = std::abs(d[s.axis]);
    const float u = o[s.u_axis] + hit.t * d[s.u_axis];
    const float v = o[s.v_axis] + hit.t * d[s.v_axis];
    const float footprint = hit.t * footprint_scale / (da > 1e-6f ? da : 1e-6f);
    float g = 0;
    for (const Octave& oc : s.octave) {
      const float ratio = footprint * oc.inv_spacing_m;  // footprint / spacing
      if (ratio >= kFadeEnd) continue;
      const float x = oc.m00 * u + oc.m01 * v + oc.o0;
      const float y = oc.m10 * u + oc.m11 * v + oc.o1;
      g += oc.amp * fade(ratio) * value_noise(x, y);
    }
    return fast_exp(s.log_radiance[d[s.axis] > 0 ? 0 : 1] + s.contrast * g);
  }

  /// Ball irradiance at outward unit normal n (W) and the same normal in the ball frame n_o,
  /// seen from distance `dist` [m] along a unit ray with cos(incidence) `cos_inc`.
  float ball_radiance(int index, const float* n, const float* n_o, float dist, float pixel_angle,
                      float cos_inc) const {
    const BallLook& b = balls_[index];
    const float lambert = n[0] * light_[0] + n[1] * light_[1] + n[2] * light_[2];
    const float shade = ambient_ + (1 - ambient_) * (lambert > 0 ? lambert : 0);
    const float footprint = dist * pixel_angle / (cos_inc > 0.02f ? cos_inc : 0.02f);
    float g = 0;
    for (int k = 0; k < 3; ++k) {
      const float ratio = footprint * b.inv_wavelength_m[k] * 2.0f;  // half-wavelength ~ spacing
      if (ratio >= kFadeEnd) continue;
      const float arg = b.wave[k][0] * n_o[0] + b.wave[k][1] * n_o[1] + b.wave[k][2] * n_o[2];
      g += b.amp[k] * fade(ratio) * std::sin(arg + b.phase[k]);
    }
    return illuminance_ * shade * fast_exp(b.log_albedo + b.contrast * g);
  }

  // ---- kLanes rays at once (same results as the scalar functions above, lane by lane)

  /// Nearest static surface for lanes::kLanes rays from one origin.
  void cast_static_v(const float* o, const lanes::vf* d, const lanes::vf* inv, std::uint64_t panels,
                     lanes::vf& t_out, lanes::vi& surface_out) const {
    using namespace lanes;
    vf t = splat(1e30f);
    vi surf = splat_i(-1);
    for (int a = 0; a < 3; ++a) {
      const vi up = inv[a] > 0;
      const vf bound = select(up, splat(room_max_[a]), splat(room_min_[a]));
      const vf ta = (bound - o[a]) * inv[a];
      const vi better = ta < t;
      t = select(better, ta, t);
      surf = select(better, splat_i(2 * a) - up, surf);  // up lanes are -1: 2a + 1
    }
    while (panels) {
      const int i = __builtin_ctzll(panels);
      panels &= panels - 1;
      const Surface& s = surfaces_[kRoomSurfaces + i];
      const vf ta = (s.coord - o[s.axis]) * inv[s.axis];
      const vf pu = o[s.u_axis] + ta * d[s.u_axis];
      const vf pv = o[s.v_axis] + ta * d[s.v_axis];
      const vi hit = (ta > 1e-4f) & (ta < t) & (pu >= s.umin) & (pu <= s.umax) & (pv >= s.vmin) &
                     (pv <= s.vmax);
      t = select(hit, ta, t);
      surf = select(hit, splat_i(kRoomSurfaces + i), surf);
    }
    t_out = t;
    surface_out = surf;
  }

  /// Image irradiance of lanes::kLanes hits on the same surface (see static_radiance()).
  lanes::vf static_radiance_v(int surface, lanes::vf t, const float* o, const lanes::vf* d,
                              lanes::vf footprint_scale) const {
    using namespace lanes;
    const Surface& s = surfaces_[surface];
    const vf da = max(abs(d[s.axis]), splat(1e-6f));
    const vf u = o[s.u_axis] + t * d[s.u_axis];
    const vf v = o[s.v_axis] + t * d[s.v_axis];
    const vf footprint = t * footprint_scale / da;
    vf g = splat(0.0f);
    for (const Octave& oc : s.octave) {
      const vf ratio = footprint * oc.inv_spacing_m;
      if (!any(ratio < kFadeEnd)) continue;
      const vf x = oc.m00 * u + oc.m01 * v + oc.o0;
      const vf y = oc.m10 * u + oc.m11 * v + oc.o1;
      g += oc.amp * fade_v(ratio) * value_noise_v(x, y);
    }
    const vf lr = select(d[s.axis] > 0, splat(s.log_radiance[0]), splat(s.log_radiance[1]));
    return fast_exp(lr + s.contrast * g);
  }

  static void safe_inverse(const float* d, float* inv) {
    for (int a = 0; a < 3; ++a) {
      const float x = std::abs(d[a]) < 1e-20f ? (d[a] < 0 ? -1e-20f : 1e-20f) : d[a];
      inv[a] = 1.0f / x;
    }
  }

 private:
  static constexpr float kFadeStart = 1.0f / 3.0f, kFadeEnd = 2.0f / 3.0f;
  /// 1 while the footprint is below a third of the spacing, 0 above two thirds, smooth between.
  static float fade(float ratio) {
    if (ratio <= kFadeStart) return 1.0f;
    const float x = (kFadeEnd - ratio) * 3.0f;  // 1 -> 0
    return x * x * (3 - 2 * x);
  }
  static lanes::vf fade_v(lanes::vf ratio) {
    using namespace lanes;
    const vf x = max(min((kFadeEnd - ratio) * 3.0f, splat(1.0f)), splat(0.0f));
    return select(ratio <= kFadeStart, splat(1.0f), x * x * (3 - 2 * x));
  }
  lanes::vf value_noise_v(lanes::vf x, lanes::vf y) const {
    using namespace lanes;
    const vi ix = floor_i(x), iy = floor_i(y);
    const vf fx = x - to_float(ix), fy = y - to_float(iy);
    const vi x0 = ix & (kNoiseSize - 1), x1 = (ix + 1) & (kNoiseSize - 1);
    const vi y0 = (iy & (kNoiseSize - 1)) * kNoiseSize,
             y1 = ((iy + 1) & (kNoiseSize - 1)) * kNoiseSize;
    vf l00, l01, l10, l11;
    for (int k = 0; k < kLanes; ++k) {
      l00[k] = lattice_[y0[k] + x0[k]], l01[k] = lattice_[y0[k] + x1[k]];
      l10[k] = lattice_[y1[k] + x0[k]], l11[k] = lattice_[y1[k] + x1[k]];
    }
    const vf sx = fx * fx * fx * (fx * (fx * 6 - 15) + 10);
    const vf sy = fy * fy * fy * (fy * (fy * 6 - 15) + 10);
    const vf a = l00 + sx * (l01 - l00);
    const vf b = l10 + sx * (l11 - l10);
    return (a + sy * (b - a)) * (1.0f / 127.0f);
  }

  /// Smooth (C2) value noise: quintic interpolation of a periodic lattice of values in [-1, 1].
  float value_noise(float x, float y) const {
    int ix = static_cast<int>(x), iy = static_cast<int>(y);
    ix -= x < static_cast<float>(ix);
    iy -= y < static_cast<float>(iy);
    const float fx = x - static_cast<float>(ix), fy = y - static_cast<float>(iy);
    const int x0 = ix & (kNoiseSize - 1), x1 = (ix + 1) & (kNoiseSize - 1);
    const int y0 = (iy & (kNoiseSize - 1)) * kNoiseSize,
              y1 = ((iy + 1) & (kNoiseSize - 1)) * kNoiseSize;
    const float sx = fx * fx * fx * (fx * (fx * 6 - 15) + 10);
    const float sy = fy * fy * fy * (fy * (fy * 6 - 15) + 10);
    const float l00 = lattice_[y0 + x0], l01 = lattice_[y0 + x1];
    const float l10 = lattice_[y1 + x0], l11 = lattice_[y1 + x1];
    const float a = l00 + sx * (l01 - l00);
    const float b = l10 + sx * (l11 - l10);
    return (a + sy * (b - a)) * (1.0f / 127.0f);
  }

  std::vector<Surface> surfaces_;  ///< 6 room faces (2·axis + max side), then panels
  std::vector<BallLook> balls_;
  std::vector<std::int8_t> lattice_;  ///< values in [-127, 127] (16 KB: stays in L1)
  Eigen::Vector3f room_min_, room_max_;
  std::uint64_t all_panels_ = 0;
  float illuminance_ = 0, ambient_ = 0;
  float light_[3] = {0, 0, 1};
};

}  // namespace fdv::sim
