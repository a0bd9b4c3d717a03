#include "fdv/eval/detection_metrics.h"

#include <algorithm>
#include <limits>
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
  else if (!(min_fraction_in_view_any_size > 0 && min_fraction_in_view_any_size <= 1))
    why << "min_fraction_in_view_any_size must be in (0, 1], got " << min_fraction_in_view_any_size;
  else if (!(min_size_px >= 0))
    why << "min_size_px must be >= 0, got " << min_size_px;
  else if (!(max_size_of_short_side > 0))
    why << "max_size_of_short_side must be > 0, got " << max_size_of_short_side;
  return why.str();
}

std::string size_bin_label(std::size_t bin) {
  if (bin == 0) return fmt::format("< {:g} px", kSizeBinEdges_px.front());
  if (bin >= kSizeBinEdges_px.size()) return fmt::format("> {:g} px", kSizeBinEdges_px.back());
  return fmt::format("{:g}-{:g} px", kSizeBinEdges_px[bin - 1], kSizeBinEdges_px[bin]);
}

std::size_t size_bin_of(double size_px) {
  return static_cast<std::size_t>(
      std::upper_bound(kSizeBinEdges_px.begin(), kSizeBinEdges_px.end(), size_px) -
      kSizeBinEdges_px.begin());
}

void RecallCounts::merge(const RecallCounts& other) {
  eligible += other.eligible;
  found += other.found;
  center_errors_px.insert(center_errors_px.end(), other.center_errors_px.begin(),
                          other.center_errors_px.end());
  sizes_px.insert(sizes_px.end(), other.sizes_px.begin(), other.sizes_px.end());
}

namespace {
/// The median, or null when there is nothing to take it of.
nlohmann::json median_or_null(const std::vector<double>& values) {
  return values.empty() ? nlohmann::json(nullptr) : nlohmann::json(summarize(values).median);
}
}  // namespace

nlohmann::json RecallCounts::to_json() const {
  return {{"eligible_windows", eligible},
          {"detected", found},
          {"recall", recall()},
          {"median_center_error_px", median_or_null(center_errors_px)},
          {"median_size_px", median_or_null(sizes_px)}};
}

void ObjectMetrics::merge(const ObjectMetrics& other) {
  counts.merge(other.counts);
  id_switches += other.id_switches;
  max_id_switches_per_run = std::max(max_id_switches_per_run, other.max_id_switches_per_run);
}

void DetectionMetrics::merge(const DetectionMetrics& other) {
  windows += other.windows;
  eligible += other.eligible;
  found += other.found;
  false_detections += other.false_detections;
  center_errors_px.insert(center_errors_px.end(), other.center_errors_px.begin(),
                          other.center_errors_px.end());
  per_window.insert(per_window.end(), other.per_window.begin(), other.per_window.end());
  per_pair.insert(per_pair.end(), other.per_pair.begin(), other.per_pair.end());
  any_size.merge(other.any_size);
  for (std::size_t i = 0; i < size_bins.size(); ++i) size_bins[i].merge(other.size_bins[i]);
  partial.merge(other.partial);
  center_full_errors_px.insert(center_full_errors_px.end(), other.center_full_errors_px.begin(),
                               other.center_full_errors_px.end());
  partial_flagged += other.partial_flagged;
  fills_view_windows += other.fills_view_windows;
  fills_view_reported += other.fills_view_reported;
  duplicate_detections += other.duplicate_detections;
  for (const auto& [id, o] : other.objects) objects[id].merge(o);
}

void write_window_outcomes_csv(std::ostream& out, const std::vector<WindowOutcome>& windows) {
  out << "t_start_s,t_end_s,eligible,found,detections,false_detections,center_error_px,ball,"
         "fraction_in_view_min,span_px_min,size_px,fills_view,u_min,v_min,u_max,v_max\n";
  for (const WindowOutcome& w : windows) {
    out << fmt::format("{:.6f},{:.6f},{},{},{},{},", to_seconds(w.t_start), to_seconds(w.t_end),
                       w.eligible ? 1 : 0, w.found ? 1 : 0, w.detections, w.false_detections);
    if (w.center_error_px >= 0) out << fmt::format("{:.3f}", w.center_error_px);
    out << fmt::format(",{},{:.3f},{:.2f},{:.2f},{}", w.ball, w.fraction_in_view_min, w.span_px_min,
                       w.size_px, w.fills_view ? 1 : 0);
    if (w.ball >= 0)
      out << fmt::format(",{:.1f},{:.1f},{:.1f},{:.1f}\n", w.box.u_min, w.box.v_min, w.box.u_max, w.box.v_max);
    else
      out << ",,,,\n";
  }
}

void write_pair_outcomes_csv(std::ostream& out, const std::vector<PairOutcome>& pairs) {
  out << "t_start_s,t_end_s,ball,size_px,fraction_in_view_min,partial,fills_view,found,center_error_px,track,"
         "u_min,v_min,u_max,v_max\n";
  for (const PairOutcome& p : pairs) {
    out << fmt::format("{:.6f},{:.6f},{},{:.2f},{:.3f},{},{},{},", to_seconds(p.t_start), to_seconds(p.t_end),
                       p.ball, p.size_px, p.fraction_in_view_min, p.partial ? 1 : 0, p.fills_view ? 1 : 0,
                       p.found ? 1 : 0);
    if (p.center_error_px >= 0) out << fmt::format("{:.3f}", p.center_error_px);
    out << fmt::format(",{},{:.1f},{:.1f},{:.1f},{:.1f}\n", p.track, p.box.u_min, p.box.v_min, p.box.u_max,
                       p.box.v_max);
  }
}

nlohmann::json DetectionMetrics::to_json() const {
  const Summary e = summarize(center_errors_px);
  nlohmann::json bins = nlohmann::json::array();
  for (std::size_t i = 0; i < size_bins.size(); ++i) {
    nlohmann::json b = size_bins[i].to_json();
    b["bin"] = size_bin_label(i);
    bins.push_back(b);
  }
  nlohmann::json partial_json = partial.to_json();
  partial_json["flagged_partial"] = partial_flagged;
  partial_json["center_full_count"] = center_full_errors_px.size();
  partial_json["median_center_full_error_px"] = median_or_null(center_full_errors_px);
  return {{"windows", windows},
          {"eligible_windows", eligible},
          {"eligible_windows_detected", found},
          {"recall", recall()},
          {"median_center_error_px", e.median},
          {"center_error_px", e.to_json()},
          {"false_detections", false_detections},
          {"false_detections_per_window", false_per_window()},
          {"any_size", any_size.to_json()},
          {"size_bins", bins},
          {"partial", partial_json},
          {"fills_view", {{"windows", fills_view_windows}, {"reported", fills_view_reported}}},
          {"duplicate_detections", duplicate_detections}};
}

nlohmann::json DetectionMetrics::objects_json() const {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [id, o] : objects)
    out.push_back({{"id", id},
                   {"eligible_windows", o.counts.eligible},
                   {"recall", o.counts.recall()},
                   {"median_center_error_px", median_or_null(o.counts.center_errors_px)},
                   {"id_switches", o.id_switches}});
  return out;
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

/// The ball's true centre projected at t; nothing behind the camera.
std::optional<Eigen::Vector2d> projected_center(const DatasetTruth& truth, int ball, TimeNs t) {
  const auto s = truth.object_at(ball, t);
  if (!s) return std::nullopt;
  const Eigen::Isometry3d T_W_E = truth.body_at(t).T_W_B() * truth.calibration.T_B_E;
  const Eigen::Vector3d p_E = T_W_E.inverse() * s->p_W;
  if (p_E.z() <= 0) return std::nullopt;
  return truth.calibration.event_camera.project(p_E);
}

/// The ball a detection belongs to: the one whose box (grown by margin_px) holds its centre, the
/// nearest true centre at the detection's time where several do (the box's centre when the ball's
/// centre is behind the camera); -1 for none.
int matched_ball(const DatasetTruth& truth, const std::map<int, GroundTruthBox>& boxes,
                 const WindowDetections::Det& d, double margin_px) {
  int matched = -1;
  double nearest = std::numeric_limits<double>::infinity();
  for (const auto& [id, b] : boxes) {
    if (!b.contains(d.center_raw.x(), d.center_raw.y(), margin_px)) continue;
    const Eigen::Vector2d c = projected_center(truth, id, d.t)
                                  .value_or(Eigen::Vector2d((b.u_min + b.u_max) / 2,
                                                            (b.v_min + b.v_max) / 2));
    if (const double distance = (c - d.center_raw).norm(); matched < 0 || distance < nearest) {
      matched = id;
      nearest = distance;
    }
  }
  return matched;
}

enum class Eligibility { kNone, kEligible, kFillsView };

/// The any-size eligibility of one ball in one window, with its apparent size at the middle.
Eligibility any_size_eligibility(const DatasetTruth& truth, int id, const GroundTruthBox& box,
                                 TimeNs t_mid, const DetectionMetricsOptions& o, double& size_px) {
  size_px = 0;
  if (!box.visible || !truth.in_flight(id, t_mid) ||
      box.fraction_in_view_min < o.min_fraction_in_view_any_size)
    return Eligibility::kNone;
  size_px = visible_silhouette(truth.objects, id, truth.radius_m.at(id), truth.body,
                               truth.calibration, t_mid)
                .size_px();
  const auto& cam = truth.calibration.event_camera;
  if (size_px > o.max_size_of_short_side * std::min(cam.width, cam.height))
    return Eligibility::kFillsView;
  return size_px >= o.min_size_px ? Eligibility::kEligible : Eligibility::kNone;
}

}  // namespace

DetectionMetrics detection_metrics(const DatasetTruth& truth,
                                   const std::vector<WindowDetections>& windows,
                                   const DetectionMetricsOptions& options) {
  if (const std::string why = options.validate(); !why.empty())
    throw ConfigError("detection metrics: " + why);
  DetectionMetrics m;
  for (const auto& [id, r] : truth.radius_m) m.objects[id];
  std::map<int, int> last_track;  // ball -> track of its last detection with a track
  std::map<int, int> switches;    // ball -> identity switches in this run
  for (const WindowDetections& w : windows) {
    ++m.windows;
    const TimeNs t_mid = (w.t_start + w.t_end) / 2;
    const std::map<int, GroundTruthBox> boxes = window_boxes(truth, w);
    std::set<int> eligible;
    for (const auto& [id, b] : boxes)
      if (truth.in_flight(id, t_mid) && b.visible &&
          b.fraction_in_view_min >= options.min_fraction_in_view &&
          b.span_px_min >= options.min_span_px)
        eligible.insert(id);
    WindowOutcome o;
    o.t_start = w.t_start;
    o.t_end = w.t_end;
    o.eligible = !eligible.empty();
    o.detections = static_cast<int>(w.detections.size());
    m.eligible += o.eligible;
    std::map<int, Eligibility> any_size;
    std::map<int, double> size_px;
    for (const auto& [id, b] : boxes) {
      any_size[id] = any_size_eligibility(truth, id, b, t_mid, options, size_px[id]);
      o.fills_view = o.fills_view || any_size[id] == Eligibility::kFillsView;
    }
    if (o.fills_view) {
      ++m.fills_view_windows;
      m.fills_view_reported += w.status == kFillsTheViewStatus;
    }
    // The ball to report: eligible before not, then the most in view.
    const auto rank = [&](int ball, double fraction) { return std::pair(eligible.count(ball), fraction); };
    for (const auto& [id, b] : boxes) {
      if (!b.visible || !truth.in_flight(id, t_mid)) continue;
      if (o.ball < 0 || rank(id, b.fraction_in_view_min) > rank(o.ball, o.fraction_in_view_min)) {
        o.ball = id;
        o.fraction_in_view_min = b.fraction_in_view_min;
        o.span_px_min = b.span_px_min;
        o.box = b;
        o.size_px = size_px[id];
      }
    }
    // Each detection to its ball; each ball keeps the detection nearest to its true centre.
    std::map<int, std::pair<const WindowDetections::Det*, double>> taken;  // ball -> (det, distance)
    for (const auto& d : w.detections) {
      const int ball = matched_ball(truth, boxes, d, options.margin_px);
      if (ball < 0) {
        ++m.false_detections;
        ++o.false_detections;
        continue;
      }
      const auto center = projected_center(truth, ball, d.t);
      const double distance = center ? (*center - d.center_raw).norm()
                                     : std::numeric_limits<double>::infinity();
      if (const auto it = taken.find(ball); it == taken.end()) {
        taken[ball] = {&d, distance};
      } else {
        ++m.duplicate_detections;
        if (distance < it->second.second) it->second = {&d, distance};
      }
      if (!eligible.count(ball)) continue;
      o.found = true;
      if (!center) continue;
      m.center_errors_px.push_back(distance);
      if (o.center_error_px < 0) o.center_error_px = distance;
    }
    m.found += o.found;
    m.per_window.push_back(o);

    for (const auto& [id, b] : boxes) {
      const auto it = taken.find(id);
      const WindowDetections::Det* d = it == taken.end() ? nullptr : it->second.first;
      if (d && d->track >= 0) {
        if (const auto last = last_track.find(id); last != last_track.end() && last->second != d->track)
          ++switches[id];
        last_track[id] = d->track;
      }
      if (any_size[id] == Eligibility::kNone) continue;
      const bool partial = b.fraction_in_view_min < 1;
      PairOutcome& pair = m.per_pair.emplace_back();
      pair.t_start = w.t_start;
      pair.t_end = w.t_end;
      pair.ball = id;
      pair.size_px = size_px[id];
      pair.fraction_in_view_min = b.fraction_in_view_min;
      pair.partial = partial;
      pair.fills_view = any_size[id] == Eligibility::kFillsView;
      pair.found = d != nullptr;
      pair.track = d ? d->track : -1;
      pair.box = b;
      if (pair.fills_view) continue;
      std::vector<RecallCounts*> counts{&m.any_size, &m.size_bins[size_bin_of(size_px[id])],
                                        &m.objects[id].counts};
      if (partial) counts.push_back(&m.partial);
      for (RecallCounts* c : counts) ++c->eligible;
      if (!d) continue;
      const VisibleSilhouette at_detection = visible_silhouette(
          truth.objects, id, truth.radius_m.at(id), truth.body, truth.calibration, d->t);
      if (at_detection.visible)  // else the detection's time lies beyond the truth
        pair.center_error_px = (at_detection.visible_center_px - d->center_raw).norm();
      for (RecallCounts* c : counts) {
        ++c->found;
        if (pair.center_error_px < 0) continue;
        c->center_errors_px.push_back(pair.center_error_px);
        c->sizes_px.push_back(size_px[id]);
      }
      if (!partial) continue;
      m.partial_flagged += d->partial;
      if (const auto c = projected_center(truth, id, d->t); c && d->center_full_raw)
        m.center_full_errors_px.push_back((*c - *d->center_full_raw).norm());
    }
  }
  for (auto& [id, o] : m.objects) {
    o.id_switches = switches[id];
    o.max_id_switches_per_run = switches[id];
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
      on_ball += matched_ball(truth, boxes, d, options.margin_px) == id;
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
      if (matched_ball(truth, boxes, d, options.margin_px) == id) return FirstBallDetection{w.t_end, d};
  }
  return std::nullopt;
}

}  // namespace fdv
