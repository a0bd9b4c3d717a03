#include "fdv/results/schema.h"

#include <cmath>
#include <limits>

#include "fdv/detection/candidate_source.h"

namespace fdv {
namespace {

using json = nlohmann::json;

json box_json(const Box2D& b) { return {b.x0, b.y0, b.x1, b.y1}; }
json vec_json(const Eigen::Vector2d& v) { return {v.x(), v.y()}; }
json vec_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
Box2D box_of(const json& j) { return {j.at(0), j.at(1), j.at(2), j.at(3)}; }
Eigen::Vector2d vec2_of(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>()}; }
Eigen::Vector3d vec3_of(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()}; }

/// Reads `key` into `out` when the line has it (the default stays otherwise: older results).
template <typename T>
void optional_key(const json& j, const char* key, T& out) {
  if (const auto it = j.find(key); it != j.end()) out = it->template get<T>();
}
/// A number that may have been non-finite when written: JSON has no infinity or NaN, and
/// nlohmann::json writes them as null.
void optional_number(const json& j, const char* key, double& out, double if_null) {
  if (const auto it = j.find(key); it != j.end()) out = it->is_null() ? if_null : it->get<double>();
}
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// summary.json's names of the by-reason and by-flag counts, in one table each for both directions.
using Dropped = PerceptionCounters::DroppedEvents;
using Flags = PerceptionCounters::FallbackFlags;
constexpr std::pair<const char*, std::uint64_t Dropped::*> kDropReasons[] = {
    {"decimated (overload policy)", &Dropped::overload},
    {"outside the window", &Dropped::outside_window},
    {"outside the sensor", &Dropped::outside_sensor},
    {"no lens-model inverse at the pixel", &Dropped::no_inverse},
    {"warped outside the image", &Dropped::left_image},
    {"hot pixel", &Dropped::hot_pixel},
};
constexpr std::pair<const char*, std::uint64_t Flags::*> kFallbackFlags[] = {
    {"imu missing", &Flags::imu_missing},         {"imu gap", &Flags::imu_gap},
    {"odometry missing", &Flags::odometry_missing}, {"depth missing", &Flags::depth_missing},
    {"depth stale", &Flags::depth_stale},         {"depth wrong size", &Flags::depth_wrong_size},
};

/// The DetectionStatus whose text is `name` (enumerators are contiguous from 0; to_string says "?"
/// past the last).
std::optional<DetectionStatus> parse_status(std::string_view name) {
  for (int i = 0; i < 256; ++i) {
    const auto s = static_cast<DetectionStatus>(i);
    if (to_string(s) == "?") break;
    if (to_string(s) == name) return s;
  }
  return std::nullopt;
}

PerceptionCounters counters_of(const json& j) {
  PerceptionCounters c;
  c.events = j.at("events_read");
  c.events_in_windows = j.at("events");
  c.windows = j.at("windows");
  c.windows_skipped = j.at("windows_skipped_in_gaps");
  c.detections = j.at("detections");
  const json& dropped = j.at("events_dropped_by_reason");
  for (const auto& [name, member] : kDropReasons) optional_key(dropped, name, c.events_dropped.*member);
  const json& flags = j.at("windows_with_fallback_flag");
  for (const auto& [name, member] : kFallbackFlags) optional_key(flags, name, c.windows_flagged.*member);
  for (const auto& [name, n] : j.at("windows_by_status").items()) {
    const auto status = parse_status(name);
    if (!status) throw std::invalid_argument("unknown detection status '" + name + "' in windows_by_status");
    c.windows_by_status[*status] = n;
  }
  for (const auto& [name, n] : j.at("windows_by_method").items()) {
    const auto method = parse_compensation_method(name);
    if (!method) throw std::invalid_argument("unknown compensation method '" + name + "' in windows_by_method");
    c.windows_by_method[*method] = n;
  }
  c.imu = j.at("imu");
  c.odometry = j.at("odometry");
  c.depth_frames = j.at("depth_frames");
  c.depth_rejected_registration = j.at("depth_frames_rejected");
  c.depth_observations = j.at("depth_observations");
  c.estimates = j.at("estimates");
  optional_key(j, "dodge_decisions", c.dodge_decisions);
  c.imu_out_of_order = j.at("imu_out_of_order");
  c.odometry_out_of_order = j.at("odometry_out_of_order");
  return c;
}

}  // namespace

json counts_json(const PerceptionCounters& c) {
  json by_status = json::object(), by_method = json::object();
  for (const auto& [status, n] : c.windows_by_status) by_status[std::string(to_string(status))] = n;
  for (const auto& [method, n] : c.windows_by_method) by_method[std::string(to_string(method))] = n;
  json dropped = json::object(), flags = json::object();
  for (const auto& [name, n] : dropped_by_reason(c)) dropped[name] = n;
  for (const auto& [name, n] : windows_by_fallback_flag(c)) flags[name] = n;
  return {{"events_read", c.events},
          {"events", c.events_in_windows},
          {"windows", c.windows},
          {"windows_skipped_in_gaps", c.windows_skipped},
          {"detections", c.detections},
          {"events_dropped", c.events_dropped.total()},
          {"events_dropped_by_reason", dropped},
          {"windows_by_status", by_status},
          {"windows_by_method", by_method},
          {"windows_with_fallback_flag", flags},
          {"imu", c.imu},
          {"odometry", c.odometry},
          {"depth_frames", c.depth_frames},
          {"depth_frames_rejected", c.depth_rejected_registration},
          {"depth_observations", c.depth_observations},
          {"estimates", c.estimates},
          {"dodge_decisions", c.dodge_decisions},
          {"imu_out_of_order", c.imu_out_of_order},
          {"odometry_out_of_order", c.odometry_out_of_order}};
}

std::map<std::string, std::uint64_t> dropped_by_reason(const PerceptionCounters& c) {
  std::map<std::string, std::uint64_t> out;
  if (c.windows > 0)
    for (const auto& [name, member] : kDropReasons) out[name] = c.events_dropped.*member;
  return out;
}

std::map<std::string, std::uint64_t> windows_by_fallback_flag(const PerceptionCounters& c) {
  std::map<std::string, std::uint64_t> out;
  if (c.windows > 0)
    for (const auto& [name, member] : kFallbackFlags) out[name] = c.windows_flagged.*member;
  return out;
}

void to_json(json& j, const DetectionRow& r) {
  j = {{"box", box_json(r.box)},
       {"center", vec_json(r.center)},
       {"box_undistorted", box_json(r.box_undistorted)},
       {"center_undistorted", vec_json(r.center_undistorted)},
       {"t", r.t_s},
       {"events", r.events},
       {"score", r.score},
       {"event_density", r.event_density},
       {"track_aided", r.track_aided},
       {"source", r.source},
       {"track", r.track},
       {"partial", r.partial},
       {"visible_fraction", r.visible_fraction}};
  if (r.center_full) j["center_full"] = vec_json(*r.center_full);
}

void from_json(const json& j, DetectionRow& r) {
  r.t_s = j.at("t");
  r.center = vec2_of(j.at("center"));
  if (const auto it = j.find("box"); it != j.end()) r.box = box_of(*it);
  if (const auto it = j.find("box_undistorted"); it != j.end()) r.box_undistorted = box_of(*it);
  if (const auto it = j.find("center_undistorted"); it != j.end()) r.center_undistorted = vec2_of(*it);
  optional_key(j, "events", r.events);
  optional_number(j, "score", r.score, kNaN);
  optional_number(j, "event_density", r.event_density, kNaN);
  optional_key(j, "track_aided", r.track_aided);
  optional_key(j, "source", r.source);
  optional_key(j, "track", r.track);
  optional_key(j, "partial", r.partial);
  optional_number(j, "visible_fraction", r.visible_fraction, 1.0);
  if (const auto it = j.find("center_full"); it != j.end()) r.center_full = vec2_of(*it);
}

void to_json(json& j, const WindowRow& r) {
  j = {{"t_start", r.t_start_s}, {"t_end", r.t_end_s},   {"events", r.events},
       {"method", r.method},     {"status", r.status}, {"detections", json::array()}};
  if (r.method_requested) j["method_requested"] = *r.method_requested;
  for (const DetectionRow& d : r.detections) j["detections"].push_back(d);
}

void from_json(const json& j, WindowRow& r) {
  r.t_start_s = j.at("t_start");
  r.t_end_s = j.at("t_end");
  r.detections = j.at("detections").get<std::vector<DetectionRow>>();
  optional_key(j, "events", r.events);
  optional_key(j, "method", r.method);
  optional_key(j, "status", r.status);
  if (const auto it = j.find("method_requested"); it != j.end()) r.method_requested = it->get<std::string>();
}

void to_json(json& j, const DepthRow& r) {
  j = {{"t", r.t_s},
       {"track", r.track},
       {"accepted", r.observation.has_value()},
       {"roi_pixels", r.roi_pixels},
       {"valid_pixels", r.valid_pixels}};
  if (const auto& o = r.observation) {
    j["depth"] = o->depth_m;
    j["surface_depth"] = o->surface_depth_m;
    j["sigma"] = o->sigma_m;
    j["pixels"] = o->pixels;
    j["spread"] = o->spread_m;
    j["center"] = vec_json(o->center);
  } else {
    j["rejection"] = r.rejection;
    j["reason"] = r.reason;
  }
}

void from_json(const json& j, DepthRow& r) {
  r.t_s = j.at("t");
  r.track = j.at("track");
  optional_key(j, "roi_pixels", r.roi_pixels);
  optional_key(j, "valid_pixels", r.valid_pixels);
  if (j.at("accepted").get<bool>()) {
    DepthRow::Observation o;
    o.depth_m = j.at("depth");
    optional_number(j, "surface_depth", o.surface_depth_m, kNaN);
    optional_number(j, "sigma", o.sigma_m, kNaN);
    optional_key(j, "pixels", o.pixels);
    optional_number(j, "spread", o.spread_m, kNaN);
    if (const auto it = j.find("center"); it != j.end()) o.center = vec2_of(*it);
    r.observation = o;
  } else {
    optional_key(j, "rejection", r.rejection);
    optional_key(j, "reason", r.reason);
  }
}

void to_json(json& j, const TrajectoryRow& r) {
  j = {{"t", r.t_s},
       {"track", r.track},
       {"method", r.method},
       {"fit", r.fit},
       {"usable", r.usable},
       {"converged", r.converged},
       {"t0", r.t0_s},
       {"p0", vec_json(r.p0_W)},
       {"v0", vec_json(r.v0_W)},
       {"gravity", vec_json(r.gravity_W)},
       {"t_first", r.t_first_s},
       {"t_last", r.t_last_s},
       {"event_observations", r.event_observations},
       {"depth_observations", r.depth_observations},
       {"outliers", r.outliers},
       {"cost", r.cost},
       {"iterations", r.iterations},
       {"message", r.message}};
  if (const auto& u = r.uncertainty) {
    json cov = json::array();
    for (int row = 0; row < 6; ++row)
      for (int col = 0; col < 6; ++col) cov.push_back(u->covariance(row, col));
    j["covariance"] = cov;
    j["position_sigma"] = u->position_sigma_m;
    j["horizon_sigma"] = u->horizon_sigma_m;
  }
  if (const auto& l = r.looming) {
    j["apparent_size_px"] = l->size_px;
    j["apparent_size_sigma_px"] = l->size_sigma_px;
    j["tau_s"] = l->tau_s ? json(*l->tau_s) : json();
    j["tau_sigma_s"] = l->tau_sigma_s ? json(*l->tau_sigma_s) : json();
  }
  if (r.radius_conflict) j["radius_conflict"] = true;
}

void from_json(const json& j, TrajectoryRow& r) {
  r.t_s = j.at("t");
  r.track = j.at("track");
  r.method = j.at("method");
  r.usable = j.at("usable");
  r.converged = j.value("converged", r.usable);
  r.t0_s = j.at("t0");
  r.p0_W = vec3_of(j.at("p0"));
  r.v0_W = vec3_of(j.at("v0"));
  r.gravity_W = vec3_of(j.at("gravity"));
  r.t_first_s = j.at("t_first");
  r.t_last_s = j.at("t_last");
  optional_key(j, "fit", r.fit);
  optional_key(j, "event_observations", r.event_observations);
  optional_key(j, "depth_observations", r.depth_observations);
  optional_key(j, "outliers", r.outliers);
  optional_number(j, "cost", r.cost, kNaN);
  optional_key(j, "iterations", r.iterations);
  optional_key(j, "message", r.message);
  if (const auto it = j.find("covariance"); it != j.end()) {
    TrajectoryRow::Uncertainty u;
    if (it->size() != 36) throw std::invalid_argument("covariance has " + std::to_string(it->size()) + " numbers, not 36");
    for (int row = 0; row < 6; ++row)
      for (int col = 0; col < 6; ++col) {
        const json& v = it->at(static_cast<std::size_t>(6 * row + col));
        u.covariance(row, col) = v.is_null() ? kNaN : v.get<double>();
      }
    optional_number(j, "position_sigma", u.position_sigma_m, kInf);
    optional_number(j, "horizon_sigma", u.horizon_sigma_m, kInf);
    r.uncertainty = u;
  }
  if (j.contains("apparent_size_px")) {
    TrajectoryRow::LoomingKeys l;
    l.size_px = j.at("apparent_size_px");
    optional_key(j, "apparent_size_sigma_px", l.size_sigma_px);
    if (const auto it = j.find("tau_s"); it != j.end() && !it->is_null()) l.tau_s = it->get<double>();
    if (const auto it = j.find("tau_sigma_s"); it != j.end() && !it->is_null()) l.tau_sigma_s = it->get<double>();
    r.looming = l;
  }
  optional_key(j, "radius_conflict", r.radius_conflict);
}

void to_json(json& j, const PredictionRow& r) {
  j = {{"t", r.t_s},
       {"track", r.track},
       {"closest_t", r.closest_t_s},
       {"closest_in_s", r.closest_in_s},
       {"miss_distance", r.miss_distance_m},
       {"object_W", vec_json(r.object_W)},
       {"passage_B", vec_json(r.passage_B)},
       {"receding", r.receding}};
  if (r.time_to_contact_s) j["time_to_contact"] = *r.time_to_contact_s;
  if (r.miss_distance_sigma_m) j["miss_distance_sigma"] = *r.miss_distance_sigma_m;
}

void from_json(const json& j, PredictionRow& r) {
  r.t_s = j.at("t");
  r.track = j.at("track");
  r.closest_t_s = j.at("closest_t");
  r.miss_distance_m = j.at("miss_distance");
  optional_key(j, "closest_in_s", r.closest_in_s);
  if (const auto it = j.find("object_W"); it != j.end()) r.object_W = vec3_of(*it);
  if (const auto it = j.find("passage_B"); it != j.end()) r.passage_B = vec3_of(*it);
  optional_key(j, "receding", r.receding);
  if (const auto it = j.find("time_to_contact"); it != j.end()) r.time_to_contact_s = it->get<double>();
  if (const auto it = j.find("miss_distance_sigma"); it != j.end()) r.miss_distance_sigma_m = it->get<double>();
}

void to_json(json& j, const DodgeRow& r) {
  j = {{"t", r.t_s},
       {"effective_t", r.effective_t_s},
       {"track", r.track},
       {"action", r.action},
       {"probability", r.probability},
       {"miss_distance", r.miss_distance_m},
       {"committed", r.committed},
       {"reason", r.reason}};
  if (r.time_to_contact_s) j["time_to_contact"] = *r.time_to_contact_s;
  if (const auto& m = r.maneuver)
    j["maneuver"] = {{"acceleration_W", vec_json(m->acceleration_W)},
                     {"start_t", m->start_t_s},
                     {"duration", m->duration_s},
                     {"expected_clearance", m->expected_clearance_m},
                     {"probability_after", m->probability_after}};
}

void from_json(const json& j, DodgeRow& r) {
  r.t_s = j.at("t");
  r.action = j.at("action");
  r.effective_t_s = r.t_s;
  optional_key(j, "effective_t", r.effective_t_s);
  optional_key(j, "track", r.track);
  optional_key(j, "probability", r.probability);
  optional_key(j, "miss_distance", r.miss_distance_m);
  optional_key(j, "committed", r.committed);
  optional_key(j, "reason", r.reason);
  if (const auto it = j.find("time_to_contact"); it != j.end()) r.time_to_contact_s = it->get<double>();
  if (const auto it = j.find("maneuver"); it != j.end()) {
    DodgeRow::Maneuver m;
    m.acceleration_W = vec3_of(it->at("acceleration_W"));
    m.start_t_s = it->at("start_t");
    m.duration_s = it->at("duration");
    optional_key(*it, "expected_clearance", m.expected_clearance_m);
    optional_key(*it, "probability_after", m.probability_after);
    r.maneuver = m;
  }
}

void to_json(json& j, const RunSummary& s) {
  json timing = json::object();
  for (const auto& [stage, t] : s.timing_ms)
    timing[stage] = {{"count", t.count}, {"min", t.min}, {"median", t.median}, {"p99", t.p99},
                     {"max", t.max},     {"mean", t.mean}};
  j = {{"counts", counts_json(s.counts)},
       {"timing_ms", timing},
       {"input", s.input},
       {"format", s.format},
       {"resolution", {s.width, s.height}},
       {"calibration", s.calibration},
       {"method_requested", s.method_requested},
       {"method", s.method},
       {"threads", s.threads},
       {"reader_report", s.reader_report},
       {"warnings", s.warnings},
       {"options", s.options},
       {"detector_in_use", s.detector_in_use}};
}

void from_json(const json& j, RunSummary& s) {
  s.counts = counters_of(j.at("counts"));
  for (const auto& [stage, t] : j.at("timing_ms").items()) {
    Summary& out = s.timing_ms[stage];
    out.count = t.at("count");
    out.min = t.at("min");
    out.median = t.at("median");
    out.p99 = t.at("p99");
    out.max = t.at("max");
    out.mean = t.at("mean");
  }
  s.input = j.at("input");
  s.format = j.at("format");
  s.width = j.at("resolution").at(0);
  s.height = j.at("resolution").at(1);
  s.calibration = j.at("calibration");
  s.method_requested = j.at("method_requested");
  s.method = j.at("method");
  s.threads = j.at("threads");
  s.reader_report = j.at("reader_report");
  s.warnings = j.at("warnings").get<std::vector<std::string>>();
  s.options = j.value("options", nlohmann::json::object());
  s.detector_in_use = j.value("detector_in_use", nlohmann::json::object());
}

WindowRow window_row(const WindowResult& w) {
  WindowRow r;
  r.t_start_s = to_seconds(w.t_start);
  r.t_end_s = to_seconds(w.t_end);
  r.events = w.events;
  r.method = to_string(w.compensation.used);
  r.status = to_string(w.status);
  if (w.compensation.used != w.compensation.requested) r.method_requested = to_string(w.compensation.requested);
  for (const auto& [d, track_id] : w.detections)
    r.detections.push_back({d.box_raw, d.center_raw, d.box_undistorted, d.center_undistorted, to_seconds(d.t),
                            d.events, d.score, d.event_density, d.track_aided, std::string(to_string(d.source)),
                            track_id, d.partial, d.visible_fraction, d.center_full_raw});
  return r;
}

DepthRow depth_row(const DepthResult& d) {
  DepthRow r;
  r.t_s = to_seconds(d.t);
  r.track = d.track_id;
  r.roi_pixels = d.segmentation.roi_pixels;
  r.valid_pixels = d.segmentation.valid_pixels;
  if (const auto& o = d.segmentation.observation) {
    r.observation = {o->depth_m, o->surface_depth_m, o->sigma_m, o->pixel_count, o->spread_m, o->center_px};
  } else {
    r.rejection = to_string(d.segmentation.rejection);
    r.reason = d.segmentation.reason;
  }
  return r;
}

TrajectoryRow trajectory_row(const EstimateResult& e) {
  const TrajectoryEstimate& est = *e.estimate;
  TrajectoryRow r;
  r.t_s = to_seconds(e.t);
  r.track = e.track_id;
  r.method = e.mode == EstimatorMode::kFusion ? "fusion" : "mono";
  r.fit = to_string(est.method);
  r.usable = est.usable;
  r.converged = est.converged;
  r.t0_s = to_seconds(est.trajectory.t0);
  r.p0_W = est.trajectory.p0_W;
  r.v0_W = est.trajectory.v0_W;
  r.gravity_W = est.trajectory.gravity_W;
  r.t_first_s = to_seconds(est.t_first);
  r.t_last_s = to_seconds(est.t_last);
  r.event_observations = est.event_observations;
  r.depth_observations = est.depth_observations;
  r.outliers = est.outliers;
  r.cost = est.final_cost;
  r.iterations = est.iterations;
  r.message = est.message;
  if (est.covariance) r.uncertainty = {*est.covariance, est.position_sigma_m, est.horizon_sigma_m};
  if (const auto& l = e.looming) r.looming = TrajectoryRow::LoomingKeys{l->size_px, l->size_sigma_px, l->tau_s, l->tau_sigma_s};
  r.radius_conflict = e.radius_conflict;
  return r;
}

PredictionRow prediction_row(const PredictionResult& p) {
  const CollisionPrediction& c = p.prediction;
  PredictionRow r;
  r.t_s = to_seconds(p.t);
  r.track = p.track_id;
  r.closest_t_s = to_seconds(c.closest.t);
  r.closest_in_s = c.closest.time_from_now_s;
  r.miss_distance_m = c.closest.miss_distance_m;
  r.object_W = c.closest.object_W;
  r.passage_B = c.closest.offset_B;
  r.receding = c.closest.receding;
  if (c.contact) r.time_to_contact_s = c.time_to_contact_s;
  r.miss_distance_sigma_m = p.miss_distance_sigma_m;
  return r;
}

DodgeRow dodge_row(const DodgeDecision& d) {
  DodgeRow r;
  r.t_s = to_seconds(d.t);
  r.effective_t_s = to_seconds(d.effective_t);
  r.track = d.track_id;
  r.action = to_string(d.action);
  r.probability = d.probability;
  if (std::isfinite(d.time_to_contact_s)) r.time_to_contact_s = d.time_to_contact_s;
  r.miss_distance_m = d.miss_distance_m;
  r.committed = d.committed;
  r.reason = d.reason;
  if (const auto& m = d.maneuver)
    r.maneuver = DodgeRow::Maneuver{m->acceleration_W, to_seconds(m->start_t), m->duration_s,
                                    m->expected_clearance_m, m->probability_after};
  return r;
}

std::vector<std::string> window_timing_stages() {
  std::vector<std::string> stages{"compensation", "time_images", "segmentation", "preprocess"};
  for (const RegisteredSource& s : registered_sources()) stages.emplace_back(s.name);
  for (const char* stage : {"refine", "detection_total", "tracking", "window_total"}) stages.emplace_back(stage);
  return stages;
}

WindowTimingRow window_timing_row(const WindowResult& w) {
  WindowTimingRow r;
  r.window = w.index;
  r.t_start_s = to_seconds(w.t_start);
  const WindowTimings& t = w.timings;
  r.stage_ms = {{"compensation", t.compensation_ms},       {"time_images", t.detection.time_images_ms},
                {"segmentation", t.detection.segmentation_ms}, {"preprocess", t.detection.preprocess_ms},
                {"detection_total", t.detection.total_ms},   {"tracking", t.tracking_ms},
                {"window_total", t.total_ms}};
  // The candidate sources tried in this window (summary "count": in how many windows).
  for (const SourceTime& s : t.detection.sources()) r.stage_ms[std::string(s.source)] = s.ms;
  // The found objects' centre and time from their events (EventRefiner): windows with a candidate.
  if (t.detection.refine_ms > 0) r.stage_ms["refine"] = t.detection.refine_ms;
  return r;
}

}  // namespace fdv
