#include "fdv/eval/dataset_truth.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/eval/ground_truth_box.h"
#include "fdv/io/dataset/dataset_reader.h"

namespace fdv {

std::optional<ObjectState> DatasetTruth::object_at(int id, TimeNs t) const {
  const ObjectState* best = nullptr;
  for (const ObjectState& s : objects)
    if (s.id == id && (!best || std::abs(s.t - t) < std::abs(best->t - t))) best = &s;
  if (!best || std::abs(best->t - t) > 10 * kNsPerMs) return std::nullopt;
  const double dt = to_seconds(t - best->t);
  ObjectState out = *best;
  out.t = t;
  out.p_W = best->p_W + dt * best->v_W + 0.5 * dt * dt * gravity_W;
  out.v_W = best->v_W + dt * gravity_W;
  return out;
}

OdometrySample DatasetTruth::body_at(TimeNs t) const { return interpolate_odometry(body, t); }

bool DatasetTruth::in_flight(int id, TimeNs t) const {
  const auto s = object_at(id, t);
  return s && s->v_W.norm() >= kMinFlightSpeed_m_s;
}

DatasetTruth load_dataset_truth(const std::string& dir) {
  namespace fs = std::filesystem;
  DatasetTruth truth;
  truth.dir = dir;
  const std::string manifest_path = (fs::path(dir) / kDatasetManifest).string();
  if (!fs::exists(manifest_path))
    throw InputError(dir, "", "not a dataset folder (no dataset.yaml)");
  truth.calibration = load_calibration((fs::path(dir) / "calibration.yaml").string());
  truth.body = read_body_truth(dir);
  truth.objects = read_object_truth(dir);
  if (truth.body.empty())
    throw InputError(dir, "truth/body.csv", "missing or empty: no ground truth");
  std::stable_sort(truth.objects.begin(), truth.objects.end(),
                   [](const ObjectState& a, const ObjectState& b) { return a.t < b.t; });
  try {
    const YAML::Node m = parse_config_yaml(read_config_file(manifest_path), manifest_path);
    if (m["scenario"]) truth.scenario = m["scenario"].as<std::string>();
    if (m["gravity_W"]) {
      const auto g = m["gravity_W"].as<std::vector<double>>();
      if (g.size() == 3) truth.gravity_W = {g[0], g[1], g[2]};
    }
    for (const auto& b : m["balls"]) truth.radius_m[b["id"].as<int>()] = b["radius_m"].as<double>();
  } catch (const YAML::Exception& e) {
    throw InputError(manifest_path, "line " + std::to_string(e.mark.line + 1), e.msg);
  }
  for (const ObjectState& s : truth.objects)
    if (!truth.radius_m.count(s.id))
      throw InputError(manifest_path, "key balls",
                       "no radius for object id " + std::to_string(s.id));
  return truth;
}

cv::Rect undistorted_truth_rect(const DatasetTruth& truth, int id, TimeNs t0, TimeNs t1,
                                const GroundTruthBoxOptions& options) {
  Calibration ideal = truth.calibration;
  ideal.event_camera.distortion = {};
  const GroundTruthBox b = ground_truth_box(truth.objects, id, truth.radius_m.at(id), truth.body,
                                            ideal, t0, t1, options);
  if (!b.visible) return {};
  const cv::Point lo(static_cast<int>(std::lround(b.u_min)),
                     static_cast<int>(std::lround(b.v_min)));
  const cv::Point hi(static_cast<int>(std::lround(b.u_max)) + 1,
                     static_cast<int>(std::lround(b.v_max)) + 1);
  return cv::Rect(lo, hi);
}

std::optional<TimeNs> first_in_flight_in_view(const DatasetTruth& truth, int id,
                                              double min_fraction_in_view) {
  if (truth.body.empty() || !truth.radius_m.count(id)) return std::nullopt;
  for (TimeNs t = truth.body.front().t; t <= truth.body.back().t; t += kNsPerMs) {
    if (!truth.in_flight(id, t)) continue;
    const GroundTruthBox b = ground_truth_box(truth.objects, id, truth.radius_m.at(id), truth.body,
                                              truth.calibration, t, t);
    if (b.visible && b.fraction_in_view_min >= min_fraction_in_view) return t;
  }
  return std::nullopt;
}

std::optional<TimeNs> true_contact_time(const DatasetTruth& truth, int id, double radius_m) {
  if (truth.body.empty()) return std::nullopt;
  for (const ObjectState& s : truth.objects) {
    if (s.id != id || s.t < truth.body.front().t || s.t > truth.body.back().t) continue;
    if ((s.p_W - truth.body_at(s.t).p_W_B).norm() <= radius_m) return s.t;
  }
  return std::nullopt;
}

std::optional<TrueClosestApproach> true_closest_approach(const DatasetTruth& truth, int id) {
  if (truth.body.empty()) return std::nullopt;
  std::optional<TrueClosestApproach> best;
  for (const ObjectState& s : truth.objects) {
    if (s.id != id || s.t < truth.body.front().t || s.t > truth.body.back().t) continue;
    const double d = (s.p_W - truth.body_at(s.t).p_W_B).norm();
    if (!best || d < best->distance_m) best = TrueClosestApproach{s.t, d};
  }
  return best;
}

}  // namespace fdv
