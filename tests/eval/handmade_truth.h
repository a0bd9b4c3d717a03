#pragma once
// A hand-made DatasetTruth for the scoring tests: an ideal 640x480 camera (f = 500 px, no
// distortion) at the world origin looking along +z (vehicle still, T_B_E identity), no gravity,
// so a ball's pixel is u = cx + f X / Z, v = cy + f Y / Z by hand.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "fdv/eval/dataset_truth.h"
#include "fdv/eval/detection_metrics.h"

namespace fdv::test {

constexpr double kF = 500.0, kCx = 319.5, kCy = 239.5;

constexpr TimeNs ms(int m) { return m * kNsPerMs; }

/// The 10 ms window starting at `t0_ms`, with its detections.
inline WindowDetections window(int t0_ms, std::vector<WindowDetections::Det> dets = {},
                               std::string status = "") {
  return {ms(t0_ms), ms(t0_ms + 10), std::move(dets), std::move(status)};
}

inline Eigen::Vector2d pixel_of(const Eigen::Vector3d& p) {
  return {kCx + kF * p.x() / p.z(), kCy + kF * p.y() / p.z()};
}

/// Ball `id` of `radius_m` whose state at t (seconds) is `state(t)` = (position, velocity), sampled
/// every millisecond over [0, end_ms].
inline DatasetTruth handmade_truth(
    double radius_m, int end_ms,
    const std::function<std::pair<Eigen::Vector3d, Eigen::Vector3d>(double)>& state, int id = 1) {
  DatasetTruth t;
  t.dir = "handmade";
  t.calibration.event_camera = {640, 480, kF, kF, kCx, kCy, {}};
  t.body.resize(2);
  t.body[0].t = 0;
  t.body[1].t = kNsPerS;
  t.gravity_W = Eigen::Vector3d::Zero();
  t.radius_m[id] = radius_m;
  for (int ms = 0; ms <= end_ms; ++ms) {
    const auto [p, v] = state(ms * 1e-3);
    t.objects.push_back({ms * kNsPerMs, id, p, v});
  }
  return t;
}

/// Constant velocity `v` from `p0` at t = 0.
inline DatasetTruth straight_flight(const Eigen::Vector3d& p0, const Eigen::Vector3d& v,
                                    double radius_m = 0.25, int end_ms = 200) {
  return handmade_truth(radius_m, end_ms, [=](double t) {
    return std::pair{Eigen::Vector3d(p0 + t * v), v};
  });
}

}  // namespace fdv::test
