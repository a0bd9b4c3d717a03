#include "fdv/detection/gaussian_fit_source.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

namespace fdv {

std::string GaussianFitSourceOptions::validate() const {
  for (double v : {refit_min_roi_px, refit_local_scale, roi_max_fraction, large_region_min_contrast, min_peak,
                   further_min_peak})
    if (!std::isfinite(v)) return "non-finite detector parameter";
  std::ostringstream why;
  if (!(refit_min_roi_px == 0 || refit_min_roi_px >= 1))
    why << "refit_min_roi_px must be 0 (off) or at least 1, got " << refit_min_roi_px;
  else if (!(refit_local_scale >= 0)) why << "refit_local_scale must be >= 0, got " << refit_local_scale;
  else if (max_candidates < 1 || max_candidates > 100)
    why << "max_candidates must be in [1, 100], got " << max_candidates;
  else if (!(min_peak >= 0 && min_peak <= 1)) why << "min_peak must be in [0, 1], got " << min_peak;
  else if (!(further_min_peak >= 0 && further_min_peak <= 1))
    why << "further_min_peak must be in [0, 1], got " << further_min_peak;
  else if (!(large_region_min_contrast >= 0))
    why << "large_region_min_contrast must be >= 0, got " << large_region_min_contrast;
  else if (!(roi_max_fraction > 0 && roi_max_fraction <= 1))
    why << "roi_max_fraction must be in (0, 1], got " << roi_max_fraction;
  return why.str();
}

bool spans_separate_tracks(const Box2D& box, std::span<const Box2D> gates) {
  for (std::size_t i = 0; i < gates.size(); ++i)
    for (std::size_t j = i + 1; j < gates.size(); ++j)
      if (box.contains(gates[i].center()) && box.contains(gates[j].center()) && !gates[i].intersects(gates[j]))
        return true;
  return false;
}

std::optional<Candidate> evaluate_pattern(const DetectorOptions& o, SourceWindow& in, const cv::Mat& P, cv::Point seed,
                                          double min_peak, PatternFitDiagnostics& diagnostics, Box2D& blank) {
  const GaussianFitSourceOptions& g = o.gaussian_fit;
  const int w = in.events.width, h = in.events.height;
  const double fit_max_w = g.roi_max_fraction * w, fit_max_h = g.roi_max_fraction * h;
  const double region_max_side = o.fills_view_fraction * std::min(w, h);
  // Algorithm 1 from the seed pattern, half-image initial ROI.
  const Eigen::Vector2d c0(seed.x, seed.y), l0(0.5 * w, 0.5 * h);
  const Box2D initial{c0.x() - 0.5 * l0.x(), c0.y() - 0.5 * l0.y(), c0.x() + 0.5 * l0.x(), c0.y() + 0.5 * l0.y()};
  const GaussianFit fit = iterative_gaussian_fit(P, c0, l0, o);
  auto events_in = [&](const Box2D& box) {
    const cv::Rect r = box_pixels(box, w, h);
    return r.area() > 0 ? static_cast<int>(cv::sum(in.ti.count(r))[0]) : 0;
  };
  std::string_view rejected;
  if (!fit.converged) rejected = fit.empty_roi ? "empty roi" : fit.diverged ? "diverged" : "not converged";
  else if (fit.size.x() > fit_max_w || fit.size.y() > fit_max_h) rejected = "too large";
  else if (fit.size.maxCoeff() > o.roi_max_aspect * fit.size.minCoeff()) rejected = "aspect ratio";
  else if (events_in(fit.roi()) < o.roi_min_events) rejected = "too few events";
  diagnostics = {.fit_iterations = fit.iterations, .fit_converged = fit.converged, .fit_rejected = rejected};

  // The evidence gates: events, the peak of P (score) and events per pixel in the box.
  auto passes_gates = [&](Candidate& k) {
    k.events = events_in(k.box);
    if (k.events < o.roi_min_events) {
      in.why_not = DetectionStatus::kTooFewEventsInBox;
      return false;
    }
    const cv::Rect r = box_pixels(k.box, w, h);
    const double peak_in_box = first_maximum(P, r).value;
    k.score = std::clamp(std::sqrt(peak_in_box), 0.0, 1.0);
    k.event_density = static_cast<double>(k.events) / r.area();
    if (k.score < min_peak || k.event_density < o.min_event_density) {
      in.why_not = DetectionStatus::kWeakEvidence;
      return false;
    }
    k.t_mean_s = cv::sum(in.ti.sum_time_s(r))[0] / k.events;
    return true;
  };
  Candidate c;
  c.fit_iterations = fit.iterations;
  if (rejected.empty()) {
    c.box = fit.roi();
    c.center = fit.center;
    c.source = DetectionSource::kGaussianFit;
  } else {
    // Moving-region retrieval: components within the initial (half-image) ROI around the seed;
    // the heaviest one overlapping the failed ROI, else the heaviest overall.
    const cv::Rect search = box_pixels(initial, w, h);
    const std::array<Box2D, 2> rois{fit.roi(), initial};
    const auto roi_list = std::span<const Box2D>(rois).subspan(fit.empty_roi ? 1 : 0);
    std::optional<Region> region = retrieve_region(P, roi_list, search, o, in.region_scratch);
    // A region the search area cut (it reaches one of its inner edges) may be an object larger than
    // the area: labelled again over the whole image, so that its size is its own.
    auto cut_by_search = [&](const Box2D& b) {
      return (search.x > 0 && b.x0 <= search.x + 1) || (search.y > 0 && b.y0 <= search.y + 1) ||
             (search.x + search.width < w && b.x1 >= search.x + search.width - 2) ||
             (search.y + search.height < h && b.y1 >= search.y + search.height - 2);
    };
    if (region && cut_by_search(region->box)) region = retrieve_region(P, roi_list, {0, 0, w, h}, o, in.region_scratch);
    // A region larger than a plausible fit must stand out from the rest of the image in density.
    auto denser_than_the_rest = [&](const Box2D& box) {
      const cv::Rect r = box_pixels(box, w, h);
      const double inside = events_in(box), outside_px = static_cast<double>(w) * h - r.area();
      if (!(outside_px > 0)) return false;
      return inside / r.area() >= g.large_region_min_contrast * (in.window_events() - inside) / outside_px;
    };
    if (region && (region->box.width() > fit_max_w || region->box.height() > fit_max_h) &&
        !denser_than_the_rest(region->box)) {
      blank = region->box;
      in.why_not = DetectionStatus::kNoRegion;
      return std::nullopt;
    }
    if (!region || region->box.width() >= region_max_side || region->box.height() >= region_max_side) {
      if (region) {
        blank = region->box;
        // A connected moving pattern this large, with an object's evidence, is an object too near.
        Candidate large{.box = region->box, .center = region->center};
        in.fills_view = in.fills_view || passes_gates(large);
      }
      in.why_not = DetectionStatus::kNoRegion;
      return std::nullopt;
    }
    c.box = region->box;
    c.center = region->center;
    c.source = DetectionSource::kRegionRetrieval;
  }
  blank = c.box;
  if (!spans_separate_tracks(c.box, in.gates) && passes_gates(c)) return c;
  if (!(g.refit_min_roi_px > 0)) return std::nullopt;

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
  const double margin = in.theta - in.ti.mean_normalized;
  auto stands_out = [&](const Box2D& b) {
    if (!(g.refit_local_scale > 0)) return true;
    const cv::Rect r = box_pixels(b, w, h);
    const Eigen::Vector2d bc = b.center();
    const double half = g.refit_local_scale * std::max(b.width(), b.height());
    const cv::Rect around = box_pixels({bc.x() - half, bc.y() - half, bc.x() + half, bc.y() + half}, w, h);
    double s_sum = 0, n_sum = 0;
    int s_px = 0, n_px = 0;
    for (int y = around.y; y < around.y + around.height; ++y) {
      const std::int32_t* count = in.ti.count.ptr<std::int32_t>(y);
      const float* n = in.ti.normalized.ptr<float>(y);
      const float* seg = in.S.ptr<float>(y);
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
  const DetectionStatus why_first = in.why_not;
  for (Eigen::Vector2d l = 0.5 * l0; l.minCoeff() >= g.refit_min_roi_px; l *= 0.5) {
    const GaussianFit f = iterative_gaussian_fit(P, c0, l, o);
    if (!f.converged || f.size.x() > fit_max_w || f.size.y() > fit_max_h ||
        f.size.maxCoeff() > o.roi_max_aspect * f.size.minCoeff() || spans_separate_tracks(f.roi(), in.gates))
      continue;
    Candidate k;
    k.box = f.roi();
    k.center = f.center;
    k.source = DetectionSource::kGaussianFit;
    k.fit_iterations = f.iterations;
    if (passes_gates(k) && stands_out(k.box)) {
      diagnostics = {.fit_iterations = f.iterations, .fit_converged = true, .fit_rejected = {}};
      return k;
    }
  }
  in.why_not = why_first;  // the status of the paper's candidate
  return std::nullopt;
}

void GaussianFitSource::allocate(int width, int height) {
  blanked_.create(height, width, CV_32F);
  blanked_.setTo(0);
  blanked_bounds_ = {};
}

std::optional<Candidate> GaussianFitSource::find(SourceWindow& in, DetectionResult& res) {
  const DetectorOptions& o = options_;
  const int w = in.events.width, h = in.events.height;
  const cv::Mat& P = in.P;
  const cv::Rect& support = in.P_support;
  const double min_peak =
      in.first_object ? o.gaussian_fit.min_peak : std::max(o.gaussian_fit.min_peak, o.gaussian_fit.further_min_peak);
  // Algorithm 1 from the strongest pattern; a candidate that yields no plausible box or fails the
  // evidence gates is blanked and the next strongest pattern is tried. The blanking works on a
  // copy: P stays as pre-processed.
  const cv::Mat* image = &P;
  for (int attempt = 0; attempt < o.gaussian_fit.max_candidates && support.area() > 0; ++attempt) {
    const MaxLocation peak = image == &P ? in.P_max : first_maximum(*image, support);
    const double p_max = peak.value;
    const cv::Point arg_max = peak.at;
    if (!(p_max > 0) || p_max < min_peak * min_peak) break;  // none left can pass
    ++res.candidates;
    Box2D blank;
    PatternFitDiagnostics& diagnostics = res.diagnostics_of(kName).write<PatternFitDiagnostics>();
    if (auto found = evaluate_pattern(o, in, *image, arg_max, min_peak, diagnostics, blank)) return found;
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
  return std::nullopt;
}

}  // namespace fdv
