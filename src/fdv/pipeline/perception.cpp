#include "fdv/pipeline/perception.h"

#include <algorithm>
#include <chrono>
#include <iterator>

#include <fmt/format.h>

#include "fdv/compensation/imu_window.h"
#include "fdv/core/error.h"
#include "fdv/detection/gaussian_fit.h"
#include "fdv/estimation/camera_pose.h"
#include "fdv/pipeline/detector_input.h"
#include "fdv/pipeline/sensor_policy.h"

namespace fdv {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// History kept for IMU and odometry behind the newest sample: a window, the lateness allowance
/// and the estimator's own lateness, with margin.
constexpr TimeNs kHistoryNs = 2 * kNsPerS;

template <typename T>
void trim_history(std::vector<T>& v) {
  if (v.size() < 64) return;
  const TimeNs keep_from = v.back().t - kHistoryNs;
  auto first_kept = std::find_if(v.begin(), v.end(), [&](const T& s) { return s.t >= keep_from; });
  // Erase in bulk only when a good share is stale (amortised O(1) per sample).
  if (first_kept - v.begin() > static_cast<std::ptrdiff_t>(v.size() / 2)) v.erase(v.begin(), first_kept - 1);
}

}  // namespace

const char* to_string(DodgeSource s) {
  switch (s) {
    case DodgeSource::kFusion: return "fusion";
    case DodgeSource::kMonocular: return "monocular";
    case DodgeSource::kFusionPointEstimate: return "fusion_point_estimate";
    case DodgeSource::kNone: return "none";
  }
  return "?";
}

std::string PerceptionOptions::validate() const {
  // Window and top-level messages name the YAML keys (fdv/pipeline/options_yaml.h renames the
  // windower's window_ns to window_ms).
  if (auto why = windows.validate(); !why.empty()) return why;
  if (threads < 1 || threads > 64) return "threads must be in [1, 64], got " + std::to_string(threads);
  const std::pair<const char*, std::string> parts[] = {
      {"compensation", compensation.validate()},
      {"detection", detection.validate()},
      {"depth_registration", depth_registration.validate()},
      {"tracking", tracking.validate()},
      {"looming", looming.validate()},
      {"depth_segmentation", depth_segmentation.validate()},
      {"prediction", prediction.validate()},
      {"dodge", dodge.validate()},
  };
  for (const auto& [name, why] : parts)
    if (!why.empty()) return std::string(name) + ": " + why;
  if (max_lateness_ns < 0) return "max_lateness_ms must not be negative";
  if (odometry_max_extrapolation_ns < 0) return "odometry_max_extrapolation_ms must not be negative";
  if (depth_before_first_detection_ns < 0) return "depth_before_first_detection_ms must not be negative";
  return {};
}

PerceptionOptions overlapping_window_options(PerceptionOptions o) {
  const int n = o.windows.overlap();
  if (n <= 1) return o;
  const double sqrt_n = std::sqrt(static_cast<double>(n));
  const auto span = [n](int k) { return 1 + (k - 1) * n; };  // k windows' time span, in steps
  o.tracking.filter.measurement_sigma_px *= sqrt_n;
  o.tracking.size_noise *= sqrt_n;
  o.tracking.confirm_hits = span(o.tracking.confirm_hits);
  o.looming.size_sigma_px *= sqrt_n;
  o.looming.size_sigma_fraction *= sqrt_n;
  o.looming.fit_detections *= n;
  o.looming.min_detections = span(o.looming.min_detections);
  o.detection.hot_pixels.memory_windows *= n;
  return o;
}

void PerceptionCounters::count_window(const WindowResult& w) {
  ++windows;
  windows_skipped += w.skipped_before;
  detections += w.detections.size();
  events_in_windows += w.events;
  const CompensationReport& r = w.compensation;
  events_dropped.overload += w.decimated + r.dropped_burst;
  events_dropped.outside_window += r.dropped_outside_window;
  events_dropped.outside_sensor += r.dropped_outside_sensor;
  events_dropped.no_inverse += r.dropped_no_inverse;
  events_dropped.left_image += r.dropped_left_image;
  events_dropped.hot_pixel += w.hot_pixel_events;
  windows_flagged.imu_missing += r.imu_missing;
  windows_flagged.imu_gap += r.imu_gap;
  windows_flagged.odometry_missing += r.odometry_missing;
  windows_flagged.depth_missing += r.depth_missing;
  windows_flagged.depth_stale += r.depth_stale;
  windows_flagged.depth_wrong_size += r.depth_wrong_size;
  ++windows_by_status[w.status];
  ++windows_by_method[r.used];
}

Perception::Perception(const Calibration& calibration, PerceptionOptions options,
                       PerceptionCallbacks callbacks)
    : calibration_(calibration),
      options_([&] {
        if (options.estimation.event_focal_px <= 0)
          options.estimation.event_focal_px = 0.5 * (calibration.event_camera.fx + calibration.event_camera.fy);
        options.estimation.mode = EstimatorMode::kFusion;
        options.compensation.threads = options.threads;
        // One overload limit: the windower decimates first, to at most this many events, so the
        // compensator's own guard (for direct callers) never acts inside the pipeline, also when
        // the configuration raises the limit above the shared default.
        options.compensation.max_events_per_window = options.windows.max_events_per_window;
        if (const auto why = options.validate(); !why.empty()) throw ConfigError(why);
        if (const auto why = options.estimation.validate(); !why.empty())
          throw ConfigError("estimation: " + why);
        return overlapping_window_options(std::move(options));
      }()),
      callbacks_(std::move(callbacks)),
      windower_(options_.windows),
      compensator_(make_compensator(calibration, options_.compensation)),
      detector_(options_.detection, calibration.event_camera),
      tracker_(options_.tracking) {
  if (options_.detection.hot_pixels.enabled)
    hot_pixels_.emplace(options_.detection.hot_pixels, calibration.event_camera.width, calibration.event_camera.height);
  if (calibration.depth_camera) registrar_.emplace(calibration, options_.depth_registration);
  if (options_.estimate_trajectories && options_.dodge_from != DodgeSource::kNone)
    planner_.emplace(options_.dodge, options_.prediction.safety_radius_m);
}

Perception::~Perception() = default;

void Perception::warn_once(const std::string& key, const std::string& message) {
  if (std::find(warned_.begin(), warned_.end(), key) != warned_.end()) return;
  warned_.push_back(key);
  if (callbacks_.on_warning) callbacks_.on_warning(message);
}

void Perception::advance_stream_time(TimeNs t) { stream_time_ = std::max(stream_time_, t); }

void Perception::enqueue(const EventWindow& w) {
  PendingWindow p;
  if (!free_buffers_.empty()) {  // reuse a processed window's storage: no allocation once warm
    p.events = std::move(free_buffers_.back());
    free_buffers_.pop_back();
  }
  p.t_start = w.t_start;
  p.t_end = w.t_end;
  p.index = w.index;
  p.decimated = w.decimated;
  p.skipped_before = w.skipped_before;
  if (w.storage) {  // take the windower's buffer instead of copying 2-4 MB; it gets ours back
    p.events.clear();
    p.events.swap(*w.storage);
  } else {
    p.events.assign(w.events.begin(), w.events.end());
  }
  pending_windows_.push_back(std::move(p));
}

void Perception::drop_input(const char* stream, const char* why, std::uint64_t index, TimeNs t, std::uint64_t n) {
  const std::string reason = std::string(stream) + ": " + why;
  input_report_.drop(reason, std::string(stream) + " " + std::to_string(index) + " (t " + std::to_string(t) + " ns)", n);
  warn_once("dropped " + reason, "pushed " + reason + ": dropped (further ones counted in the input report)");
}

void Perception::push_events(std::span<const Event> events) {
  const std::uint64_t first_index = events_pushed_;
  events_pushed_ += events.size();
  const auto corrupt = [](const Event& e) { return !valid_time(e.t); };
  if (const auto bad = std::find_if(events.begin(), events.end(), corrupt); bad != events.end()) {
    valid_events_.clear();
    std::remove_copy_if(events.begin(), events.end(), std::back_inserter(valid_events_), corrupt);
    drop_input("event", "time out of range (corrupt)", first_index + static_cast<std::uint64_t>(bad - events.begin()),
               bad->t, events.size() - valid_events_.size());
    events = valid_events_;
  }
  if (events.empty()) return;
  counters_.events += events.size();
  windower_.push(events, [this](const EventWindow& w) { enqueue(w); });
  advance_stream_time(events.back().t);
  process_ready(false);
}

void Perception::push_imu(const ImuSample& sample) {
  if (const char* why = why_invalid(sample)) return drop_input("imu", why, imu_pushed_++, sample.t);
  ++imu_pushed_;
  if (!imu_.empty() && sample.t < imu_.back().t) {
    ++counters_.imu_out_of_order;
    return;
  }
  ++counters_.imu;
  imu_.push_back(sample);
  trim_history(imu_);
  advance_stream_time(sample.t);
  process_ready(false);
}

void Perception::push_odometry(const OdometrySample& sample) {
  if (const char* why = why_invalid(sample)) return drop_input("odometry", why, odometry_pushed_++, sample.t);
  ++odometry_pushed_;
  if (!odometry_.empty() && sample.t < odometry_.back().t) {
    ++counters_.odometry_out_of_order;
    return;
  }
  ++counters_.odometry;
  odometry_.push_back(sample);
  odometry_.back().q_W_B.normalize();
  trim_history(odometry_);
  advance_stream_time(sample.t);
  process_ready(false);
}

void Perception::push_depth(const DepthFrame& frame) {
  if (const char* why = why_invalid(frame)) return drop_input("depth", why, depth_pushed_++, frame.t);
  ++depth_pushed_;
  ++counters_.depth_frames;
  if (!registrar_) {
    warn_once("no depth camera", "depth frames given but the calibration has no depth camera: ignored");
    return;
  }
  DepthRegistrationResult r = registrar_->register_frame(frame);
  if (!r.ok()) {
    ++counters_.depth_rejected_registration;
    warn_once("depth rejected: " + r.rejected, "depth frame at t=" + std::to_string(frame.t) +
                                                   " ns rejected: " + r.rejected + " (further ones counted)");
    return;
  }
  recent_depth_.push_back(r.depth);
  while (recent_depth_.size() > 4) recent_depth_.pop_front();  // ~130 ms at 30 Hz
  pending_depth_.push_back(std::move(r.depth));
  advance_stream_time(frame.t);
  process_ready(false);
  // The translational compensation's per-frame work (~0.9 ms at 640x480) is done now, off the
  // path of the windows that will use this frame (those still pending, and the next ones).
  compensator_->prepare_depth_frame(recent_depth_.back());
}

void Perception::finish() {
  windower_.flush([this](const EventWindow& w) { enqueue(w); });
  process_ready(true);
  segment_pending_depth(std::numeric_limits<TimeNs>::max());  // frames after the last window: with predictions
}

bool Perception::window_ready(const PendingWindow& w, bool flush) const {
  if (flush || stream_time_ >= w.t_end + options_.max_lateness_ns) return true;
  const bool imu_caught_up = !imu_.empty() && imu_.back().t >= w.t_end;
  const bool odometry_caught_up = !odometry_.empty() && odometry_.back().t >= w.t_end;
  return imu_caught_up && odometry_caught_up;
}

void Perception::process_ready(bool flush) {
  while (!pending_windows_.empty() && window_ready(pending_windows_.front(), flush)) {
    PendingWindow& w = pending_windows_.front();
    process_window(w);
    processed_until_ = w.t_end;
    w.events.clear();
    free_buffers_.push_back(std::move(w.events));
    pending_windows_.pop_front();
    // Depth frames up to this window's end, now that the tracks cover their time; the rest wait
    // for the windows that do.
    segment_pending_depth(processed_until_);
  }
  // A frame that arrived after the windows covering its time: segment it now.
  segment_pending_depth(processed_until_);
}

std::optional<Eigen::Matrix3d> Perception::camera_turn(TimeNs from, TimeNs to) const {
  if (!options_.derotate_tracking || from == to || imu_.empty()) return std::nullopt;
  const auto R_I = imu_turn(imu_, from, to, options_.compensation.max_imu_gap_ns);
  if (!R_I) return std::nullopt;
  const Eigen::Matrix3d R_E_I = calibration_.R_E_I();
  return R_E_I * *R_I * R_E_I.transpose();
}

Eigen::Vector2d Perception::turned_pixel(const Eigen::Vector2d& px, const std::optional<Eigen::Matrix3d>& R_E) const {
  if (!R_E) return px;
  const Eigen::Vector2d xn = calibration_.event_camera.pixel_to_normalized(px);
  const Eigen::Vector3d ray = *R_E * Eigen::Vector3d(xn.x(), xn.y(), 1.0);
  if (!ray.allFinite() || ray.z() <= 1e-6) return px;  // turned behind the camera: nowhere better
  return calibration_.event_camera.project(ray);
}

std::optional<OdometrySample> Perception::vehicle_state(TimeNs t) const {
  if (!odometry_.empty()) return body_state_at(odometry_, t, options_.odometry_max_extrapolation_ns);
  if (!options_.assume_static_vehicle) return std::nullopt;
  OdometrySample s;
  s.t = t;
  return s;
}

std::optional<Eigen::Isometry3d> Perception::camera_pose(TimeNs t) const {
  const auto body = vehicle_state(t);
  if (!body) return std::nullopt;
  return body->T_W_B() * calibration_.T_B_E;
}

// The stages of one window (paper Fig. 2), each a named step below; the feedback edges from the
// tracks and the 3D estimates into the front end are named calls too.
void Perception::process_window(PendingWindow& w) {
  const auto start = Clock::now();
  WindowResult result;
  result.index = w.index;
  result.t_start = w.t_start;
  result.t_end = w.t_end;
  result.events = w.events.size();
  result.decimated = w.decimated;
  result.skipped_before = w.skipped_before;

  result.hot_pixel_events = drop_hot_pixels(w);
  // Between anchors with gates_only_between_anchors, only the events that can reach the gates'
  // surroundings are compensated.
  const TimeNs t_mid = w.t_start + (w.t_end - w.t_start) / 2;
  std::optional<std::span<const Eigen::AlignedBox2d>> near_gates;
  if (options_.gates_only_between_anchors && !is_anchor_window(w.index)) {
    detector_priors_from_tracks(t_mid, compensator_->method() == CompensationMethod::kNone ? t_mid : w.t_start);
    const PinholeCamera& camera = calibration_.event_camera;
    surround_gates(camera.width, camera.height);
    gate_regions_.clear();
    for (const cv::Rect& r : gate_surrounds_)
      gate_regions_.emplace_back(Eigen::Vector2d(r.x - 0.5, r.y - 0.5),
                                 Eigen::Vector2d(r.x + r.width - 0.5, r.y + r.height - 0.5));
    near_gates = gate_regions_;
  }
  const CompensatedWindow& cw = compensate(w, near_gates);
  result.compensation = cw.report;
  result.timings.compensation_ms = ms_since(start);

  // The detector searches the compensated grid, the camera at the window's start (the events
  // were warped there), or the raw image when nothing was warped.
  detector_priors_from_tracks(t_mid, cw.report.used == CompensationMethod::kNone ? t_mid : w.t_start);
  const DetectionResult det = detect(cw, w);
  result.status = det.status;
  result.theta = det.theta;
  result.timings.detection = det.timings;

  const auto tracking_start = Clock::now();
  const TrackerStep step = associate(w.t_end, det.detections);
  result.timings.tracking_ms = ms_since(tracking_start);
  for (int id : step.deleted) estimators_.erase(id);
  for (const TrackAssignment& a : step.assignments) result.detections.push_back({det.detections[a.detection], a.track_id});
  const std::vector<int> to_solve = add_event_observations(step, det.detections, w.index);
  segment_depth_since_first_detection(step.confirmed);
  for (int id : to_solve) estimate(id, w.t_end);

  result.timings.total_ms = ms_since(start);
  result.detector = &detector_;
  result.priors = priors_;
  counters_.count_window(result);
  if (callbacks_.on_window) callbacks_.on_window(result);
}

// Sensor noise: the events of pixels learned hot leave the window before any stage sees it
// (docs/DETECTION.md, "Hot pixels").
std::size_t Perception::drop_hot_pixels(PendingWindow& w) {
  return hot_pixels_ ? hot_pixels_->filter(w.events, w.index) : 0;
}

// Ego-motion compensation (paper §IV-A) with the IMU history, the vehicle state at the window's
// start and the newest registered depth frame not newer than the window's end.
const CompensatedWindow& Perception::compensate(const PendingWindow& w,
                                                std::optional<std::span<const Eigen::AlignedBox2d>> near_regions) {
  CompensationInput in;
  in.near_regions = near_regions;
  in.events = w.events;
  in.t_start = w.t_start;
  in.t_end = w.t_end;
  in.imu = imu_;
  in.odometry = vehicle_state(w.t_start);
  in.depth = nullptr;
  for (const RegisteredDepth& d : recent_depth_)
    if (d.t <= w.t_end) in.depth = &d;
  return compensator_->compensate(in);
}

bool dodge_decides_on(const TrajectoryEstimate& estimate, const DodgeOptions& dodge) {
  return estimate.usable ||
         (estimate.converged && estimate.covariance && estimate.horizon_sigma_m <= dodge.max_horizon_sigma_m);
}

bool lends_detector_gate(const Track& track, const PerceptionOptions& options) {
  return track.confirmed() || (options.tentative_track_priors && track.misses() == 0);
}

// Feedback, tracks -> detector: where the confirmed tracks, and the tentative ones detected in the
// last window, expect their objects at time t (the window's middle), for the detector's gate
// sources (docs/DETECTION.md), seen by the camera at grid_t; with trajectory_gates, a coasting track
// also where its 3D estimate expects it.
void Perception::detector_priors_from_tracks(TimeNs t, TimeNs grid_t) {
  priors_.clear();
  for (const Track& track : tracker_.tracks()) {
    if (!lends_detector_gate(track, options_)) continue;
    const TrackPrediction p = track.predict(t);
    if (options_.trajectory_gates && track.confirmed() && track.misses() > 0)
      if (const auto projected = trajectory_pixel(track.id(), t, grid_t))
        priors_.push_back({*projected, p.box_size_px, true, true});
    priors_.push_back({in_camera_at(p.center_px, grid_t), p.box_size_px, track.confirmed()});
  }
}

std::optional<Eigen::Vector2d> Perception::trajectory_pixel(int track_id, TimeNs t, TimeNs camera_t) const {
  const auto it = estimators_.find(track_id);
  if (it == estimators_.end()) return std::nullopt;
  const TrajectoryEstimate& est = it->second.fusion.latest();
  if (!est.converged || !est.usable || est.method != EstimateMethod::kFusion) return std::nullopt;
  const auto T_W_E = camera_pose(camera_t);
  if (!T_W_E) return std::nullopt;
  const Eigen::Vector3d p_E = T_W_E->inverse() * est.trajectory.position(t);
  if (!(p_E.z() > options_.estimation.min_depth_in_front_m)) return std::nullopt;
  const PinholeCamera& camera = calibration_.event_camera;
  const Eigen::Vector2d px = camera.project(p_E);
  if (!px.allFinite() || !camera.in_image(px)) return std::nullopt;
  return px;
}

// Detection (paper §IV-B). Feedback, detector -> compensator: the detector reports its centre
// through the compensator's inverse warp, in the camera at the detection's time, because
// add_event_observations pairs it with the camera's pose at that time.
DetectionResult Perception::detect(const CompensatedWindow& cw, const PendingWindow& w) {
  CompensatedEventsView view = detector_input(cw, *compensator_, options_.threads);
  view.new_evidence = is_anchor_window(w.index);
  const bool gates_only = options_.gates_only_between_anchors && !view.new_evidence;
  if (gates_only) {
    surround_gates(view.width, view.height);
    // The sources measure an object against the window's events in the sensor; compensated near
    // the gates only, the compensation gives their times.
    std::span<const float> window_t_s = cw.window_t_s();
    if (window_t_s.empty() && !gate_surrounds_.empty()) window_t_s = sensor_event_times(w);
    keep_events_near_gates(view, window_t_s);
  }
  DetectionResult det = detector_.detect(view, priors_);
  if (gates_only && gate_surrounds_.empty()) det.status = DetectionStatus::kNotSearched;
  return det;
}

// A gate's neighbourhood holds what the gate sources read around it: the count-contrast source's
// surround (3 centre boxes across) and the pattern's reach past the object's box.
void Perception::surround_gates(int width, int height) {
  gate_surrounds_.clear();
  for (const DetectionPrior& prior : priors_)
    if (const auto gate = detector_.prior_gate(prior)) {
      const double grow = std::max(gate->width(), gate->height());
      const cv::Rect r = box_pixels(Box2D{gate->x0 - grow, gate->y0 - grow, gate->x1 + grow, gate->y1 + grow}, width, height);
      if (r.area() > 0) gate_surrounds_.push_back(r);
    }
}

// Every event of the window in the sensor, before the warp moves some off the grid: the same as
// CompensatedWindow::window_t_s, whichever compensation ran.
std::span<const float> Perception::sensor_event_times(const PendingWindow& w) {
  const PinholeCamera& camera = calibration_.event_camera;
  sensor_t_s_.clear();
  for (const Event& e : w.events)
    if (e.x < camera.width && e.y < camera.height) sensor_t_s_.push_back(static_cast<float>(e.t - w.t_start) * 1e-9f);
  return sensor_t_s_;
}

void Perception::keep_events_near_gates(CompensatedEventsView& view, std::span<const float> window_t_s) {
  gated_pixel_.clear();
  gated_t_s_.clear();
  if (!gate_surrounds_.empty()) {
    // The rows the neighbourhoods span, as pixel indices: most events fall outside and cost no
    // division.
    std::int32_t first = std::numeric_limits<std::int32_t>::max(), last = -1;
    for (const cv::Rect& r : gate_surrounds_) {
      first = std::min(first, r.y * view.width);
      last = std::max(last, (r.y + r.height) * view.width - 1);
    }
    for (std::size_t i = 0; i < view.pixel.size(); ++i) {
      const std::int32_t p = view.pixel[i];
      if (p < first || p > last) continue;
      const cv::Point at(p % view.width, p / view.width);
      if (std::any_of(gate_surrounds_.begin(), gate_surrounds_.end(), [&](const cv::Rect& r) { return r.contains(at); })) {
        gated_pixel_.push_back(p);
        gated_t_s_.push_back(view.t_s[i]);
      }
    }
  }
  view.window_t_s = window_t_s;
  view.pixel = gated_pixel_;
  view.t_s = gated_t_s_;
}

// Association and Kalman filter on the image plane (paper §IV-C.1), with the 3D estimates' say.
TrackerStep Perception::associate(TimeNs t, std::span<const Detection2D> detections) {
  // The tracker's coordinates: the camera at the window's end (derotate_tracking).
  if (tracker_frame_t_ && *tracker_frame_t_ != t)
    if (const auto R_E = camera_turn(*tracker_frame_t_, t))
      tracker_.change_coordinates([&](const Eigen::Vector2d& px) { return turned_pixel(px, R_E); });
  tracker_frame_t_ = t;
  tracker_inputs_.clear();
  for (const Detection2D& d : detections) {
    const Eigen::Vector2d at_end = turned_pixel(d.center_raw, camera_turn(d.t, t));
    tracker_inputs_.push_back({d.t, at_end.allFinite() ? at_end : d.center_raw, d.center_normalized,
                               Eigen::Vector2d(d.box_raw.width(), d.box_raw.height()), d.events});
  }
  vouch_by_trajectory();
  hold_by_trajectory(t);
  return tracker_.update(t, tracker_inputs_, vouched_, held_);
}

// Feedback, estimator -> track lifetime: a confirmed track whose 3D trajectory still projects into
// the image is held past the tracker's gap (TrackerOptions::held_max_gap_ns), unless another track,
// detected in the last window, already follows its object there: that one is the object's track,
// and a held duplicate would only lend the detector gates beside it.
void Perception::hold_by_trajectory(TimeNs t) {
  held_.clear();
  if (options_.tracking.held_max_gap_ns <= 0) return;
  for (const Track& track : tracker_.tracks()) {
    if (!track.confirmed()) continue;
    const auto projected = trajectory_pixel(track.id(), t, t);
    if (!projected) continue;
    if (!followed_by_another(track, *projected, tracker_.tracks(), t, options_.detection.prior_min_gate_px))
      held_.push_back(track.id());
  }
}

bool followed_by_another(const Track& held, const Eigen::Vector2d& projected_px, std::span<const Track> tracks, TimeNs t,
                         double min_reach_px) {
  return std::any_of(tracks.begin(), tracks.end(), [&](const Track& other) {
    if (other.id() == held.id() || other.misses() > 0) return false;
    const double reach = std::max({held.box_size_px().maxCoeff(), other.box_size_px().maxCoeff(), min_reach_px});
    return (other.predict(t).center_px - projected_px).norm() < reach;
  });
}

// Feedback, estimator -> association gate: the 3D trajectory of a confirmed track vouches for the
// detections it predicts, so that a miss of the image-plane gate does not restart the track and
// its 3D history (PerceptionOptions::estimate_aided_association, docs/ESTIMATION.md §1).
void Perception::vouch_by_trajectory() {
  vouched_.clear();
  if (!options_.estimate_aided_association) return;
  for (const Track& track : tracker_.tracks()) {
    const auto it = estimators_.find(track.id());
    if (!track.confirmed() || it == estimators_.end()) continue;
    for (std::size_t i = 0; i < tracker_inputs_.size(); ++i)
      if (const auto m2 = trajectory_mahalanobis2(it->second.fusion.latest(), tracker_inputs_[i]))
        vouched_.push_back({track.id(), i, *m2});
  }
}

// The assigned detections as event observations of their tracks' estimators (paper §IV-C.3).
// Returns the tracks to solve: those confirmed in this step, and the confirmed ones that got a
// detection.
std::vector<int> Perception::add_event_observations(const TrackerStep& step, std::span<const Detection2D> detections,
                                                    std::uint64_t window_index) {
  std::vector<int> to_solve = step.confirmed;
  if (!options_.estimate_trajectories) return to_solve;
  // Overlapping windows: one detection per Δt is kept, the others stand only until the next one
  // (overlapping_window_options).
  const bool provisional = !is_anchor_window(window_index);
  // With gates_only_between_anchors the monocular baseline, a comparison rather than the
  // decisions' input (unless dodge_from says so), is solved at the anchors only.
  const bool mono_observes = !provisional || !options_.gates_only_between_anchors ||
                             options_.dodge_from == DodgeSource::kMonocular;
  for (const TrackAssignment& a : step.assignments) {
    if (a.track_id < 0) continue;
    const TrackerDetection& d = tracker_inputs_[a.detection];
    const auto T_W_E = camera_pose(d.t);
    if (!T_W_E) {
      warn_once("no pose", odometry_.empty() ? kNoOdometryWarning
                                             : "odometry does not cover a detection's time: its 3D observation skipped");
      continue;
    }
    EventObservation obs;
    obs.t = d.t;
    obs.xn = d.center_normalized;
    obs.T_W_E = *T_W_E;
    obs.provisional = provisional;
    if (const Detection2D& found = detections[a.detection]; found.partial)
      observe_cut_object(found, calibration_.event_camera,
                         options_.estimation.event_sigma_px / options_.estimation.event_focal_px, obs);
    else if (options_.estimation.event_size_noise > 0)
      obs.sigma_n = detection_sigma_n(options_.estimation, d.box_size_px.maxCoeff());
    TrackEstimators& e = estimators_for(a.track_id);
    // A cut object's box is the visible part's: its size is not the object's.
    if (const Detection2D& found = detections[a.detection]; !found.partial)
      e.looming.add(d.t, found.box_raw.width(), found.box_raw.height());
    e.fusion_new |= e.fusion.add(obs) == AddResult::kAccepted;
    if (e.mono && mono_observes) e.mono_new |= e.mono->add(obs) == AddResult::kAccepted;
    const Track* track = tracker_.find(a.track_id);
    if (track && track->confirmed() &&
        std::find(to_solve.begin(), to_solve.end(), a.track_id) == to_solve.end())
      to_solve.push_back(a.track_id);
  }
  return to_solve;
}

void observe_cut_object(const Detection2D& found, const PinholeCamera& camera, double sigma_n, EventObservation& obs) {
  if (found.center_full_raw) {
    const Eigen::Vector2d xn = camera.pixel_to_normalized(*found.center_full_raw);
    if (xn.allFinite()) obs.xn = xn;
  }
  obs.sigma_n = sigma_n / std::clamp(found.visible_fraction, 0.1, 1.0);
}

// Tracks confirmed now missed the depth frames segmented while they were tentative: those since
// their first detection are still in recent_depth_. The frames still pending (newer than the
// windows done, or stuck behind a newer frame that arrived first) are segmented after this window
// for every confirmed track, this one included: not here, or the track would get them twice.
void Perception::segment_depth_since_first_detection(std::span<const int> confirmed) {
  if (!options_.depth_since_first_detection) return;
  for (int id : confirmed)
    if (const Track* track = tracker_.find(id))
      for (const RegisteredDepth& d : recent_depth_) {
        const bool pending = std::any_of(pending_depth_.begin(), pending_depth_.end(),
                                         [&](const RegisteredDepth& p) { return p.t == d.t; });
        if (d.t >= track->first_time() - options_.depth_before_first_detection_ns && !pending) segment_depth(d, *track);
      }
}

Perception::TrackEstimators& Perception::estimators_for(int track_id) {
  auto it = estimators_.find(track_id);
  if (it == estimators_.end()) {
    TrackEstimators e{TrajectoryEstimator(options_.estimation), std::nullopt, LoomingFit(options_.looming)};
    if (options_.monocular_baseline) {
      EstimatorOptions mono = options_.estimation;
      mono.mode = EstimatorMode::kMonocular;
      e.mono.emplace(mono);
    }
    it = estimators_.emplace(track_id, std::move(e)).first;
  }
  return it->second;
}

std::optional<double> Perception::trajectory_mahalanobis2(const TrajectoryEstimate& est,
                                                         const TrackerDetection& d) const {
  if (!est.converged || !est.usable || est.method != EstimateMethod::kFusion) return std::nullopt;
  const auto T_W_E = camera_pose(d.t);
  if (!T_W_E) return std::nullopt;
  return est.observation_mahalanobis2(d.t, *T_W_E, d.center_normalized,
                                      detection_sigma_n(options_.estimation, d.box_size_px.maxCoeff()));
}

void Perception::segment_pending_depth(TimeNs up_to) {
  while (!pending_depth_.empty() && pending_depth_.front().t <= up_to) {
    const RegisteredDepth& depth = pending_depth_.front();
    for (const Track& track : tracker_.tracks())
      if (track.confirmed() && segment_depth(depth, track)) estimate(track.id(), depth.t);
    pending_depth_.pop_front();
  }
}

bool Perception::segment_depth(const RegisteredDepth& depth, const Track& track) {
  const auto start = Clock::now();
  const TrackPrediction p = track.predict(depth.t);
  DepthQuery query;
  query.center_px = in_camera_at(p.center_px, depth.t);
  query.box_size_px = p.box_size_px;
  const auto T_W_E = camera_pose(depth.t);
  if (T_W_E)
    if (const auto expected = expected_depth_from_estimate(track.id(), depth.t, *T_W_E)) {
      query.expected_depth_m = expected->depth_m;
      query.expected_depth_sigma_m = expected->sigma_m;
    }
  DepthResult r;
  r.t = depth.t;
  r.track_id = track.id();
  TrackEstimators& e = estimators_for(track.id());
  DepthSegmentationOptions segmentation = options_.depth_segmentation;
  if (e.radius_conflict) segmentation.object_radius_m = 0;
  r.segmentation = segment_object_depth(depth_view(depth), calibration_.event_camera, query, segmentation);
  r.ms = ms_since(start);
  if (callbacks_.on_depth) callbacks_.on_depth(r);
  note_radius_conflict(e, track.id(), r.segmentation);
  if (!r.segmentation.observation || !T_W_E) return false;
  ++counters_.depth_observations;
  if (!options_.estimate_trajectories) return false;
  const DepthObservation& o = *r.segmentation.observation;
  const bool accepted = e.fusion.add(DepthMeasurement{o.t, o.depth_m, o.sigma_m, *T_W_E}) == AddResult::kAccepted;
  e.fusion_new |= accepted;
  return accepted;
}

// A wrong known radius makes the size gate reject the object's every depth frame: the estimate
// would go on without depth, trusting the radius over the depth camera. After
// kRadiusConflictFrames rejections in a row, the track's depth is segmented without the radius.
void Perception::note_radius_conflict(TrackEstimators& e, int track_id, const DepthSegmentation& s) {
  if (s.observation) e.size_rejections_in_a_row = 0;
  if (s.rejection != DepthRejection::kSizeInconsistent || e.radius_conflict) return;
  if (++e.size_rejections_in_a_row < kRadiusConflictFrames) return;
  e.radius_conflict = true;
  warn_once("object radius conflicts with depth",
            fmt::format("depth_segmentation.object_radius_m = {} m conflicts with the depth camera: {} depth frames "
                        "of track {} in a row rejected ({}); its depth is used without the radius from now on "
                        "(its estimates are flagged radius_conflict)",
                        options_.depth_segmentation.object_radius_m, kRadiusConflictFrames, track_id, s.reason));
}

// Feedback, estimator -> depth segmentation: the track's trajectory sets the expected depth of
// the segmentation's gate (docs/ESTIMATION.md §2, gate 5), only when that trajectory was itself
// fitted to depth: an event-only fit knows the range only through gravity's curvature, and its
// (linearised) covariance can be confidently wrong; gating on it locked the true depth out (swing).
std::optional<Perception::ExpectedDepth> Perception::expected_depth_from_estimate(
    int track_id, TimeNs t, const Eigen::Isometry3d& T_W_E) const {
  const auto it = estimators_.find(track_id);
  if (it == estimators_.end()) return std::nullopt;
  const TrajectoryEstimate& est = it->second.fusion.latest();
  if (!est.usable || est.method != EstimateMethod::kFusion) return std::nullopt;
  const Eigen::Vector3d p_E = T_W_E.inverse() * est.trajectory.position(t);
  ExpectedDepth expected{p_E.z(), 0.0};
  if (const auto cov = est.position_covariance(t)) {
    const Eigen::Vector3d axis_W = T_W_E.linear().col(2);
    expected.sigma_m = std::sqrt(std::max(0.0, axis_W.dot(*cov * axis_W)));
  }
  return expected;
}

void Perception::estimate(int track_id, TimeNs t) {
  if (!options_.estimate_trajectories) return;
  TrackEstimators& e = estimators_for(track_id);
  // Solved only with a new observation; emitted only with a fit (not while it waits for the
  // minimum number of observations).
  auto solve_and_emit = [&](TrajectoryEstimator& estimator, EstimatorMode mode, bool& is_new) -> const TrajectoryEstimate* {
    if (!is_new) return nullptr;
    is_new = false;
    const auto start = Clock::now();
    const TrajectoryEstimate& est = estimator.solve();
    if (est.method == EstimateMethod::kNone) return nullptr;
    ++counters_.estimates;
    if (callbacks_.on_estimate)
      callbacks_.on_estimate({t, track_id, mode, &est, ms_since(start), e.looming.at(t), e.radius_conflict});
    return &est;
  };
  const TrajectoryEstimate* fused = solve_and_emit(e.fusion, EstimatorMode::kFusion, e.fusion_new);
  const TrajectoryEstimate* mono = e.mono ? solve_and_emit(*e.mono, EstimatorMode::kMonocular, e.mono_new) : nullptr;
  // The prediction's risk against the vehicle at t, assessed once: the planner takes it when it
  // decides on the fusion estimate at t.
  const auto vehicle = fused && fused->usable && callbacks_.on_prediction ? vehicle_state(t) : std::nullopt;
  std::optional<RiskAssessment> fused_risk;
  if (vehicle)
    fused_risk = assess_collision_risk(*fused, {*vehicle, vehicle_state_covariance(options_.prediction)}, options_.prediction);
  const TrajectoryEstimate* dodge_on = options_.dodge_from == DodgeSource::kMonocular ? mono : fused;
  if (dodge_on && dodge_decides_on(*dodge_on, options_.dodge))
    decide_dodge(track_id, *dodge_on, t, dodge_on == fused && fused_risk ? &*fused_risk : nullptr);
  if (fused && fused->method == EstimateMethod::kEventOnly && counters_.depth_frames == 0)
    warn_once("no depth", "no depth frames: 3D estimates are event-only, their range observable only through "
                          "gravity (docs/ESTIMATION.md)");
  if (!vehicle) return;
  if (fused_risk->risk)  // its nominal is predict_collision's
    callbacks_.on_prediction({t, track_id, fused_risk->risk->nominal, fused_risk->risk->miss_distance_sigma_m});
  else
    callbacks_.on_prediction({t, track_id, predict_collision(fused->trajectory, *vehicle, options_.prediction), {}});
}

// The dodge (docs/AVOIDANCE.md): the risk of the new estimate against the vehicle's state at the
// time the result exists (a window's estimate exists at the window's end; a depth frame's once the
// windows up to it are processed), then the planner. A refusal is reported once per track and reason.
void Perception::decide_dodge(int track_id, const TrajectoryEstimate& estimate, TimeNs t,
                              const RiskAssessment* assessed_at_t) {
  if (!planner_) return;
  const TimeNs now = std::max(t, processed_until_);
  const auto odometry = vehicle_state(now);
  if (!odometry) return;
  VehicleState vehicle{*odometry, vehicle_state_covariance(options_.prediction)};
  RiskAssessment assessed;
  if (options_.dodge_from == DodgeSource::kFusionPointEstimate) {
    TrajectoryEstimate point = estimate;
    point.covariance = Eigen::Matrix<double, 6, 6>::Zero();
    vehicle.covariance.setZero();
    assessed = assess_collision_risk(point, vehicle, options_.prediction);
  } else if (assessed_at_t && now == t) {
    assessed = *assessed_at_t;
  } else {
    assessed = assess_collision_risk(estimate, vehicle, options_.prediction);
  }
  std::optional<DodgeDecision> decision;
  if (assessed.risk) {
    decision = planner_->update(track_id, *assessed.risk, vehicle);
  } else if (refused_[track_id] != assessed.reason) {
    refused_[track_id] = assessed.reason;
    decision.emplace();
    decision->t = decision->effective_t = now;
    decision->track_id = track_id;
    decision->action = DodgeAction::kRefused;
    decision->reason = assessed.reason;
  }
  if (!decision) return;
  ++counters_.dodge_decisions;
  if (callbacks_.on_dodge) callbacks_.on_dodge(*decision);
}

}  // namespace fdv
