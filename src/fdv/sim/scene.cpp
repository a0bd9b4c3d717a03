#include "fdv/sim/scene.h"

#include <cmath>
#include <numbers>

#include "fdv/sim/random.h"

namespace fdv::sim {
namespace {

int axis_index(const std::string& axis) { return axis == "x" ? 0 : axis == "y" ? 1 : 2; }

/// Three octaves: coarsest spacing `scale_m`, then /2.3 and /5.1, amplitudes 1, 0.55, 0.3, each
/// rotated by a random angle and offset so the lattice axes never line up.
void make_octaves(Surface& s, double scale_m, Rng& rng) {
  const double rel_spacing[kOctaves] = {1.0, 1.0 / 2.3, 1.0 / 5.1};
  const double amp[kOctaves] = {1.0, 0.55, 0.3};
  for (int k = 0; k < kOctaves; ++k) {
    const double spacing = scale_m * rel_spacing[k];
    const double angle = rng.uniform(0, 2 * std::numbers::pi);
    const double c = std::cos(angle) / spacing, sn = std::sin(angle) / spacing;
    Octave& o = s.octave[k];
    o.m00 = static_cast<float>(c), o.m01 = static_cast<float>(-sn);
    o.m10 = static_cast<float>(sn), o.m11 = static_cast<float>(c);
    o.o0 = static_cast<float>(rng.uniform(0, kNoiseSize));
    o.o1 = static_cast<float>(rng.uniform(0, kNoiseSize));
    o.amp = static_cast<float>(amp[k]);
    o.inv_spacing_m = static_cast<float>(1.0 / spacing);
  }
}

}  // namespace

Scene::Scene(const SceneConfig& config, const std::vector<BallConfig>& balls, std::uint64_t seed) {
  room_min_ = config.room_min_W_m.cast<float>();
  room_max_ = config.room_max_W_m.cast<float>();
  illuminance_ = static_cast<float>(config.illuminance_lux);
  ambient_ = static_cast<float>(config.ambient_fraction);
  const Eigen::Vector3d light = config.light_direction_W.normalized();
  for (int a = 0; a < 3; ++a) light_[a] = static_cast<float>(light[a]);

  Rng lattice_rng = Rng::stream(seed, RngStream::kScenario, 2000);
  lattice_.resize(kNoiseSize * kNoiseSize);
  for (auto& v : lattice_)
    v = static_cast<std::int8_t>(std::lround(lattice_rng.uniform(-127, 127)));

  Rng rng = Rng::stream(seed, RngStream::kScenario, 2001);
  auto log_radiance = [&](int axis, double albedo, float out[2]) {
    for (int side = 0; side < 2; ++side) {
      const double n_dot_l = (side == 0 ? -1.0 : 1.0) * light[axis];
      const double shade =
          config.ambient_fraction + (1 - config.ambient_fraction) * std::max(0.0, n_dot_l);
      out[side] = static_cast<float>(std::log(config.illuminance_lux * shade * albedo));
    }
  };
  for (int a = 0; a < 3; ++a)
    for (int up = 0; up < 2; ++up) {
      Surface s;
      s.axis = a;
      s.u_axis = a == 0 ? 1 : 0;
      s.v_axis = a == 2 ? 1 : 2;
      s.coord = up ? room_max_[a] : room_min_[a];
      const double albedo =
          a == 2 ? (up ? config.ceiling_albedo : config.floor_albedo) : config.wall_albedo;
      log_radiance(a, albedo, s.log_radiance);
      s.contrast = static_cast<float>(config.surface_contrast);
      make_octaves(s, config.surface_scale_m, rng);
      surfaces_.push_back(s);
    }
  for (const auto& p : config.panels) {
    Surface s;
    s.axis = axis_index(p.axis);
    s.u_axis = s.axis == 0 ? 1 : 0;
    s.v_axis = s.axis == 2 ? 1 : 2;
    s.coord = static_cast<float>(p.position_m);
    s.umin = static_cast<float>(p.min_m.x()), s.umax = static_cast<float>(p.max_m.x());
    s.vmin = static_cast<float>(p.min_m.y()), s.vmax = static_cast<float>(p.max_m.y());
    log_radiance(s.axis, p.albedo, s.log_radiance);
    s.contrast = static_cast<float>(p.contrast);
    make_octaves(s, p.scale_m, rng);
    all_panels_ |= 1ull << (surfaces_.size() - kRoomSurfaces);
    surfaces_.push_back(s);
  }

  for (const auto& bc : balls) {
    BallLook b;
    b.id = bc.id;
    b.radius = static_cast<float>(bc.radius_m);
    b.log_albedo = static_cast<float>(std::log(bc.albedo));
    b.contrast = static_cast<float>(bc.contrast);
    Rng ball_rng =
        Rng::stream(seed, RngStream::kScenario, 3000 + static_cast<std::uint64_t>(bc.id));
    const double rel[3] = {1.0, 1.6, 2.5}, amp[3] = {1.0, 0.6, 0.4};
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d dir = ball_rng.normal3();
      dir.normalize();
      const double freq = bc.texture_frequency * rel[k];
      for (int a = 0; a < 3; ++a) b.wave[k][a] = static_cast<float>(dir[a] * freq);
      b.phase[k] = static_cast<float>(ball_rng.uniform(0, 2 * std::numbers::pi));
      b.amp[k] = static_cast<float>(amp[k]);
      b.inv_wavelength_m[k] = static_cast<float>(freq / (2 * std::numbers::pi * bc.radius_m));
    }
    balls_.push_back(b);
  }
}

std::array<Eigen::Vector3d, 4> Scene::panel_corners(int i) const {
  const Surface& s = surfaces_[kRoomSurfaces + i];
  std::array<Eigen::Vector3d, 4> c;
  const float us[4] = {s.umin, s.umax, s.umax, s.umin}, vs[4] = {s.vmin, s.vmin, s.vmax, s.vmax};
  for (int k = 0; k < 4; ++k) {
    c[k][s.axis] = s.coord;
    c[k][s.u_axis] = us[k];
    c[k][s.v_axis] = vs[k];
  }
  return c;
}

}  // namespace fdv::sim
