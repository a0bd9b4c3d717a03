#include "apps/experiment.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "fdv/core/error.h"
#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/io/time_ordered_merger.h"

namespace fdv::cli {

PerceptionCounters replay(std::unique_ptr<RecordingReader> reader, const Calibration& calib,
                          const PerceptionOptions& options, const PerceptionCallbacks& callbacks,
                          ReadReport* reader_report) {
  Perception perception(calib, options, callbacks);
  std::vector<std::unique_ptr<RecordingReader>> sources;
  sources.push_back(std::move(reader));
  TimeOrderedMerger merger(std::move(sources));
  StreamItem item;
  while (merger.next(item)) {
    switch (item.kind) {
      case StreamKind::kEvents: perception.push_events(item.events); break;
      case StreamKind::kImu: perception.push_imu(*item.imu); break;
      case StreamKind::kDepth: perception.push_depth(*item.depth); break;
      case StreamKind::kOdometry: perception.push_odometry(*item.odometry); break;
      case StreamKind::kGroundTruth: break;  // evaluation only, never the pipeline
    }
  }
  perception.finish();
  if (reader_report) *reader_report = merger.source(0).report();
  return perception.counters();
}

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

DatasetTruth load_dataset_truth(const std::string& dir) {
  namespace fs = std::filesystem;
  DatasetTruth truth;
  truth.dir = dir;
  const std::string manifest_path = (fs::path(dir) / kDatasetManifest).string();
  if (!fs::exists(manifest_path)) throw InputError(dir, "", "not a dataset folder (no dataset.yaml)");
  truth.calibration = load_calibration((fs::path(dir) / "calibration.yaml").string());
  truth.body = read_body_truth(dir);
  truth.objects = read_object_truth(dir);
  if (truth.body.empty()) throw InputError(dir, "truth/body.csv", "missing or empty: no ground truth");
  std::stable_sort(truth.objects.begin(), truth.objects.end(),
                   [](const ObjectState& a, const ObjectState& b) { return a.t < b.t; });
  try {
    const YAML::Node m = YAML::LoadFile(manifest_path);
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
      throw InputError(manifest_path, "key balls", "no radius for object id " + std::to_string(s.id));
  return truth;
}

}  // namespace fdv::cli

#include <fstream>
#include <nlohmann/json.hpp>

#include "fdv/eval/ground_truth_box.h"
#include "fdv/eval/statistics.h"

namespace fdv::cli {

namespace {
/// A ball held or lying still makes no events of its own: it counts for recall only in flight.
constexpr double kMinFlightSpeed_m_s = 1.0;
}  // namespace

nlohmann::json DetectionMetrics::to_json() const {
  const Summary e = summarize(center_errors_px);
  return {{"windows", windows},
          {"eligible_windows", eligible},
          {"eligible_windows_detected", found},
          {"recall", recall()},
          {"median_center_error_px", e.median},
          {"center_error_px", e.to_json()},
          {"false_detections", false_detections},
          {"false_detections_per_window", false_per_window()}};
}

std::vector<WindowDetections> read_detections(const std::string& results_dir) {
  const std::string path = results_dir + "/detections.jsonl";
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open (run `fdv run ... --out DIR` first)");
  std::vector<WindowDetections> out;
  std::string line;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    try {
      const auto j = nlohmann::json::parse(line);
      WindowDetections w;
      w.t_start = from_seconds(j.at("t_start").get<double>());
      w.t_end = from_seconds(j.at("t_end").get<double>());
      for (const auto& d : j.at("detections"))
        w.detections.push_back({from_seconds(d.at("t").get<double>()),
                                {d.at("center")[0].get<double>(), d.at("center")[1].get<double>()}});
      out.push_back(std::move(w));
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path, "line " + std::to_string(n), e.what());
    }
  }
  return out;
}

DetectionMetrics detection_metrics(const DatasetTruth& truth, const std::vector<WindowDetections>& windows,
                                   double min_fraction_in_view, double min_span_px, double margin_px) {
  DetectionMetrics m;
  for (const WindowDetections& w : windows) {
    ++m.windows;
    std::map<int, GroundTruthBox> boxes;
    bool eligible_ball = false;
    for (const auto& [id, r] : truth.radius_m) {
      boxes[id] = ground_truth_box(truth.objects, id, r, truth.body, truth.calibration, w.t_start, w.t_end - 1);
      const GroundTruthBox& b = boxes[id];
      const auto mid = truth.object_at(id, (w.t_start + w.t_end) / 2);
      const bool in_flight = mid && mid->v_W.norm() >= kMinFlightSpeed_m_s;
      if (in_flight && b.visible && b.fraction_in_view_min >= min_fraction_in_view && b.span_px_min >= min_span_px)
        eligible_ball = true;
    }
    m.eligible += eligible_ball;
    bool found = false;
    for (const auto& d : w.detections) {
      int matched = -1;
      for (const auto& [id, b] : boxes)
        if (b.contains(d.center_raw.x(), d.center_raw.y(), margin_px)) matched = id;
      if (matched < 0) {
        ++m.false_detections;
        continue;
      }
      const GroundTruthBox& b = boxes[matched];
      if (eligible_ball && b.fraction_in_view_min >= min_fraction_in_view && b.span_px_min >= min_span_px)
        found = true;
      if (const auto s = truth.object_at(matched, d.t)) {
        const Eigen::Isometry3d T_W_E = truth.body_at(d.t).T_W_B() * truth.calibration.T_B_E;
        const Eigen::Vector3d p_E = T_W_E.inverse() * s->p_W;
        if (p_E.z() > 0)
          m.center_errors_px.push_back((truth.calibration.event_camera.project(p_E) - d.center_raw).norm());
      }
    }
    m.found += found;
  }
  return m;
}

cv::Rect undistorted_truth_rect(const DatasetTruth& truth, int id, TimeNs t0, TimeNs t1) {
  Calibration ideal = truth.calibration;
  ideal.event_camera.distortion = {};
  const GroundTruthBox b = ground_truth_box(truth.objects, id, truth.radius_m.at(id), truth.body, ideal, t0, t1);
  if (!b.visible) return {};
  const cv::Point lo(static_cast<int>(std::lround(b.u_min)), static_cast<int>(std::lround(b.v_min)));
  const cv::Point hi(static_cast<int>(std::lround(b.u_max)) + 1, static_cast<int>(std::lround(b.v_max)) + 1);
  return cv::Rect(lo, hi);
}

}  // namespace fdv::cli
