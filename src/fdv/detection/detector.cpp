#include "fdv/detection/detector.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <Eigen/Cholesky>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/core/lanes.h"

namespace fdv {
namespace {

void validate_or_throw(const DetectorOptions& o) {
  if (const auto why = o.validate(); !why.empty()) throw ConfigError("detector: " + why);
}

using Clock = std::chrono::steady_clock;

/// The refinement's scan: the events k in [begin, end) on the image rows [row0, row0 + rows) of a
/// w-wide image whose time lies in [t_lo, t_hi] are added to acc (per pixel: count, Σt; row-major,
/// w wide), in event order. Events on and off the band alternate in no pattern (with a branch per
/// event the scan took ~6 ns per event, warm or cold): the tests run four events at a time and
/// write the passing ones to a short list, branch-free; then the list is added in order.
/// The band's whole rows are counted, so no column is computed (the caller reads a rectangle of it).
void bin_slice(const std::int32_t* __restrict pixel, const float* __restrict t_s, std::size_t begin, std::size_t end,
               std::uint32_t w, std::uint32_t row0, std::uint32_t rows, float t_lo, float t_hi,
               float* __restrict acc) {
  using lanes::vf;
  using lanes::vi;
  using vu = std::uint32_t __attribute__((vector_size(16)));
  typedef std::uint32_t vu_u __attribute__((vector_size(16), aligned(4)));
  const std::uint32_t first = row0 * w, band = rows * w;
  const vu first_v = vu{} + first, band_v = vu{} + band;
  const vf lo = vf{} + t_lo, hi = vf{} + t_hi;
  constexpr std::size_t kChunk = 256;
  std::array<std::uint32_t, kChunk> at;
  std::array<float, kChunk> time;
  std::size_t k = begin;
  while (k < end) {
    const std::size_t chunk_end = std::min(end, k + kChunk);
    std::size_t n = 0;
    for (; k + 4 <= chunk_end; k += 4) {
      const vu d = *reinterpret_cast<const vu_u*>(pixel + k) - first_v;  // negative pixels wrap out
      const vf t = lanes::load(t_s + k);
      const vi pass = (d < band_v) & (t >= lo) & (t <= hi);
      for (int j = 0; j < 4; ++j) {
        at[n] = d[j];
        time[n] = t[j];
        n += static_cast<std::size_t>(pass[j] & 1);
      }
    }
    for (; k < chunk_end; ++k) {
      const std::uint32_t d = static_cast<std::uint32_t>(pixel[k]) - first;
      const float t = t_s[k];
      at[n] = d;
      time[n] = t;
      n += d < band && t >= t_lo && t <= t_hi;
    }
    for (std::size_t i = 0; i < n; ++i) {
      float* a = acc + 2 * (static_cast<std::size_t>(first) + at[i]);
      a[0] += 1.0f;
      a[1] += time[i];
    }
  }
}

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace

std::string_view to_string(DetectionSource s) {
  switch (s) {
    case DetectionSource::kGaussianFit: return "gaussian_fit";
    case DetectionSource::kRegionRetrieval: return "region_retrieval";
    case DetectionSource::kDenseMotion: return "dense_motion";
    case DetectionSource::kCountContrast: return "count_contrast";
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
  }
  return "?";
}

std::string DetectorOptions::validate() const {
  std::ostringstream why;
  auto odd_positive = [](int k) { return k >= 1 && k % 2 == 1 && k <= 31; };
  const double coeffs[] = {count_cue_surround_scale, count_cue_min_contrast, count_cue_min_fill,
                           motion_cue_min_r2, motion_cue_min_span, threshold_a_s_per_rad, threshold_b_s_per_m, threshold_c, fit_delta_center_px,
                           fit_delta_size_px, fit_min_size_px, refit_min_roi_px, refit_local_scale, roi_max_fraction, roi_max_aspect, max_segmented_fraction,
                           refine_box_scale, min_peak, min_event_density, prior_min_peak, prior_gate_scale,
                           prior_min_gate_px};
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
  else if (!(fit_min_size_px >= 1)) why << "fit_min_size_px must be at least 1, got " << fit_min_size_px;
  else if (!(refit_min_roi_px == 0 || refit_min_roi_px >= 1))
    why << "refit_min_roi_px must be 0 (off) or at least 1, got " << refit_min_roi_px;
  else if (!(refit_local_scale >= 0)) why << "refit_local_scale must be >= 0, got " << refit_local_scale;
  else if (!(prior_min_peak >= 0 && prior_min_peak <= 1)) why << "prior_min_peak must be in [0, 1], got " << prior_min_peak;
  else if (!(prior_gate_scale > 0)) why << "prior_gate_scale must be positive, got " << prior_gate_scale;
  else if (!(prior_min_gate_px >= 0)) why << "prior_min_gate_px must be >= 0, got " << prior_min_gate_px;
  else if (!(min_event_density >= 0)) why << "min_event_density must be >= 0, got " << min_event_density;
  else if (max_candidates < 1 || max_candidates > 100)
    why << "max_candidates must be in [1, 100], got " << max_candidates;
  else if (min_pixel_events < 1 || min_pixel_events > 1000)
    why << "min_pixel_events must be in [1, 1000], got " << min_pixel_events;
  else if (!(min_peak >= 0 && min_peak <= 1)) why << "min_peak must be in [0, 1], got " << min_peak;
  else if (!(roi_max_fraction > 0 && roi_max_fraction <= 1)) why << "roi_max_fraction must be in (0, 1], got " << roi_max_fraction;
  else if (!(roi_max_aspect >= 1)) why << "roi_max_aspect must be at least 1, got " << roi_max_aspect;
  else if (roi_min_events < 1) why << "roi_min_events must be positive, got " << roi_min_events;
  else if (region_min_area_px < 1) why << "region_min_area_px must be positive, got " << region_min_area_px;
  else if (!(refine_box_scale == 0 || (refine_box_scale >= 1 && refine_box_scale <= 10)))
    why << "refine_box_scale must be 0 (off) or in [1, 10], got " << refine_box_scale;
  else if (refine_recentre_passes < 0 || refine_recentre_passes > 20)
    why << "refine_recentre_passes must be in [0, 20], got " << refine_recentre_passes;
  else if (!odd_positive(motion_cue_density_px))
    why << "motion_cue_density_px must be odd in [1, 31], got " << motion_cue_density_px;
  else if (motion_cue_radius_px < 1 || motion_cue_radius_px > 100)
    why << "motion_cue_radius_px must be in [1, 100], got " << motion_cue_radius_px;
  else if (!(motion_cue_min_r2 >= 0 && motion_cue_min_r2 <= 1))
    why << "motion_cue_min_r2 must be in [0, 1], got " << motion_cue_min_r2;
  else if (motion_cue_min_pixels < 3) why << "motion_cue_min_pixels must be at least 3, got " << motion_cue_min_pixels;
  else if (!(motion_cue_min_span >= 0)) why << "motion_cue_min_span must be >= 0, got " << motion_cue_min_span;
  else if (!odd_positive(count_cue_box_px)) why << "count_cue_box_px must be odd in [1, 31], got " << count_cue_box_px;
  else if (!(count_cue_surround_scale > 1 && count_cue_surround_scale <= 10))
    why << "count_cue_surround_scale must be in (1, 10], got " << count_cue_surround_scale;
  else if (!(count_cue_min_contrast >= 1)) why << "count_cue_min_contrast must be at least 1, got " << count_cue_min_contrast;
  else if (!(count_cue_min_fill >= 0 && count_cue_min_fill <= 1))
    why << "count_cue_min_fill must be in [0, 1], got " << count_cue_min_fill;
  else if (min_window_events < 1) why << "min_window_events must be positive, got " << min_window_events;
  else if (!(max_segmented_fraction > 0 && max_segmented_fraction <= 1))
    why << "max_segmented_fraction must be in (0, 1], got " << max_segmented_fraction;
  return why.str();
}

Detector::Detector(const DetectorOptions& options, const PinholeCamera& event_camera)
    : options_(options), camera_(event_camera), pre_((validate_or_throw(options), options)) {
  if (const auto why = event_camera.validate(); !why.empty()) throw ConfigError("detector: event camera: " + why);
  allocate(camera_.width, camera_.height);
}

void Detector::allocate(int width, int height) {
  S_.create(height, width, CV_32F);
  S_.setTo(0);
  pre_.allocate({width, height});
  region_.reserve(width, height);
  blanked_.create(height, width, CV_32F);
  blanked_.setTo(0);
  blanked_bounds_ = {};
  count_f_.create(height, width, CV_32F);
  count_integral_.create(height + 1, width + 1, CV_64F);
  refine_acc_.create(height, width, CV_32FC2);
  cue_count8_.create(height, width, CV_8U);
  cue_active8_.create(height, width, CV_8U);
  cue_count_integral_.create(height + 1, width + 1, CV_32S);
  cue_live_blocks_.reserve(static_cast<std::size_t>(width));
  cue_active_integral_.create(height + 1, width + 1, CV_32S);
  count_excess_.create(height, width, CV_32F);
  count_excess_.setTo(0);
  excess_bounds_ = {};
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
                                                                              const Box2D& box, double t_box_s) {
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
  // The clutter guard below keeps the centre within one box size of the box's: the squares of all
  // passes lie inside `outer`, whose slice events are binned once per pixel (count, Σt).
  const double reach = std::max(box.width(), box.height());
  const cv::Rect outer = box_pixels({c.x() - reach - half, c.y() - reach - half, c.x() + reach + half, c.y() + reach + half},
                                    window.width, window.height);
  if (outer.area() == 0) return std::nullopt;
  // The band of outer's rows, whole (bin_slice counts whole rows).
  CV_Assert(refine_acc_.isContinuous() && refine_acc_.cols == window.width);
  std::fill_n(refine_acc_.ptr<float>(outer.y), 2 * static_cast<std::size_t>(outer.height) * window.width, 0.0f);
  const std::int32_t w = window.width;
  // Time-ordered windows (the compensators keep the input's order): only the slice is scanned.
  std::size_t begin = 0, end = std::min(window.pixel.size(), window.t_s.size());
  if (window.time_sorted) {
    const auto t_begin = window.t_s.begin();
    begin = static_cast<std::size_t>(std::lower_bound(t_begin, t_begin + static_cast<std::ptrdiff_t>(end), t_lo) - t_begin);
    end = static_cast<std::size_t>(std::upper_bound(t_begin, t_begin + static_cast<std::ptrdiff_t>(end), t_hi) - t_begin);
  }
  bin_slice(window.pixel.data(), window.t_s.data(), begin, end, static_cast<std::uint32_t>(w),
            static_cast<std::uint32_t>(outer.y), static_cast<std::uint32_t>(outer.height), t_lo, t_hi,
            refine_acc_.ptr<float>(0));
  // Mean shift with a flat square kernel: the square starts on the box, whose centre lies ahead of
  // the object (the box holds the latest sweep), and residual background events inside it pull the
  // centroid towards that centre. Re-centring the square on the centroid removes the pull: the
  // fixed point is the square centred on the object's events.
  Eigen::Vector2d centre = c;
  double sx = 0, sy = 0, st = 0;
  long n = 0;
  for (int pass = 0; pass <= options_.refine_recentre_passes; ++pass) {
    const cv::Rect e = box_pixels({centre.x() - half, centre.y() - half, centre.x() + half, centre.y() + half},
                                  window.width, window.height) & outer;
    if (e.area() == 0) return std::nullopt;
    sx = sy = st = 0;
    n = 0;
    for (int y = e.y; y < e.y + e.height; ++y) {
      const float* acc = refine_acc_.ptr<float>(y);
      long row_n = 0;
      for (int x = e.x; x < e.x + e.width; ++x) {
        const auto count = static_cast<long>(acc[2 * x]);  // a whole number below 2^24: exact
        row_n += count;
        sx += static_cast<double>(count) * x;
        st += acc[2 * x + 1];
      }
      n += row_n;
      sy += static_cast<double>(row_n) * y;
    }
    if (n < options_.roi_min_events) return std::nullopt;
    const Eigen::Vector2d next = Eigen::Vector2d(sx, sy) / static_cast<double>(n);
    const bool settled = (next - centre).norm() < 0.25;
    centre = next;
    // Clutter guard: the object was inside the box at the end of its sweep, so within the slice
    // its centre is at most about one box size away; a centroid further off is background.
    if ((centre - c).norm() > reach) return std::nullopt;
    if (settled) break;
  }
  return std::make_pair(centre, st / static_cast<double>(n));
}

std::optional<Box2D> Detector::prior_gate(const DetectionPrior& prior) const {
  const Eigen::Vector2d xn = camera_.pixel_to_normalized(prior.center_raw);
  if (!xn.allFinite()) return std::nullopt;
  const Eigen::Vector2d c(camera_.fx * xn.x() + camera_.cx, camera_.fy * xn.y() + camera_.cy);
  const double half_w = std::max(0.5 * options_.prior_gate_scale * prior.box_size_px.x(), options_.prior_min_gate_px);
  const double half_h = std::max(0.5 * options_.prior_gate_scale * prior.box_size_px.y(), options_.prior_min_gate_px);
  return Box2D{c.x() - half_w, c.y() - half_h, c.x() + half_w, c.y() + half_h};
}

std::optional<Detector::Candidate> Detector::evaluate_candidate(const CompensatedEventsView& window,
                                                               const cv::Mat& P, cv::Point seed, double min_peak,
                                                               DetectionResult& res, DetectionStatus& why_not,
                                                               Box2D& blank) {
  const DetectorOptions& o = options_;
  const int w = window.width, h = window.height;
  // Algorithm 1 from the seed pattern, half-image initial ROI.
  auto t = Clock::now();
  const Eigen::Vector2d c0(seed.x, seed.y), l0(0.5 * w, 0.5 * h);
  const Box2D initial{c0.x() - 0.5 * l0.x(), c0.y() - 0.5 * l0.y(), c0.x() + 0.5 * l0.x(), c0.y() + 0.5 * l0.y()};
  res.fit = iterative_gaussian_fit(P, c0, l0, o);
  const GaussianFit& fit = res.fit;
  auto events_in = [&](const Box2D& box) {
    const cv::Rect r = box_pixels(box, w, h);
    return r.area() > 0 ? static_cast<int>(cv::sum(ti_.count(r))[0]) : 0;
  };
  res.fit_rejected = {};
  if (!fit.converged) res.fit_rejected = fit.empty_roi ? "empty roi" : fit.diverged ? "diverged" : "not converged";
  else if (fit.size.x() > o.roi_max_fraction * w || fit.size.y() > o.roi_max_fraction * h) res.fit_rejected = "too large";
  else if (fit.size.maxCoeff() > o.roi_max_aspect * fit.size.minCoeff()) res.fit_rejected = "aspect ratio";
  else if (events_in(fit.roi()) < o.roi_min_events) res.fit_rejected = "too few events";
  res.timings.fit_ms += ms_since(t);

  Candidate c;
  if (res.fit_rejected.empty()) {
    c.box = fit.roi();
    c.center = fit.center;
    c.source = DetectionSource::kGaussianFit;
  } else {
    // Moving-region retrieval: components within the initial (half-image) ROI around the seed;
    // the heaviest one overlapping the failed ROI, else the heaviest overall.
    t = Clock::now();
    const cv::Rect search = box_pixels(initial, w, h);
    const std::array<Box2D, 2> rois{fit.roi(), initial};
    const std::optional<Region> region =
        retrieve_region(P, std::span<const Box2D>(rois).subspan(fit.empty_roi ? 1 : 0), search, o, region_);
    res.timings.retrieval_ms += ms_since(t);
    if (!region || region->box.width() > o.roi_max_fraction * w || region->box.height() > o.roi_max_fraction * h) {
      why_not = DetectionStatus::kNoRegion;
      if (region) blank = region->box;
      return std::nullopt;
    }
    c.box = region->box;
    c.center = region->center;
    c.source = DetectionSource::kRegionRetrieval;
  }
  blank = c.box;
  // The evidence gates: events, the peak of P (score) and events per pixel in the box.
  auto passes_gates = [&](Candidate& k) {
    k.events = events_in(k.box);
    if (k.events < o.roi_min_events) {
      why_not = DetectionStatus::kTooFewEventsInBox;
      return false;
    }
    const cv::Rect r = box_pixels(k.box, w, h);
    const double peak_in_box = first_maximum(P, r).value;
    k.score = std::clamp(std::sqrt(peak_in_box), 0.0, 1.0);
    k.event_density = static_cast<double>(k.events) / r.area();
    if (k.score < min_peak || k.event_density < o.min_event_density) {
      why_not = DetectionStatus::kWeakEvidence;
      return false;
    }
    k.t_mean_s = cv::sum(ti_.sum_time_s(r))[0] / k.events;
    return true;
  };
  if (passes_gates(c)) return c;
  if (!(o.refit_min_roi_px > 0)) return std::nullopt;

  // Smaller initial ROIs from the same seed (docs/DETECTION.md, "Smaller initial ROIs").
  // Algorithm 1 is a mean shift whose result depends on its initial window: from half the image it
  // merges a small object's pattern with the clutter patterns around it into a large, sparse box
  // (or fails, and the retrieved component is the object plus touching clutter), which the
  // density gate then rejects. A smaller window converges on the seed's own pattern. The ROI is
  // halved while its shorter side is at least refit_min_roi_px; the first box that passes the
  // plausibility gates, the evidence gates and the local test below is kept.
  //
  // Local test: a small box can sit on the texture of a region that the compensation left late
  // as a whole (a wall at the image border in fast flight, texture far from the median depth);
  // every blob of such a region exceeds θ and is dense. θ = mean(N) + margin asks a pattern to
  // stand out against the whole image's mean; the box must stand out the same way against its
  // surroundings: the mean of S over its segmented pixels at least the mean N of the event pixels
  // within refit_local_scale × its longer side of its centre, plus θ − mean(N).
  const double margin = res.theta - res.mean_normalized;
  auto stands_out = [&](const Box2D& b) {
    if (!(o.refit_local_scale > 0)) return true;
    const cv::Rect r = box_pixels(b, w, h);
    const Eigen::Vector2d bc = b.center();
    const double half = o.refit_local_scale * std::max(b.width(), b.height());
    const cv::Rect around = box_pixels({bc.x() - half, bc.y() - half, bc.x() + half, bc.y() + half}, w, h);
    double s_sum = 0, n_sum = 0;
    int s_px = 0, n_px = 0;
    for (int y = around.y; y < around.y + around.height; ++y) {
      const std::int32_t* count = ti_.count.ptr<std::int32_t>(y);
      const float* n = ti_.normalized.ptr<float>(y);
      const float* seg = S_.ptr<float>(y);
      const bool row_in_box = y >= r.y && y < r.y + r.height;
      for (int x = around.x; x < around.x + around.width; ++x) {
        if (count[x] == 0) continue;
        n_sum += n[x];
        ++n_px;
        if (row_in_box && x >= r.x && x < r.x + r.width && seg[x] > 0) {
          s_sum += seg[x];
          ++s_px;
        }
      }
    }
    return s_px > 0 && n_px > 0 && s_sum / s_px >= n_sum / n_px + margin;
  };
  const DetectionStatus why_first = why_not;
  for (Eigen::Vector2d l = 0.5 * l0; l.minCoeff() >= o.refit_min_roi_px; l *= 0.5) {
    t = Clock::now();
    const GaussianFit f = iterative_gaussian_fit(P, c0, l, o);
    res.timings.fit_ms += ms_since(t);
    if (!f.converged || f.size.x() > o.roi_max_fraction * w || f.size.y() > o.roi_max_fraction * h ||
        f.size.maxCoeff() > o.roi_max_aspect * f.size.minCoeff())
      continue;
    Candidate k;
    k.box = f.roi();
    k.center = f.center;
    k.source = DetectionSource::kGaussianFit;
    if (passes_gates(k) && stands_out(k.box)) {
      res.fit = f;
      res.fit_rejected = {};
      return k;
    }
  }
  why_not = why_first;  // the status of the paper's candidate
  return std::nullopt;
}

std::optional<Detector::Candidate> Detector::dense_motion_candidate(double window_s, const cv::Rect& search,
                                                                  DetectionResult& res) {
  const DetectorOptions& o = options_;
  const int w = ti_.count.cols, h = ti_.count.rows;
  const cv::Rect area = search & cv::Rect(0, 0, w, h);
  if (area.area() == 0) return std::nullopt;
  res.motion_cue_ran = true;
  // The box with the most active pixels (I ≥ min_pixel_events) in the search area (its centre
  // pixel; boxes are clipped at the area's border). Counting pixels, not events, keeps a hot pixel
  // from being "dense".
  for (int y = 0; y < area.height; ++y) {
    const std::int32_t* count = ti_.count.ptr<std::int32_t>(area.y + y) + area.x;
    float* active = count_f_.ptr<float>(y);
    for (int x = 0; x < area.width; ++x) active[x] = count[x] >= o.min_pixel_events ? 1.0f : 0.0f;
  }
  cv::Mat integral = count_integral_(cv::Rect(0, 0, area.width + 1, area.height + 1));
  cv::integral(count_f_(cv::Rect(0, 0, area.width, area.height)), integral, CV_64F);
  const int hk = o.motion_cue_density_px / 2;
  double densest = 0;
  cv::Point at(-1, -1);
  for (int y = 0; y < area.height; ++y) {
    const double* top = integral.ptr<double>(std::max(0, y - hk));
    const double* bottom = integral.ptr<double>(std::min(area.height, y + hk + 1));
    for (int x = 0; x < area.width; ++x) {
      const int x0 = std::max(0, x - hk), x1 = std::min(area.width, x + hk + 1);
      const double active_pixels = bottom[x1] - bottom[x0] - top[x1] + top[x0];
      if (active_pixels > densest) {
        densest = active_pixels;
        at = {area.x + x, area.y + y};
      }
    }
  }
  if (at.x < 0) return std::nullopt;
  // Count-weighted least squares T_ij ≈ a + g·(i − x_c, j − y_c) over the square; the weighted
  // moments of I give the blob's centroid and spread as well.
  const int r = o.motion_cue_radius_px;
  const cv::Rect square = cv::Rect(at.x - r, at.y - r, 2 * r + 1, 2 * r + 1) & cv::Rect(0, 0, w, h);
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double n_sum = 0, t_sum = 0, tt_sum = 0, xx_sum = 0, yy_sum = 0;
  int active_pixels = 0;
  for (int y = square.y; y < square.y + square.height; ++y) {
    const std::int32_t* count = ti_.count.ptr<std::int32_t>(y);
    const float* mean_time = ti_.mean_time_s.ptr<float>(y);
    for (int x = square.x; x < square.x + square.width; ++x) {
      if (count[x] < o.min_pixel_events) continue;
      ++active_pixels;
      const double n = count[x], t = mean_time[x];
      const Eigen::Vector3d f(1.0, x - at.x, y - at.y);
      A.noalias() += n * f * f.transpose();
      b += (n * t) * f;
      n_sum += n;
      t_sum += n * t;
      tt_sum += n * t * t;
      xx_sum += n * f.y() * f.y();
      yy_sum += n * f.z() * f.z();
    }
  }
  if (active_pixels < o.motion_cue_min_pixels || n_sum < o.roi_min_events) return std::nullopt;
  const double total_ss = tt_sum - t_sum * t_sum / n_sum;
  if (!(total_ss > 0)) return std::nullopt;
  const Eigen::Vector3d plane = A.ldlt().solve(b);
  const double residual_ss = tt_sum - 2.0 * plane.dot(b) + plane.dot(A * plane);
  res.motion_cue_r2 = 1.0 - residual_ss / total_ss;
  res.motion_cue_span = std::hypot(plane.y(), plane.z()) * square.width / window_s;
  if (!(res.motion_cue_r2 >= o.motion_cue_min_r2) || !(res.motion_cue_span >= o.motion_cue_min_span))
    return std::nullopt;
  // The box: centroid ± 2σ of I over the square (Algorithm 1's L = 4σ), inside the square.
  const Eigen::Vector2d mean(A(0, 1) / n_sum, A(0, 2) / n_sum);
  const Eigen::Vector2d sigma(std::sqrt(std::max(0.0, xx_sum / n_sum - mean.x() * mean.x())),
                              std::sqrt(std::max(0.0, yy_sum / n_sum - mean.y() * mean.y())));
  const Eigen::Vector2d half = (2.0 * sigma).cwiseMax(0.5 * o.fit_min_size_px);
  const Eigen::Vector2d c = mean + Eigen::Vector2d(at.x, at.y);
  Candidate cand;
  cand.box = Box2D{std::max<double>(square.x, c.x() - half.x()), std::max<double>(square.y, c.y() - half.y()),
                   std::min<double>(square.x + square.width, c.x() + half.x()),
                   std::min<double>(square.y + square.height, c.y() + half.y())};
  cand.center = cand.box.center();
  cand.source = DetectionSource::kDenseMotion;
  const cv::Rect box = box_pixels(cand.box, w, h);
  if (box.area() == 0) return std::nullopt;
  cand.events = static_cast<int>(cv::sum(ti_.count(box))[0]);
  cand.event_density = static_cast<double>(cand.events) / box.area();
  if (cand.events < o.roi_min_events || cand.event_density < o.min_event_density) return std::nullopt;
  cand.score = std::clamp(res.motion_cue_r2, 0.0, 1.0);
  cand.t_mean_s = cv::sum(ti_.sum_time_s(box))[0] / cand.events;
  return cand;
}

std::optional<Detector::Candidate> Detector::count_contrast_candidate(const cv::Rect& search, bool time_test,
                                                                    DetectionResult& res) {
  const DetectorOptions& o = options_;
  const int w = ti_.count.cols, h = ti_.count.rows;
  const int k = o.count_cue_box_px, hk = k / 2;
  const int hs = static_cast<int>(std::lround(0.5 * o.count_cue_surround_scale * k));
  // Centres whose surround lies in the image: the contrast needs the whole surround (and the
  // image's border is where compensation is worst: content enters and leaves there).
  const cv::Rect area = search & cv::Rect(hs, hs, w - 2 * hs, h - 2 * hs);
  if (area.area() <= 0 || ti_.events <= 0 || !(ti_.t_max_s > ti_.t_min_s)) return std::nullopt;
  res.count_cue_ran = true;
  // The summed-area table of I's active pixels (I ≥ min_pixel_events) over the whole image (the
  // surround of a centre near the search area's border reaches outside it), once per window.
  if (!cue_active_ready_) {
    cv::compare(ti_.count, o.min_pixel_events - 1, cue_active8_, cv::CMP_GT);  // 255 where active
    cv::integral(cue_active8_, cue_active_integral_, CV_32S);
    cue_active_ready_ = true;
  }
  auto box_sum = [](const cv::Mat& sat, int x, int y, int width, int height) {
    return static_cast<double>(sat.at<std::int32_t>(y + height, x + width) - sat.at<std::int32_t>(y, x + width) -
                               sat.at<std::int32_t>(y + height, x) + sat.at<std::int32_t>(y, x));
  };
  // Σ of I saturated at 255 over a box (8-bit counts: a hot pixel weighs as 255 events). Few centres
  // pass the fill test (~100 of 280 k on a textured 5 M ev/s window), so their sums are taken
  // directly; past kDirectSums centres the whole image's table is cheaper and is built. Both give the
  // same integers.
  constexpr int kDirectSums = 1000;
  int filled = 0;  // centres that pass the fill test
  auto count_sum = [&](int x, int y, int width, int height) {
    if (!cue_count_ready_ && filled > kDirectSums) {
      ti_.count.convertTo(cue_count8_, CV_8U);
      cv::integral(cue_count8_, cue_count_integral_, CV_32S);
      cue_count_ready_ = true;
    }
    if (cue_count_ready_) return box_sum(cue_count_integral_, x, y, width, height);
    std::int32_t sum = 0;
    for (int r = y; r < y + height; ++r) {
      const std::int32_t* row = ti_.count.ptr<std::int32_t>(r) + x;
      for (int c = 0; c < width; ++c) sum += std::min(row[c], 255);
    }
    return static_cast<double>(sum);
  };
  // The background level: the image's mean events per pixel, the floor of the surround's density
  // (an empty surround must not make any small cluster "infinitely" dense).
  const double image_density = static_cast<double>(ti_.events) / (static_cast<double>(w) * h);
  double best = 0;
  cv::Point at(-1, -1);
  double best_fill = 0, best_surround = 0;
  // Both boxes lie in the image (hs > hk since count_cue_surround_scale > 1).
  const double centre_area = static_cast<double>(k) * k;
  const double ring_area = static_cast<double>(2 * hs + 1) * (2 * hs + 1) - centre_area;
  // Centres in raster order (the first best wins ties), in bands of kBlock rows cut into blocks of
  // kBlock columns: a block whose centres' boxes together hold too few active pixels for any one of
  // them to pass the fill test is skipped whole (each box's fill ≤ the union's; exact).
  constexpr int kBlock = 8;
  std::vector<int>& live = cue_live_blocks_;  // this band's blocks that may hold a passing centre
  for (int y0 = area.y; y0 < area.y + area.height; y0 += kBlock) {
    const int rows = std::min(kBlock, area.y + area.height - y0);
    live.clear();
    for (int x0 = area.x; x0 < area.x + area.width; x0 += kBlock) {
      const int cols = std::min(kBlock, area.x + area.width - x0);
      const double union_fill =
          box_sum(cue_active_integral_, x0 - hk, y0 - hk, cols + 2 * hk, rows + 2 * hk) / (255.0 * centre_area);
      if (!(union_fill < o.count_cue_min_fill)) live.push_back(x0);
    }
    for (int y = y0; y < y0 + rows && !live.empty(); ++y) {
      for (const int x0 : live) {
        for (int x = x0; x < std::min(x0 + kBlock, area.x + area.width); ++x) {
          const double fill = box_sum(cue_active_integral_, x - hk, y - hk, k, k) / (255.0 * centre_area);
          if (fill < o.count_cue_min_fill) continue;
          ++filled;
          const double in = count_sum(x - hk, y - hk, k, k);
          const double surround = (count_sum(x - hs, y - hs, 2 * hs + 1, 2 * hs + 1) - in) / ring_area;
          const double contrast = in / centre_area / std::max(surround, image_density);
          if (contrast > best) {
            best = contrast;
            at = {x, y};
            best_fill = fill;
            best_surround = surround;
          }
        }
      }
    }
  }
  res.count_cue_contrast = best;
  res.count_cue_fill = best_fill;
  res.count_cue_filled_centres = filled;
  if (at.x < 0 || best < o.count_cue_min_contrast) return std::nullopt;
  // The blob's box: Algorithm 1 on the events above the surround's level, I − max(surround, mean),
  // within the surround square around the densest centre (zero elsewhere), from that square.
  const double level = std::max(best_surround, image_density);
  const cv::Rect outer = cv::Rect(at.x - hs, at.y - hs, 2 * hs + 1, 2 * hs + 1) & cv::Rect(0, 0, w, h);
  zero_rect(count_excess_, excess_bounds_);
  cv::Mat excess = count_excess_(outer);
  ti_.count(outer).convertTo(excess, CV_32F, 1.0, -level);
  cv::max(excess, 0.0, excess);
  excess_bounds_ = outer;
  const GaussianFit f = iterative_gaussian_fit(count_excess_, Eigen::Vector2d(at.x, at.y),
                                              Eigen::Vector2d(outer.width, outer.height), o);
  Candidate cand;
  cand.source = DetectionSource::kCountContrast;
  if (f.converged && f.size.maxCoeff() <= o.roi_max_aspect * f.size.minCoeff()) {
    cand.box = f.roi();
    cand.center = f.center;
  } else {
    cand.box = Box2D{at.x - 0.5 * k + 0.5, at.y - 0.5 * k + 0.5, at.x + 0.5 * k + 0.5, at.y + 0.5 * k + 0.5};
    cand.center = cand.box.center();
  }
  const cv::Rect box = box_pixels(cand.box, w, h);
  if (box.area() == 0) return std::nullopt;
  cand.events = static_cast<int>(cv::sum(ti_.count(box))[0]);
  cand.event_density = static_cast<double>(cand.events) / box.area();
  if (cand.events < o.roi_min_events || cand.event_density < o.min_event_density) return std::nullopt;
  // Its events must not follow the background's time profile: their mean time stands out from all
  // events' by θ's margin a‖ω‖ + b‖v‖ + c, in N's units (the margin by which a pixel of S stands out
  // from mean(N)); early or late, since a late burst of background events (a jerk of the camera)
  // moves the image's mean time, not the object's.
  cand.t_mean_s = cv::sum(ti_.sum_time_s(box))[0] / cand.events;
  const double image_t_mean_s = cv::sum(ti_.sum_time_s)[0] / ti_.events;
  res.count_cue_time_offset = (cand.t_mean_s - image_t_mean_s) / (ti_.t_max_s - ti_.t_min_s);
  if (time_test && !(std::abs(res.count_cue_time_offset) >= res.theta - res.mean_normalized)) return std::nullopt;
  cand.score = 1.0 - 1.0 / best;  // the fraction of the centre's events above the background level
  return cand;
}

DetectionResult Detector::detect(const CompensatedEventsView& window, std::span<const DetectionPrior> priors) {
  const auto t_total = Clock::now();
  DetectionResult res;
  const DetectorOptions& o = options_;
  const int w = window.width, h = window.height;
  auto finish = [&](DetectionStatus s) {
    if (s != DetectionStatus::kDetected && s != DetectionStatus::kNoRegion &&
        s != DetectionStatus::kTooFewEventsInBox && s != DetectionStatus::kRemovedAsNoise &&
        s != DetectionStatus::kWeakEvidence)
      pre_.clear();  // no stale image from an earlier window
    res.status = s;
    res.timings.total_ms = ms_since(t_total);
    return res;
  };

  auto t = Clock::now();
  build_time_images(window, ti_);
  res.timings.time_images_ms = ms_since(t);
  res.mean_normalized = ti_.mean_normalized;
  if (S_.rows != h || S_.cols != w) allocate(w, h);
  if (ti_.events < o.min_window_events) {
    zero_rect(S_, {0, 0, w, h});
    return finish(DetectionStatus::kTooFewEvents);
  }

  t = Clock::now();
  res.theta = adaptive_threshold(ti_.mean_normalized, window.omega_rad_s, window.speed_m_s, o);
  const SegmentResult seg = segment(ti_, res.theta, o.min_pixel_events, S_, window.threads);
  res.segmented_pixels = seg.pixels;
  res.timings.segmentation_ms = ms_since(t);
  if (!(ti_.t_max_s > ti_.t_min_s)) return finish(DetectionStatus::kNoTemporalContrast);
  if (res.segmented_pixels > o.max_segmented_fraction * w * h) return finish(DetectionStatus::kFlooded);

  const double window_s = to_seconds(window.t_end_ns - window.t_start_ns);
  t = Clock::now();
  const cv::Mat& P = pre_.run(S_, seg.bounds, window.threads);
  // P is 0 outside `support`: the maxima below search only there (the same first maximum in
  // raster order as over the whole image).
  const cv::Rect support = pre_.nonzero_bounds();
  res.timings.preprocess_ms = ms_since(t);

  // Candidates: Algorithm 1 from the strongest pattern; a candidate that yields no plausible box or
  // fails the evidence gates (min_peak, min_event_density) is blanked and the next strongest pattern
  // is tried, up to max_candidates. The blanking works on a copy: P stays as pre-processed.
  const cv::Mat* image = &P;
  std::optional<Candidate> found;
  DetectionStatus why_not =
      res.segmented_pixels == 0 ? DetectionStatus::kNothingSegmented : DetectionStatus::kRemovedAsNoise;
  for (int attempt = 0; attempt < o.max_candidates && support.area() > 0; ++attempt) {
    const MaxLocation peak = image == &P ? pre_.first_max() : first_maximum(*image, support);
    const double p_max = peak.value;
    const cv::Point arg_max = peak.at;
    if (!(p_max > 0) || p_max < o.min_peak * o.min_peak) break;  // no pattern left can pass
    ++res.candidates;
    Box2D blank;
    found = evaluate_candidate(window, *image, arg_max, o.min_peak, res, why_not, blank);
    if (found) break;
    if (image == &P) {
      // Only P's support is copied; blanked_ is kept 0 elsewhere.
      zero_rect(blanked_, blanked_bounds_);
      P(support).copyTo(blanked_(support));
      blanked_bounds_ = support;
      image = &blanked_;
    }
    // The seed's own neighbourhood always goes, so that the next attempt starts elsewhere.
    const double r = 0.5 * (o.mean_filter_px + o.opening_px);
    zero_rect(blanked_, box_pixels({arg_max.x - r, arg_max.y - r, arg_max.x + r + 1, arg_max.y + r + 1}, w, h));
    zero_rect(blanked_, box_pixels(blank, w, h));
  }
  // Track-aided look: where a confirmed track expects its object, the strongest pattern inside the
  // gate may pass with the lower prior_min_peak (its box must stay centred inside the gate).
  for (const DetectionPrior& prior : priors) {
    if (found) break;
    const auto gate = prior_gate(prior);
    if (!gate) continue;
    const cv::Rect g = box_pixels(*gate, w, h);
    if (g.area() == 0) continue;
    const MaxLocation peak = first_maximum(P, g);
    const double p_max = peak.value;
    if (!(p_max > 0) || p_max < o.prior_min_peak * o.prior_min_peak) continue;
    ++res.candidates;
    Box2D blank;
    found = evaluate_candidate(window, P, peak.at, o.prior_min_peak, res, why_not, blank);
    if (found && !gate->contains(found->center)) found.reset();
    res.track_aided = found.has_value();
  }
  // Dense-motion cue, inside the same gates: a far, spinning object that N does not show.
  for (const DetectionPrior& prior : priors) {
    if (found || !o.motion_cue || !(window_s > 0)) break;
    const auto gate = prior_gate(prior);
    if (!gate) continue;
    t = Clock::now();
    found = dense_motion_candidate(window_s, box_pixels(*gate, w, h), res);
    if (found && !gate->contains(found->center)) found.reset();
    res.track_aided = found.has_value();
    res.timings.motion_cue_ms += ms_since(t);
  }
  // Count-contrast cue: a compact blob far denser than its surroundings in I; first inside the
  // confirmed tracks' gates without the time test (count_cue_in_gates), then over the image with it.
  if (!found && o.count_cue) {
    t = Clock::now();
    cue_active_ready_ = cue_count_ready_ = false;
    for (const DetectionPrior& prior : priors) {
      if (found || !o.count_cue_in_gates) break;
      const auto gate = prior_gate(prior);
      if (!gate) continue;
      found = count_contrast_candidate(box_pixels(*gate, w, h), false, res);
      if (found && !gate->contains(found->center)) found.reset();
      res.track_aided = found.has_value();
    }
    if (!found) found = count_contrast_candidate({0, 0, w, h}, true, res);
    res.timings.count_cue_ms = ms_since(t);
  }
  if (!found) return finish(why_not);
  Box2D box = found->box;
  Eigen::Vector2d center = found->center;
  double t_mean_s = found->t_mean_s;
  const int events = found->events;
  if (o.refine_box_scale > 0) {
    t = Clock::now();
    if (const auto refined = refine_with_events(window, box, t_mean_s)) {
      box = box.moved_by(refined->first - center);
      center = refined->first;
      t_mean_s = refined->second;
    }
    res.timings.refine_ms = ms_since(t);
  }
  if (o.square_box) {
    const double half = 0.5 * std::max(box.width(), box.height());
    box = Box2D{center.x() - half, center.y() - half, center.x() + half, center.y() + half};
  }
  Detection2D d;
  d.t_ns = window.t_start_ns + from_seconds(t_mean_s);
  d.box_undistorted = box;
  d.center_undistorted = center;
  // Seen by the camera at the detection's time (the events were warped to the window's start).
  const Eigen::Vector2d seen = window.observed_at ? window.observed_at(center, t_mean_s) : center;
  d.center_normalized = {(seen.x() - camera_.cx) / camera_.fx, (seen.y() - camera_.cy) / camera_.fy};
  d.center_raw = undistorted_to_raw(seen);
  d.box_raw = undistorted_box_to_raw(box.moved_by(seen - center));
  d.events = events;
  d.score = found->score;
  d.event_density = found->event_density;
  d.source = found->source;
  d.fit_iterations = res.fit.iterations;
  d.track_aided = res.track_aided;
  res.detection = d;
  return finish(DetectionStatus::kDetected);
}

}  // namespace fdv
