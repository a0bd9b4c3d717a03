#include "fdv/detection/detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/detection/segmentation.h"

namespace fdv {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace

std::string_view to_string(DetectionSource s) {
  return s == DetectionSource::kGaussianFit ? "gaussian_fit" : "region_retrieval";
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
  }
  return "?";
}

std::string DetectorOptions::validate() const {
  std::ostringstream why;
  auto odd_positive = [](int k) { return k >= 1 && k % 2 == 1 && k <= 31; };
  const double coeffs[] = {threshold_a_s_per_rad, threshold_b_s_per_m, threshold_c, fit_delta_center_px,
                           fit_delta_size_px, fit_min_size_px, roi_max_fraction, roi_max_aspect, max_segmented_fraction,
                           refine_box_scale, min_peak};
  for (double v : coeffs)
    if (!std::isfinite(v)) return "non-finite detector parameter";
  if (!odd_positive(mean_filter_px)) why << "mean_filter_px must be odd in [1, 31], got " << mean_filter_px;
  else if (!odd_positive(opening_px)) why << "opening_px must be odd in [1, 31], got " << opening_px;
  else if (fit_max_iterations < 1) why << "fit_max_iterations (K) must be positive, got " << fit_max_iterations;
  else if (!(fit_delta_center_px > 0)) why << "fit_delta_center_px (δ_C) must be positive, got " << fit_delta_center_px;
  else if (!(fit_delta_size_px > 0)) why << "fit_delta_size_px (δ_L) must be positive, got " << fit_delta_size_px;
  else if (!(fit_min_size_px >= 1)) why << "fit_min_size_px must be at least 1, got " << fit_min_size_px;
  else if (!(min_peak >= 0 && min_peak <= 1)) why << "min_peak must be in [0, 1], got " << min_peak;
  else if (!(roi_max_fraction > 0 && roi_max_fraction <= 1)) why << "roi_max_fraction must be in (0, 1], got " << roi_max_fraction;
  else if (!(roi_max_aspect >= 1)) why << "roi_max_aspect must be at least 1, got " << roi_max_aspect;
  else if (roi_min_events < 1) why << "roi_min_events must be positive, got " << roi_min_events;
  else if (region_min_area_px < 1) why << "region_min_area_px must be positive, got " << region_min_area_px;
  else if (!(refine_box_scale == 0 || (refine_box_scale >= 1 && refine_box_scale <= 10)))
    why << "refine_box_scale must be 0 (off) or in [1, 10], got " << refine_box_scale;
  else if (min_window_events < 1) why << "min_window_events must be positive, got " << min_window_events;
  else if (!(max_segmented_fraction > 0 && max_segmented_fraction <= 1))
    why << "max_segmented_fraction must be in (0, 1], got " << max_segmented_fraction;
  return why.str();
}

Detector::Detector(const DetectorOptions& options, const PinholeCamera& event_camera)
    : options_(options), camera_(event_camera) {
  if (const auto why = options.validate(); !why.empty()) throw ConfigError("detector: " + why);
  if (const auto why = event_camera.validate(); !why.empty()) throw ConfigError("detector: event camera: " + why);
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

std::optional<std::pair<Eigen::Vector2d, double>> Detector::refine_with_events(const CompensatedEventsView& window,
                                                                              const Box2D& box, double t_box_s) const {
  // A time slice symmetric about the box's mean event time, as wide as the window allows, and a
  // region large enough to hold the object throughout that slice: the object's events in it are
  // then complete, and their centroid is the object's position at their mean time (exact for
  // constant image velocity and a time-uniform event rate).
  const double duration_s = to_seconds(window.t_end_ns - window.t_start_ns);
  const double tau = std::min(t_box_s, duration_s - t_box_s);
  if (!(tau > 0)) return std::nullopt;
  const float t_lo = static_cast<float>(t_box_s - tau), t_hi = static_cast<float>(t_box_s + tau);
  const Eigen::Vector2d c = box.center();
  // Square: the segmented sweep can be a thin crescent across the motion, while the object
  // extends along it as well.
  const double half = 0.5 * options_.refine_box_scale * std::max(box.width(), box.height());
  const cv::Rect e = box_pixels({c.x() - half, c.y() - half, c.x() + half, c.y() + half}, window.width, window.height);
  if (e.area() == 0) return std::nullopt;
  const std::int32_t w = window.width;
  const std::int32_t first_row = e.y * w, end_row = (e.y + e.height) * w;
  double sx = 0, sy = 0, st = 0;
  int n = 0;
  // Time-ordered windows (the compensators keep the input's order): only the slice is scanned.
  std::size_t begin = 0, end = std::min(window.pixel.size(), window.t_s.size());
  if (window.time_sorted) {
    const auto t_begin = window.t_s.begin();
    begin = static_cast<std::size_t>(std::lower_bound(t_begin, t_begin + static_cast<std::ptrdiff_t>(end), t_lo) - t_begin);
    end = static_cast<std::size_t>(std::upper_bound(t_begin, t_begin + static_cast<std::ptrdiff_t>(end), t_hi) - t_begin);
  }
  const auto band = static_cast<std::uint32_t>(end_row - first_row);
  for (std::size_t k = begin; k < end; ++k) {
    const std::int32_t p = window.pixel[k];
    if (static_cast<std::uint32_t>(p - first_row) >= band) continue;  // a narrow band of rows
    const float t = window.t_s[k];
    if (t < t_lo || t > t_hi) continue;
    const std::int32_t y = p / w, x = p - y * w;
    if (x < e.x || x >= e.x + e.width) continue;
    sx += x;
    sy += y;
    st += t;
    ++n;
  }
  if (n < options_.roi_min_events) return std::nullopt;
  const Eigen::Vector2d centroid(sx / n, sy / n);
  // Clutter guard: the object was inside the box at the end of its sweep, so within the slice its
  // centre is at most about one box size away; a centroid further off is background.
  if ((centroid - c).norm() > std::max(box.width(), box.height())) return std::nullopt;
  return std::make_pair(centroid, st / n);
}

DetectionResult Detector::detect(const CompensatedEventsView& window) {
  const auto t_total = Clock::now();
  DetectionResult res;
  const DetectorOptions& o = options_;
  const int w = window.width, h = window.height;
  auto finish = [&](DetectionStatus s) {
    if (s != DetectionStatus::kDetected && s != DetectionStatus::kNoRegion &&
        s != DetectionStatus::kTooFewEventsInBox && s != DetectionStatus::kRemovedAsNoise)
      P_.setTo(0);  // no stale image from an earlier window
    res.status = s;
    res.timings.total_ms = ms_since(t_total);
    return res;
  };

  auto t = Clock::now();
  build_time_images(window, ti_);
  res.timings.time_images_ms = ms_since(t);
  res.mean_normalized = ti_.mean_normalized;
  S_.create(h, w, CV_32F);
  P_.create(h, w, CV_32F);
  if (ti_.events < o.min_window_events) {
    S_.setTo(0);
    return finish(DetectionStatus::kTooFewEvents);
  }

  t = Clock::now();
  res.theta = adaptive_threshold(ti_.mean_normalized, window.omega_rad_s, window.speed_m_s, o);
  res.segmented_pixels = segment(ti_, res.theta, S_);
  res.timings.segmentation_ms = ms_since(t);
  if (!(ti_.t_max_s > ti_.t_min_s)) return finish(DetectionStatus::kNoTemporalContrast);
  if (res.segmented_pixels == 0) return finish(DetectionStatus::kNothingSegmented);
  if (res.segmented_pixels > o.max_segmented_fraction * w * h) return finish(DetectionStatus::kFlooded);

  t = Clock::now();
  preprocess(S_, o, P_, scratch_);
  double p_max = 0;
  cv::Point arg_max;
  cv::minMaxLoc(P_, nullptr, &p_max, nullptr, &arg_max);
  res.timings.preprocess_ms = ms_since(t);
  if (!(p_max > 0) || p_max < o.min_peak * o.min_peak) return finish(DetectionStatus::kRemovedAsNoise);

  // Algorithm 1 from the pattern with the highest (filtered) mean timestamp, half-image ROI.
  t = Clock::now();
  const Eigen::Vector2d c0(arg_max.x, arg_max.y), l0(0.5 * w, 0.5 * h);
  res.fit = iterative_gaussian_fit(P_, c0, l0, o);
  const GaussianFit& fit = res.fit;
  auto events_in = [&](const Box2D& box) {
    const cv::Rect r = box_pixels(box, w, h);
    return r.area() > 0 ? static_cast<int>(cv::sum(ti_.count(r))[0]) : 0;
  };
  if (!fit.converged) res.fit_rejected = fit.empty_roi ? "empty roi" : fit.diverged ? "diverged" : "not converged";
  else if (fit.size.x() > o.roi_max_fraction * w || fit.size.y() > o.roi_max_fraction * h) res.fit_rejected = "too large";
  else if (fit.size.maxCoeff() > o.roi_max_aspect * fit.size.minCoeff()) res.fit_rejected = "aspect ratio";
  else if (events_in(fit.roi()) < o.roi_min_events) res.fit_rejected = "too few events";
  res.timings.fit_ms = ms_since(t);

  Box2D box;
  Eigen::Vector2d center;
  DetectionSource source = DetectionSource::kGaussianFit;
  if (res.fit_rejected.empty()) {
    box = fit.roi();
    center = fit.center;
  } else {
    // Moving-region retrieval: components within the initial (half-image) ROI around the
    // strongest pattern; the heaviest one overlapping the failed ROI, else the heaviest overall.
    t = Clock::now();
    const Box2D initial{c0.x() - 0.5 * l0.x(), c0.y() - 0.5 * l0.y(), c0.x() + 0.5 * l0.x(), c0.y() + 0.5 * l0.y()};
    const cv::Rect search = box_pixels(initial, w, h);
    std::optional<Region> region;
    if (!fit.empty_roi) region = retrieve_region(P_, fit.roi(), search, o, mask_, labels_, stats_, centroids_, mass_);
    if (!region) region = retrieve_region(P_, initial, search, o, mask_, labels_, stats_, centroids_, mass_);
    res.timings.retrieval_ms = ms_since(t);
    if (!region || region->box.width() > o.roi_max_fraction * w || region->box.height() > o.roi_max_fraction * h)
      return finish(DetectionStatus::kNoRegion);
    box = region->box;
    center = region->center;
    source = DetectionSource::kRegionRetrieval;
  }

  // The detection: events and mean time inside the box, score, raw-pixel mapping.
  const cv::Rect r = box_pixels(box, w, h);
  const int events = r.area() > 0 ? static_cast<int>(cv::sum(ti_.count(r))[0]) : 0;
  if (events < o.roi_min_events) return finish(DetectionStatus::kTooFewEventsInBox);
  double t_mean_s = cv::sum(ti_.sum_time_s(r))[0] / events;
  double peak_in_box = 0;
  cv::minMaxLoc(P_(r), nullptr, &peak_in_box);
  if (o.refine_box_scale > 0) {
    t = Clock::now();
    if (const auto refined = refine_with_events(window, box, t_mean_s)) {
      const Eigen::Vector2d shift = refined->first - center;
      box = {box.x0 + shift.x(), box.y0 + shift.y(), box.x1 + shift.x(), box.y1 + shift.y()};
      center = refined->first;
      t_mean_s = refined->second;
    }
    res.timings.refine_ms = ms_since(t);
  }
  Detection2D d;
  d.t_ns = window.t_start_ns + from_seconds(t_mean_s);
  d.box_undistorted = box;
  d.center_undistorted = center;
  d.center_normalized = {(center.x() - camera_.cx) / camera_.fx, (center.y() - camera_.cy) / camera_.fy};
  d.center_raw = undistorted_to_raw(center);
  d.box_raw = undistorted_box_to_raw(box);
  d.events = events;
  d.score = std::clamp(std::sqrt(peak_in_box), 0.0, 1.0);
  d.source = source;
  d.fit_iterations = fit.iterations;
  res.detection = d;
  return finish(DetectionStatus::kDetected);
}

}  // namespace fdv
