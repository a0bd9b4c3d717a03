#include "fdv/detection/detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>

#include "fdv/core/error.h"

namespace fdv {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// A remaining track gate that no found object's box overlaps: another object is predicted there,
/// so neither the blanking nor the duplicate test around a nearby found object covers it.
bool free_gate(const Box2D& gate, std::span<const Detection2D> found) {
  return std::none_of(found.begin(), found.end(),
                      [&](const Detection2D& d) { return gate.intersects(d.box_undistorted); });
}

void validate_or_throw(const DetectorOptions& o) {
  if (const auto why = o.validate(); !why.empty()) throw ConfigError("detector: " + why);
}

}  // namespace

std::string_view to_string(DetectionSource s) {
  switch (s) {
    case DetectionSource::kGaussianFit: return "gaussian_fit";
    case DetectionSource::kRegionRetrieval: return "region_retrieval";
    case DetectionSource::kDenseMotion: return "dense_motion";
    case DetectionSource::kCountContrast: return "count_contrast";
    case DetectionSource::kEvidence: return "evidence";
  }
  return "?";
}

std::string_view to_string(DetectionStatus s) {
  switch (s) {
    case DetectionStatus::kDetected: return "detected";
    case DetectionStatus::kTooFewEvents: return "too few events";
    case DetectionStatus::kNoTemporalContrast: return "no temporal contrast";
    case DetectionStatus::kNothingSegmented: return "nothing above threshold";
    case DetectionStatus::kFlooded: return "segmentation flooded";
    case DetectionStatus::kRemovedAsNoise: return "removed as noise";
    case DetectionStatus::kNoRegion: return "no plausible region";
    case DetectionStatus::kTooFewEventsInBox: return "too few events in box";
    case DetectionStatus::kWeakEvidence: return "weak evidence";
    case DetectionStatus::kFillsView: return "object fills the view";
    case DetectionStatus::kNotSearched: return "not searched";
  }
  return "?";
}

std::string DetectorOptions::validate() const {
  std::ostringstream why;
  auto odd_positive = [](int k) { return k >= 1 && k % 2 == 1 && k <= 31; };
  const double coeffs[] = {threshold_a_s_per_rad, threshold_b_s_per_m, threshold_c, fit_delta_center_px,
                           fit_delta_size_px, fit_delta_fraction, fit_min_size_px, roi_max_aspect,
                           max_segmented_fraction, fills_view_fraction, refine_box_scale, refine_grow_density,
                           refine_grow_contrast, min_event_density, gate_focal_px, prior_gate_scale, prior_min_gate_px};
  for (double v : coeffs)
    if (!std::isfinite(v)) return "non-finite detector parameter";
  // θ = mean(N) + a‖ω‖ + b‖v‖ + c on N in [0, 1]: the motion terms raise it, c shifts it within N's range.
  if (!(threshold_a_s_per_rad >= 0)) why << "threshold_a_s_per_rad (a) must be >= 0, got " << threshold_a_s_per_rad;
  else if (!(threshold_b_s_per_m >= 0)) why << "threshold_b_s_per_m (b) must be >= 0, got " << threshold_b_s_per_m;
  else if (!(threshold_c >= -1 && threshold_c <= 1)) why << "threshold_c (c) must be in [-1, 1], got " << threshold_c;
  else if (!odd_positive(mean_filter_px)) why << "mean_filter_px must be odd in [1, 31], got " << mean_filter_px;
  else if (!odd_positive(opening_px)) why << "opening_px must be odd in [1, 31], got " << opening_px;
  else if (fit_max_iterations < 1) why << "fit_max_iterations (K) must be positive, got " << fit_max_iterations;
  else if (!(fit_delta_center_px > 0)) why << "fit_delta_center_px (δ_C) must be positive, got " << fit_delta_center_px;
  else if (!(fit_delta_size_px > 0)) why << "fit_delta_size_px (δ_L) must be positive, got " << fit_delta_size_px;
  else if (!(fit_delta_fraction >= 0 && fit_delta_fraction <= 0.1))
    why << "fit_delta_fraction must be in [0, 0.1], got " << fit_delta_fraction;
  else if (max_objects < 1 || max_objects > 16) why << "max_objects must be in [1, 16], got " << max_objects;
  else if (!(fills_view_fraction > 0 && fills_view_fraction <= 1))
    why << "fills_view_fraction must be in (0, 1], got " << fills_view_fraction;
  else if (!(fit_min_size_px >= 1)) why << "fit_min_size_px must be at least 1, got " << fit_min_size_px;
  else if (!(prior_gate_scale > 0)) why << "prior_gate_scale must be positive, got " << prior_gate_scale;
  else if (!(prior_min_gate_px >= 0)) why << "prior_min_gate_px must be >= 0, got " << prior_min_gate_px;
  else if (!(min_event_density >= 0)) why << "min_event_density must be >= 0, got " << min_event_density;
  else if (!(gate_focal_px == 0 || (gate_focal_px >= 10 && gate_focal_px <= 1e5)))
    why << "gate_focal_px must be 0 (off) or in [10, 1e5], got " << gate_focal_px;
  else if (min_pixel_events < 1 || min_pixel_events > 1000)
    why << "min_pixel_events must be in [1, 1000], got " << min_pixel_events;
  else if (!(roi_max_aspect >= 1)) why << "roi_max_aspect must be at least 1, got " << roi_max_aspect;
  else if (roi_min_events < 1) why << "roi_min_events must be positive, got " << roi_min_events;
  else if (region_min_area_px < 1) why << "region_min_area_px must be positive, got " << region_min_area_px;
  else if (!(refine_box_scale == 0 || (refine_box_scale >= 1 && refine_box_scale <= 10)))
    why << "refine_box_scale must be 0 (off) or in [1, 10], got " << refine_box_scale;
  else if (!(refine_grow_density >= 0 && refine_grow_density <= 1))
    why << "refine_grow_density must be in [0, 1], got " << refine_grow_density;
  else if (!(refine_grow_contrast >= 0)) why << "refine_grow_contrast must be >= 0, got " << refine_grow_contrast;
  else if (refine_recenter_passes < 0 || refine_recenter_passes > 20)
    why << "refine_recenter_passes must be in [0, 20], got " << refine_recenter_passes;
  else if (min_window_events < 1) why << "min_window_events must be positive, got " << min_window_events;
  else if (!(max_segmented_fraction > 0 && max_segmented_fraction <= 1))
    why << "max_segmented_fraction must be in (0, 1], got " << max_segmented_fraction;
  if (!why.str().empty()) return why.str();
  for (std::string source_why :
       {hot_pixels.validate(), gaussian_fit.validate(), track_aided.validate(), dense_motion.validate(),
        count_contrast.validate(), evidence.validate()})
    if (!source_why.empty()) return source_why;
  return {};
}

DetectorOptions scaled_to_camera(const DetectorOptions& options, const PinholeCamera& camera) {
  DetectorOptions o = options;
  if (o.gate_focal_px == 0 || !(camera.fx > 0)) return o;
  // Down only: at a longer focal length the same scaling traded recall for fewer false detections
  // (docs/DETECTION.md, "Tuning").
  const double scale = std::min(1.0, camera.fx / o.gate_focal_px);
  o.min_event_density *= scale;
  const int k = static_cast<int>(std::lround(o.count_contrast.box_px * scale));
  o.count_contrast.box_px = std::clamp(k % 2 == 1 ? k : k + 1, 3, 31);
  // Up only: the evidence grid's cells grow with the same ball's image at a longer focal length
  // (finer cells there only gave texture more paths); smaller cells than 8 px split a far ball.
  const double up = std::max(1.0, camera.fx / o.gate_focal_px);
  o.evidence.cell_px = std::clamp(static_cast<int>(std::lround(o.evidence.cell_px * up)), 2, 64);
  return o;
}

Detector::Detector(const DetectorOptions& options, const PinholeCamera& event_camera)
    : options_(scaled_to_camera((validate_or_throw(options), options), event_camera)),
      camera_(event_camera),
      pre_(options_),
      refiner_(options_) {
  if (const auto why = event_camera.validate(); !why.empty()) throw ConfigError("detector: event camera: " + why);
  for (const RegisteredSource& registered : registered_sources())
    if (std::unique_ptr<CandidateSource> source = registered.make(options_))
      sources_.push_back({registered.name, std::move(source)});
  allocate(camera_.width, camera_.height);
  gates_.reserve(8);
  tentative_gates_.reserve(8);
}

void Detector::allocate(int width, int height) {
  S_.create(height, width, CV_32F);
  S_.setTo(0);
  S_nonzero_ = {};
  rest_.create(height, width, CV_32F);
  rest_.setTo(0);
  rest_bounds_ = {};
  pre_.allocate({width, height});
  region_.reserve(width, height);
  for (const Source& s : sources_) s.source->allocate(width, height);
  refiner_.allocate(width, height);
  prepare_time_images(ti_, width, height);
}

Eigen::Vector2d Detector::undistorted_to_raw(const Eigen::Vector2d& uv) const {
  return camera_.normalized_to_pixel({(uv.x() - camera_.cx) / camera_.fx, (uv.y() - camera_.cy) / camera_.fy});
}

Box2D Detector::undistorted_box_to_raw(const Box2D& b) const {
  // The lens map bends straight edges: take the bounding box of the mapped outline.
  constexpr int kSteps = 8;
  Box2D out{1e300, 1e300, -1e300, -1e300};
  for (int i = 0; i <= kSteps; ++i) {
    const double s = static_cast<double>(i) / kSteps;
    const double x = b.x0 + s * (b.x1 - b.x0), y = b.y0 + s * (b.y1 - b.y0);
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(x, b.y0), Eigen::Vector2d(x, b.y1), Eigen::Vector2d(b.x0, y),
                                     Eigen::Vector2d(b.x1, y)}) {
      const Eigen::Vector2d r = undistorted_to_raw(p);
      out.x0 = std::min(out.x0, r.x());
      out.y0 = std::min(out.y0, r.y());
      out.x1 = std::max(out.x1, r.x());
      out.y1 = std::max(out.y1, r.y());
    }
  }
  return out;
}

std::optional<Box2D> Detector::prior_gate(const DetectionPrior& prior) const {
  const Eigen::Vector2d xn = camera_.pixel_to_normalized(prior.center_raw);
  if (!xn.allFinite()) return std::nullopt;
  const Eigen::Vector2d c(camera_.fx * xn.x() + camera_.cx, camera_.fy * xn.y() + camera_.cy);
  const double half_w = std::max(0.5 * options_.prior_gate_scale * prior.box_size_px.x(), options_.prior_min_gate_px);
  const double half_h = std::max(0.5 * options_.prior_gate_scale * prior.box_size_px.y(), options_.prior_min_gate_px);
  return Box2D{c.x() - half_w, c.y() - half_h, c.x() + half_w, c.y() + half_h};
}

DetectionResult Detector::detect(const CompensatedEventsView& window, std::span<const DetectionPrior> priors) {
  using Clock = std::chrono::steady_clock;
  const auto t_total = Clock::now();
  DetectionResult res;
  const DetectorOptions& o = options_;
  const int w = window.width, h = window.height;
  auto finish = [&](DetectionStatus s) {
    if (s != DetectionStatus::kDetected && s != DetectionStatus::kNoRegion &&
        s != DetectionStatus::kTooFewEventsInBox && s != DetectionStatus::kRemovedAsNoise &&
        s != DetectionStatus::kWeakEvidence && s != DetectionStatus::kFillsView)
      pre_.clear();  // no stale image from an earlier window
    res.status = s;
    res.timings.total_ms = ms_since(t_total);
    return std::move(res);  // not a copy: the list of detections would be allocated twice
  };

  auto t = Clock::now();
  build_time_images(window, ti_);
  res.timings.time_images_ms = ms_since(t);
  res.mean_normalized = ti_.mean_normalized;
  if (S_.rows != h || S_.cols != w) allocate(w, h);
  if (ti_.events < o.min_window_events) {
    // A run of near-empty windows (a sparse stream, a gap's reported windows) blanks it once.
    zero_rect(S_, S_nonzero_);
    S_nonzero_ = {};
    return finish(DetectionStatus::kTooFewEvents);
  }

  t = Clock::now();
  res.theta = adaptive_threshold(ti_.mean_normalized, window.omega_rad_s, window.speed_m_s, o);
  const SegmentResult seg =
      segment(ti_, res.theta, o.min_pixel_events, S_, window.threads, S_nonzero_);
  S_nonzero_ = seg.bounds;
  res.segmented_pixels = seg.pixels;
  res.timings.segmentation_ms = ms_since(t);
  if (!(ti_.t_max_s > ti_.t_min_s)) return finish(DetectionStatus::kNoTemporalContrast);
  if (res.segmented_pixels > o.max_segmented_fraction * w * h) return finish(DetectionStatus::kFlooded);

  t = Clock::now();
  const cv::Mat& P = pre_.run(S_, seg.bounds, window.threads);
  res.timings.preprocess_ms = ms_since(t);
  gates_.clear();
  tentative_gates_.clear();
  for (const DetectionPrior& prior : priors)
    if (const auto gate = prior_gate(prior)) (prior.confirmed ? gates_ : tentative_gates_).push_back(*gate);
  const cv::Rect support = pre_.nonzero_bounds();
  const cv::Mat* image = &P;  // P, then P with the objects found so far blanked
  MaxLocation image_max = pre_.first_max();
  DetectionStatus why_not = DetectionStatus::kRemovedAsNoise;
  bool fills_view = false;
  // One object per pass: the first source whose candidate passes its gates wins; its region is
  // then blanked, and the search goes on for the next object (docs/DETECTION.md, "Several objects").
  for (int pass = 0; pass < o.max_objects; ++pass) {
    SourceWindow in{.events = window,
                    .ti = ti_,
                    .S = S_,
                    .P = *image,
                    .P_support = support,
                    .P_max = image_max,
                    .theta = res.theta,
                    .window_s = to_seconds(window.t_end - window.t_start),
                    .gates = gates_,
                    .tentative_gates = tentative_gates_,
                    .region_scratch = region_,
                    .first_object = pass == 0,
                    .why_not = res.segmented_pixels == 0 ? DetectionStatus::kNothingSegmented
                                                         : DetectionStatus::kRemovedAsNoise};
    // The diagnostics are the first object's; a later pass adds its candidates and times.
    DetectionResult later;
    DetectionResult& out = pass == 0 ? res : later;
    if (pass == 0) begin_window(in, res);
    const std::optional<Candidate> found = find_candidate(in, out);
    std::optional<Detection2D> d;
    if (found && !already_found(res.detections, found->center)) d = to_detection(window, *found, out);
    if (pass == 0) why_not = in.fills_view ? DetectionStatus::kFillsView : in.why_not;
    else add_later_pass(later, res);
    if (!d) break;
    if (std::max(d->box_raw.width(), d->box_raw.height()) > o.fills_view_fraction * std::min(w, h)) {
      fills_view = true;
      break;
    }
    if (image == &P) {  // only P's support is copied; rest_ is kept 0 elsewhere
      zero_rect(rest_, rest_bounds_);
      if (support.area() > 0) P(support).copyTo(rest_(support));
      rest_bounds_ = support;
      image = &rest_;
    }
    if (res.detections.empty()) res.detections.reserve(o.max_objects);  // the result's one allocation
    res.detections.push_back(*d);
    // A track whose gate holds this object has its detection: the later passes skip its gate.
    auto holds_it = [&](const Box2D& gate) { return gate.contains(d->center_undistorted); };
    std::erase_if(gates_, holds_it);
    std::erase_if(tentative_gates_, holds_it);
    const cv::Rect blanked = box_pixels(blanked_region(d->box_undistorted), w, h);
    zero_rect(rest_, blanked);
    for (const Box2D& gate : gates_)
      if (free_gate(gate, res.detections)) {
        const cv::Rect spared = box_pixels(gate, w, h) & blanked & support;
        if (spared.area() > 0) P(spared).copyTo(rest_(spared));
      }
    image_max = first_maximum(rest_, support);
  }
  if (!res.detections.empty()) return finish(DetectionStatus::kDetected);
  return finish(fills_view ? DetectionStatus::kFillsView : why_not);
}

void Detector::begin_window(const SourceWindow& in, DetectionResult& res) {
  for (const Source& s : sources_) {
    const auto t = std::chrono::steady_clock::now();
    if (s.source->begin_window(in)) res.timings.add_source_ms(s.name, ms_since(t));
  }
}

std::optional<Candidate> Detector::find_candidate(SourceWindow& in, DetectionResult& res) {
  for (const Source& s : sources_) {
    const auto t = std::chrono::steady_clock::now();
    std::optional<Candidate> found = s.source->find(in, res);
    res.timings.add_source_ms(s.name, ms_since(t));
    if (found) return found;
  }
  return std::nullopt;
}

void Detector::add_later_pass(const DetectionResult& later, DetectionResult& res) {
  res.candidates += later.candidates;
  res.timings.refine_ms += later.timings.refine_ms;
  for (const SourceTime& s : later.timings.sources()) res.timings.add_source_ms(s.source, s.ms);
}

Box2D Detector::blanked_region(const Box2D& box) const {
  // The pattern of P reaches beyond the object's box: the filters' reach, and the sweep of a fast
  // object, which trails it by up to about its own size within a window.
  const double grow = std::max(box.width(), box.height()) + 0.5 * (options_.mean_filter_px + options_.opening_px);
  return {box.x0 - grow, box.y0 - grow, box.x1 + grow, box.y1 + grow};
}

bool Detector::already_found(std::span<const Detection2D> found, const Eigen::Vector2d& center) const {
  if (std::any_of(gates_.begin(), gates_.end(),
                  [&](const Box2D& gate) { return gate.contains(center) && free_gate(gate, found); }))
    return false;
  return std::any_of(found.begin(), found.end(),
                     [&](const Detection2D& d) { return blanked_region(d.box_undistorted).contains(center); });
}

Detection2D Detector::to_detection(const CompensatedEventsView& window, const Candidate& found, DetectionResult& res) {
  const DetectorOptions& o = options_;
  Box2D box = found.box;
  Eigen::Vector2d center = found.center;
  double t_mean_s = found.t_mean_s;
  const int events = found.events;
  if (o.refine_box_scale > 0) {
    const auto t = std::chrono::steady_clock::now();
    if (const auto refined = refiner_.refine(window, box, t_mean_s)) {
      const bool grown = refined->extent_px > std::max(box.width(), box.height());  // past a fragment
      box = box.moved_by(refined->center - center);
      center = refined->center;
      if (grown) {
        const double half = 0.5 * refined->extent_px;
        box = Box2D{center.x() - half, center.y() - half, center.x() + half, center.y() + half};
      }
      t_mean_s = refined->t_mean_s;
    }
    res.timings.refine_ms = ms_since(t);
  }
  if (o.square_box) {
    const double half = 0.5 * std::max(box.width(), box.height());
    box = Box2D{center.x() - half, center.y() - half, center.x() + half, center.y() + half};
  }
  Detection2D d;
  d.t = window.t_start + from_seconds(t_mean_s);
  d.box_undistorted = box;
  d.center_undistorted = center;
  // Seen by the camera at the detection's time (the events were warped to the window's start).
  const Eigen::Vector2d seen = window.observed_at ? window.observed_at(center, t_mean_s) : center;
  d.center_normalized = {(seen.x() - camera_.cx) / camera_.fx, (seen.y() - camera_.cy) / camera_.fy};
  d.center_raw = undistorted_to_raw(seen);
  d.box_raw = undistorted_box_to_raw(box.moved_by(seen - center));
  // Cut by the border: the square is centred on the visible events' centroid, its side the
  // object's extent across the motion (border_cut.h).
  if (const auto cut = border_cut(d.box_raw)) {
    d.partial = true;
    d.visible_fraction = cut->visible_fraction;
    d.center_full_raw = cut->center_full;
    d.box_raw = cut->visible;
  }
  d.events = events;
  d.score = found.score;
  d.event_density = found.event_density;
  d.source = found.source;
  d.fit_iterations = found.fit_iterations;
  d.track_aided = res.track_aided;
  return d;
}

}  // namespace fdv
