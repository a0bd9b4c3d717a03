#pragma once
// A synthetic event window for detection tests, seen by a static camera (so "none" is the exact
// compensation): a static textured background (edge segments firing at random times through the
// window), uniform background-activity noise, and a disk ("ball") moving at constant image
// velocity on the undistorted grid, firing events uniformly over its area. Events are raw sensor
// pixels through the lens model, time-ordered.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "fdv/core/camera.h"
#include "fdv/core/sensor_data.h"
#include "fdv/detection/count_contrast_source.h"
#include "fdv/detection/dense_motion_source.h"
#include "fdv/detection/detection_result.h"
#include "fdv/detection/gaussian_fit_source.h"

namespace fdv::test {

/// A VGA camera with a mild barrel lens, the detection tests' usual sensor.
inline PinholeCamera lens() {
  return {640, 480, 400.0, 401.0, 318.0, 243.0, {-0.1, 0.01, 0.0005, -0.0003, 0.0}};
}

/// Whether `source` wrote diagnostics in `r` (it ran as far as them).
inline bool ran(const DetectionResult& r, std::string_view source) {
  return std::any_of(r.source_diagnostics().begin(), r.source_diagnostics().end(),
                     [&](const SourceDiagnostics& d) { return d.source() == source && !d.empty(); });
}
/// The diagnostics `source` wrote in `r`, or D's zeros when it wrote none.
template <class D>
D diagnostics_or_zero(const DetectionResult& r, std::string_view source) {
  const D* d = r.diagnostics<D>(source);
  return d ? *d : D{};
}
inline DenseMotionDiagnostics dense_motion_of(const DetectionResult& r) {
  return diagnostics_or_zero<DenseMotionDiagnostics>(r, DenseMotionSource::kName);
}
inline CountContrastDiagnostics count_contrast_of(const DetectionResult& r) {
  return diagnostics_or_zero<CountContrastDiagnostics>(r, CountContrastSource::kName);
}

/// Why the paper's source did not use its last fit ("" when it did), for failure messages.
inline std::string_view fit_rejected(const DetectionResult& r) {
  const auto* fit = r.diagnostics<PatternFitDiagnostics>(GaussianFitSource::kName);
  return fit ? fit->fit_rejected : "no pattern fitted";
}

struct BlobScene {
  Eigen::Vector2d start_uv{200, 150};      // undistorted grid at t0 [px]
  Eigen::Vector2d velocity_px_s{300, 160};  // [px/s]
  double radius_px = 6;
  double blob_rate_ev_s = 400'000;          // events of the blob [1/s]
  int edge_segments = 60;                   // background texture
  int events_per_edge_px = 3;
  double noise_rate_ev_s = 400'000;         // uniform background activity [1/s]
  TimeNs t0 = 0;
  TimeNs duration = 25 * kNsPerMs;
  unsigned seed = 1;

  Eigen::Vector2d blob_at(TimeNs t) const { return start_uv + velocity_px_s * to_seconds(t - t0); }
};

inline bool to_raw(const PinholeCamera& cam, const Eigen::Vector2d& uv, Event& e) {
  const Eigen::Vector2d px = cam.normalized_to_pixel({(uv.x() - cam.cx) / cam.fx, (uv.y() - cam.cy) / cam.fy});
  const long x = std::lround(px.x()), y = std::lround(px.y());
  if (x < 0 || y < 0 || x >= cam.width || y >= cam.height) return false;
  e.x = static_cast<std::uint16_t>(x);
  e.y = static_cast<std::uint16_t>(y);
  return true;
}

inline std::vector<Event> make_scene(const PinholeCamera& cam, const BlobScene& s) {
  std::mt19937 rng(s.seed);
  std::uniform_int_distribution<TimeNs> when(s.t0, s.t0 + s.duration - 1);
  std::uniform_real_distribution<double> ux(0, cam.width - 1), uy(0, cam.height - 1), unit(0, 1);
  std::vector<Event> ev;
  // Background edges: straight segments 20-80 px long, away from the blob's path.
  for (int i = 0; i < s.edge_segments; ++i) {
    const Eigen::Vector2d a(ux(rng), uy(rng));
    const double ang = unit(rng) * M_PI, len = 20 + 60 * unit(rng);
    for (double l = 0; l < len; l += 1.0) {
      const Eigen::Vector2d p = a + l * Eigen::Vector2d(std::cos(ang), std::sin(ang));
      if ((p - s.blob_at(s.t0 + s.duration / 2)).norm() < 40) continue;
      Event e;
      if (!to_raw(cam, p, e)) continue;
      for (int k = 0; k < s.events_per_edge_px; ++k) {
        e.t = when(rng);
        e.polarity = k % 2 == 0;
        ev.push_back(e);
      }
    }
  }
  // Noise.
  const int n_noise = static_cast<int>(s.noise_rate_ev_s * to_seconds(s.duration));
  for (int i = 0; i < n_noise; ++i) {
    Event e{when(rng), static_cast<std::uint16_t>(ux(rng) + 0.5), static_cast<std::uint16_t>(uy(rng) + 0.5), true};
    ev.push_back(e);
  }
  // The blob: events uniformly over its disk at its position at each event's time.
  const int n_blob = static_cast<int>(s.blob_rate_ev_s * to_seconds(s.duration));
  for (int i = 0; i < n_blob; ++i) {
    const TimeNs t = when(rng);
    const double r = s.radius_px * std::sqrt(unit(rng)), phi = 2 * M_PI * unit(rng);
    Event e;
    e.t = t;
    e.polarity = true;
    if (to_raw(cam, s.blob_at(t) + r * Eigen::Vector2d(std::cos(phi), std::sin(phi)), e)) ev.push_back(e);
  }
  std::sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  return ev;
}

}  // namespace fdv::test
