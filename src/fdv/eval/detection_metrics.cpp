#include "fdv/eval/detection_metrics.h"

#include <algorithm>
#include <map>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/eval/ground_truth_box.h"
#include "fdv/eval/statistics.h"

namespace fdv {

std::string DetectionMetricsOptions::validate() const {
  std::ostringstream why;
  if (!(min_fraction_in_view >= 0 && min_fraction_in_view <= 1))
    why << "min_fraction_in_view must be in [0, 1], got " << min_fraction_in_view;
  else if (!(min_span_px >= 0))
    why << "min_span_px must be >= 0, got " << min_span_px;
  else if (!(margin_px >= 0))
    why << "margin_px must be >= 0, got " << margin_px;
  return why.str();
}

void DetectionMetrics::merge(const DetectionMetrics& other) {
  windows += other.windows;
  eligible += other.eligible;
  found += other.found;
  false_detections += other.false_detections;
  center_errors_px.insert(center_errors_px.end(), other.center_errors_px.begin(),
                          other.center_errors_px.end());
  per_window.insert(per_window.end(), other.per_window.begin(), other.per_window.end());
}

void write_window_outcomes_csv(std::ostream& out, const std::vector<WindowOutcome>& windows) {
  out << "t_start_s,t_end_s,eligible,found,detections,false_detections,center_error_px,ball,"
         "fraction_in_view_min,span_px_min\n";
  for (const WindowOutcome& w : windows) {
    out << fmt::format("{:.6f},{:.6f},{},{},{},{},", to_seconds(w.t_start), to_seconds(w.t_end),
                       w.eligible ? 1 : 0, w.found ? 1 : 0, w.detections, w.false_detections);
    if (w.center_error_px >= 0) out << fmt::format("{:.3f}", w.center_error_px);
    out << fmt::format(",{},{:.3f},{:.2f}\n", w.ball, w.fraction_in_view_min, w.span_px_min);
  }
}

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

namespace {

/// Each ball's true box over the window (raw pixels, distortion included).
std::map<int, GroundTruthBox> window_boxes(const DatasetTruth& truth, const WindowDetections& w) {
  std::map<int, GroundTruthBox> boxes;
  for (const auto& [id, r] : truth.radius_m)
    boxes[id] = ground_truth_box(truth.objects, id, r, truth.body, truth.calibration, w.t_start,
                                 w.t_end - 1);
  return boxes;
}

/// The ball whose box holds the detection; -1 for none (the last one wins where boxes overlap).
int matched_ball(const std::map<int, GroundTruthBox>& boxes, const WindowDetections::Det& d,
                 double margin_px) {
  int matched = -1;
  for (const auto& [id, b] : boxes)
    if (b.contains(d.center_raw.x(), d.center_raw.y(), margin_px)) matched = id;
  return matched;
}

}  // namespace

DetectionMetrics detection_metrics(const DatasetTruth& truth,
                                   const std::vector<WindowDetections>& windows,
                                   const DetectionMetricsOptions& options) {
  if (const std::string why = options.validate(); !why.empty())
    throw ConfigError("detection metrics: " + why);
  DetectionMetrics m;
  for (const WindowDetections& w : windows) {
    ++m.windows;
    const std::map<int, GroundTruthBox> boxes = window_boxes(truth, w);
    std::set<int> eligible;
    for (const auto& [id, b] : boxes)
      if (truth.in_flight(id, (w.t_start + w.t_end) / 2) && b.visible &&
          b.fraction_in_view_min >= options.min_fraction_in_view &&
          b.span_px_min >= options.min_span_px)
        eligible.insert(id);
    WindowOutcome o;
    o.t_start = w.t_start;
    o.t_end = w.t_end;
    o.eligible = !eligible.empty();
    o.detections = static_cast<int>(w.detections.size());
    m.eligible += o.eligible;
    // The ball to report: eligible before not, then the most in view.
    const auto rank = [&](int ball, double fraction) { return std::pair(eligible.count(ball), fraction); };
    for (const auto& [id, b] : boxes) {
      if (!b.visible || !truth.in_flight(id, (w.t_start + w.t_end) / 2)) continue;
      if (o.ball < 0 || rank(id, b.fraction_in_view_min) > rank(o.ball, o.fraction_in_view_min)) {
        o.ball = id;
        o.fraction_in_view_min = b.fraction_in_view_min;
        o.span_px_min = b.span_px_min;
      }
    }
    for (const auto& d : w.detections) {
      const int ball = matched_ball(boxes, d, options.margin_px);
      if (ball < 0) {
        ++m.false_detections;
        ++o.false_detections;
        continue;
      }
      if (!eligible.count(ball)) continue;
      o.found = true;
      if (const auto s = truth.object_at(ball, d.t)) {
        const Eigen::Isometry3d T_W_E = truth.body_at(d.t).T_W_B() * truth.calibration.T_B_E;
        const Eigen::Vector3d p_E = T_W_E.inverse() * s->p_W;
        if (p_E.z() > 0) {
          const double error = (truth.calibration.event_camera.project(p_E) - d.center_raw).norm();
          m.center_errors_px.push_back(error);
          if (o.center_error_px < 0) o.center_error_px = error;
        }
      }
    }
    m.found += o.found;
    m.per_window.push_back(o);
  }
  return m;
}

std::vector<int> tracks_following(const DatasetTruth& truth,
                                  const std::vector<WindowDetections>& windows, int id,
                                  const DetectionMetricsOptions& options) {
  if (const std::string why = options.validate(); !why.empty())
    throw ConfigError("detection metrics: " + why);
  std::map<int, std::pair<int, int>> counts;  // track -> (detections on the ball, all detections)
  for (const WindowDetections& w : windows) {
    if (w.detections.empty()) continue;
    const std::map<int, GroundTruthBox> boxes = window_boxes(truth, w);
    for (const auto& d : w.detections) {
      if (d.track < 0) continue;
      auto& [on_ball, all] = counts[d.track];
      on_ball += matched_ball(boxes, d, options.margin_px) == id;
      ++all;
    }
  }
  std::vector<std::pair<int, int>> following;  // (on_ball, track)
  for (const auto& [track, c] : counts)
    if (2 * c.first > c.second) following.emplace_back(c.first, track);
  std::stable_sort(following.begin(), following.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<int> out;
  for (const auto& f : following) out.push_back(f.second);
  return out;
}

std::optional<FirstBallDetection> first_ball_detection(const DatasetTruth& truth,
                                                       const std::vector<WindowDetections>& windows, int id,
                                                       const DetectionMetricsOptions& options) {
  if (const std::string why = options.validate(); !why.empty()) throw ConfigError("detection metrics: " + why);
  for (const WindowDetections& w : windows) {  // in window order
    if (w.detections.empty()) continue;
    const std::map<int, GroundTruthBox> boxes = window_boxes(truth, w);
    for (const auto& d : w.detections)
      if (matched_ball(boxes, d, options.margin_px) == id) return FirstBallDetection{w.t_end, d};
  }
  return std::nullopt;
}

}  // namespace fdv
