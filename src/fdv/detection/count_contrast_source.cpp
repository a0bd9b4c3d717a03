#include "fdv/detection/count_contrast_source.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace fdv {

std::string CountContrastSourceOptions::validate() const {
  for (double v : {surround_scale, min_contrast, min_fill})
    if (!std::isfinite(v)) return "non-finite detector parameter";
  std::ostringstream why;
  if (!(box_px >= 1 && box_px % 2 == 1 && box_px <= 31))
    why << "count_contrast_box_px must be odd in [1, 31], got " << box_px;
  else if (!(surround_scale > 1 && surround_scale <= 10))
    why << "count_contrast_surround_scale must be in (1, 10], got " << surround_scale;
  else if (!(min_contrast >= 1)) why << "count_contrast_min_contrast must be at least 1, got " << min_contrast;
  else if (!(min_fill >= 0 && min_fill <= 1)) why << "count_contrast_min_fill must be in [0, 1], got " << min_fill;
  else if (!(still_motion >= 0 && std::isfinite(still_motion)))
    why << "count_contrast_still_motion must be finite and at least 0, got " << still_motion;
  else if (!(still_min_isolation >= 1 && std::isfinite(still_min_isolation)))
    why << "count_contrast_still_isolation must be finite and at least 1, got " << still_min_isolation;
  else if (!(still_min_motion_z >= 0 && std::isfinite(still_min_motion_z)))
    why << "count_contrast_still_motion_z must be finite and at least 0, got " << still_min_motion_z;
  else if (!(sparse_chance >= 0 && sparse_chance < 1))
    why << "count_contrast_sparse_chance must be in [0, 1), got " << sparse_chance;
  return why.str();
}

namespace {

/// The Wald statistic of an object's motion within the window: the events in `box` give the least
/// squares slopes of their pixel's x and of its y on their time, b = cov(x, t) / var(t), each with
/// its standard error √(residual variance / (n var(t))); z = √((b_x / se_x)² + (b_y / se_y)²).
/// A still pattern, whatever its time profile, has slopes near 0; a moving one, its image velocity.
double motion_z(const CompensatedEventsView& events, const cv::Rect& box) {
  const int width = events.width;
  double n = 0, st = 0, stt = 0, sx = 0, sxx = 0, sxt = 0, sy = 0, syy = 0, syt = 0;
  for (std::size_t i = 0; i < events.pixel.size(); ++i) {
    const int x = events.pixel[i] % width, y = events.pixel[i] / width;
    if (!box.contains(cv::Point(x, y))) continue;
    const double t = events.t_s[i];
    n += 1;
    st += t, stt += t * t;
    sx += x, sxx += static_cast<double>(x) * x, sxt += x * t;
    sy += y, syy += static_cast<double>(y) * y, syt += y * t;
  }
  if (n < 3) return 0;
  const double var_t = stt / n - (st / n) * (st / n);
  if (!(var_t > 0)) return 0;
  auto slope_over_error = [&](double s, double ss, double s_t) {
    const double cov = s_t / n - (s / n) * (st / n);
    const double residual = std::max(ss / n - (s / n) * (s / n) - cov * cov / var_t, 0.0);
    const double b = cov / var_t;
    if (residual > 0) return b / std::sqrt(residual / (n * var_t));
    return b == 0 ? 0.0 : std::numeric_limits<double>::infinity();  // exact motion
  };
  return std::hypot(slope_over_error(sx, sxx, sxt), slope_over_error(sy, syy, syt));
}

}  // namespace

int fewest_unlikely_active(int n, double p, double centers, double chance) {
  if (!(p > 0)) return 1;
  if (!(p < 1)) return n + 1;
  // The tail from the top down, each term from its log (n ≤ 961: no overflow, no underflow that matters).
  const double log_p = std::log(p), log_q = std::log1p(-p);
  double tail = 0;
  for (int m = n; m >= 1; --m) {
    tail += std::exp(std::lgamma(n + 1.0) - std::lgamma(m + 1.0) - std::lgamma(n - m + 1.0) + m * log_p +
                     (n - m) * log_q);
    if (centers * tail > chance) return m + 1;
  }
  return 1;
}

void CountTables::allocate(int width, int height) {
  saturated8_.create(height, width, CV_8U);
  active8_.create(height, width, CV_8U);
  saturated_integral_.create(height + 1, width + 1, CV_32S);
  active_integral_.create(height + 1, width + 1, CV_32S);
  fired_integral_.create(height + 1, width + 1, CV_32S);
  // Touched here, so that the first window's writes do not fault every page in.
  for (cv::Mat* m : {&saturated8_, &active8_, &saturated_integral_, &active_integral_, &fired_integral_}) m->setTo(0);
}

void CountTables::reset(const TimeImages& ti, int min_pixel_events) {
  ti_ = &ti;
  min_pixel_events_ = min_pixel_events;
  active_built_ = saturated_built_ = fired_built_ = false;
}

const cv::Mat& CountTables::active() {
  if (!active_built_) {
    cv::compare(ti_->count, min_pixel_events_ - 1, active8_, cv::CMP_GT);  // 255 where active
    cv::integral(active8_, active_integral_, CV_32S);
    active_built_ = true;
  }
  return active_integral_;
}

const cv::Mat& CountTables::fired() {
  if (!fired_built_) {
    cv::compare(ti_->count, 0, active8_, cv::CMP_GT);  // 255 where any event; active8_ is scratch
    cv::integral(active8_, fired_integral_, CV_32S);
    fired_built_ = true;
  }
  return fired_integral_;
}

const cv::Mat& CountTables::saturated() {
  if (!saturated_built_) {
    ti_->count.convertTo(saturated8_, CV_8U);
    cv::integral(saturated8_, saturated_integral_, CV_32S);
    saturated_built_ = true;
  }
  return saturated_integral_;
}

void CountContrastSource::allocate(int width, int height) {
  tables_.allocate(width, height);
  live_blocks_.reserve(static_cast<std::size_t>(width));
  excess_.create(height, width, CV_32F);
  excess_.setTo(0);
  excess_bounds_ = {};
}

std::optional<Candidate> CountContrastSource::find(SourceWindow& in, DetectionResult& res) {
  const CountContrastSourceOptions& cc = options_.count_contrast;
  SourceDiagnostics& diagnostics = res.diagnostics_of(kName);
  tables_.reset(in.ti, options_.min_pixel_events);
  // The tracks' gates (where the track is the evidence of motion), then the whole image. The sparse
  // search also looks in the gates of tentative tracks: a far ball's sparse blob passes the motion
  // test in a few windows only, and from its first detection on the gate carries its track.
  auto search = [&](Activity activity) -> std::optional<Candidate> {
    auto in_gates = [&](std::span<const Box2D> gates) -> std::optional<Candidate> {
      for (const Box2D& gate : gates) {
        auto found = find_in(in, box_pixels(gate, in.events.width, in.events.height), true, activity, diagnostics);
        if (found && gate.contains(found->center)) {
          res.track_aided = true;
          return found;
        }
      }
      return std::nullopt;
    };
    std::optional<Candidate> found;
    if (cc.in_gates) found = in_gates(in.gates);
    if (!found && activity.sparse) found = in_gates(in.tentative_gates);
    if (!found && in.first_object)
      found = find_in(in, {0, 0, in.events.width, in.events.height}, false, activity, diagnostics);
    return found;
  };
  std::optional<Candidate> found = search({.sparse = false, .min_fill = cc.min_fill});
  const bool sparse_has_place = in.first_object || !in.tentative_gates.empty() || (cc.in_gates && !in.gates.empty());
  if (!found && cc.sparse_chance > 0 && sparse_has_place && camera_still(in)) {
    const int min_active = sparse_min_active(in.ti);
    diagnostics.write<CountContrastDiagnostics>().sparse_min_active = min_active;
    const double center_box_pixels = static_cast<double>(cc.box_px) * cc.box_px;
    found = search({.sparse = true, .min_fill = min_active / center_box_pixels});
  }
  return found;
}

bool CountContrastSource::camera_still(const SourceWindow& in) const {
  const DetectorOptions& o = options_;
  const double camera_motion =
      o.threshold_a_s_per_rad * in.events.omega_rad_s + o.threshold_b_s_per_m * in.events.speed_m_s;
  return o.count_contrast.still_motion > 0 && camera_motion <= o.count_contrast.still_motion;
}

int CountContrastSource::sparse_min_active(const TimeImages& ti) {
  const int w = ti.count.cols, h = ti.count.rows, k = options_.count_contrast.box_px;
  const double fired_pixels = tables_.fired().at<std::int32_t>(h, w) / 255.0;
  return fewest_unlikely_active(k * k, fired_pixels / (static_cast<double>(w) * h), static_cast<double>(w) * h,
                                options_.count_contrast.sparse_chance);
}

std::optional<Candidate> CountContrastSource::find_in(const SourceWindow& in, const cv::Rect& search, bool in_gate,
                                                      Activity activity, SourceDiagnostics& out) {
  const DetectorOptions& o = options_;
  const CountContrastSourceOptions& cc = o.count_contrast;
  const TimeImages& ti = in.ti;
  const int w = ti.count.cols, h = ti.count.rows;
  const int k = cc.box_px, hk = k / 2;
  const int hs = static_cast<int>(std::lround(0.5 * cc.surround_scale * k));
  // Centres whose surround lies in the image: the contrast needs the whole surround (and the
  // image's border is where compensation is worst: content enters and leaves there).
  const cv::Rect area = search & cv::Rect(hs, hs, w - 2 * hs, h - 2 * hs);
  if (area.area() <= 0 || ti.events <= 0 || !(ti.t_max_s > ti.t_min_s)) return std::nullopt;
  CountContrastDiagnostics& diagnostics = out.write<CountContrastDiagnostics>();
  // The active pixels' table covers the whole image: the surround of a centre near the search
  // area's border reaches outside it.
  const bool sparse = activity.sparse;
  const cv::Mat& active = sparse ? tables_.fired() : tables_.active();
  const double min_fill = activity.min_fill;
  auto box_sum = [](const cv::Mat& sat, int x, int y, int width, int height) {
    return static_cast<double>(sat.at<std::int32_t>(y + height, x + width) - sat.at<std::int32_t>(y, x + width) -
                               sat.at<std::int32_t>(y + height, x) + sat.at<std::int32_t>(y, x));
  };
  // Σ of I saturated at 255 over a box (8-bit counts: a hot pixel weighs as 255 events). Few centres
  // pass the fill test (~100 of 280 k on a textured 5 M ev/s window), so their sums are taken
  // directly, until the pixels they read pass the image's: then the whole image's table is cheaper
  // and is built. Both give the same integers.
  const double pixels_per_centre = static_cast<double>(k) * k + static_cast<double>(2 * hs + 1) * (2 * hs + 1);
  const int direct_sums = static_cast<int>(static_cast<double>(w) * h / pixels_per_centre);
  int filled = 0;  // centres that pass the fill test
  Box2D filled_span{1e300, 1e300, -1e300, -1e300};  // their extent
  auto count_sum = [&](int x, int y, int width, int height) {
    if (tables_.has_saturated() || filled > direct_sums) return box_sum(tables_.saturated(), x, y, width, height);
    std::int32_t sum = 0;
    for (int r = y; r < y + height; ++r) {
      const std::int32_t* row = ti.count.ptr<std::int32_t>(r) + x;
      for (int c = 0; c < width; ++c) sum += std::min(row[c], 255);
    }
    return static_cast<double>(sum);
  };
  // The background level: the image's mean events per pixel, the floor of the surround's density
  // (an empty surround must not make any small cluster "infinitely" dense).
  const double image_density = in.window_events() / (static_cast<double>(w) * h);
  double best = 0;
  cv::Point at(-1, -1);
  double best_fill = 0, best_surround = 0;
  // Both boxes lie in the image (hs > hk since surround_scale > 1).
  const double center_area = static_cast<double>(k) * k;
  const double ring_area = static_cast<double>(2 * hs + 1) * (2 * hs + 1) - center_area;
  // Centres in raster order (the first best wins ties), in bands of kBlock rows cut into blocks of
  // kBlock columns: a block whose centres' boxes together hold too few active pixels for any one of
  // them to pass the fill test is skipped whole (each box's fill ≤ the union's; exact).
  constexpr int kBlock = 8;
  std::vector<int>& live = live_blocks_;  // this band's blocks that may hold a passing centre
  for (int y0 = area.y; y0 < area.y + area.height; y0 += kBlock) {
    const int rows = std::min(kBlock, area.y + area.height - y0);
    live.clear();
    for (int x0 = area.x; x0 < area.x + area.width; x0 += kBlock) {
      const int cols = std::min(kBlock, area.x + area.width - x0);
      const double union_fill = box_sum(active, x0 - hk, y0 - hk, cols + 2 * hk, rows + 2 * hk) / (255.0 * center_area);
      if (!(union_fill < min_fill)) live.push_back(x0);
    }
    for (int y = y0; y < y0 + rows && !live.empty(); ++y) {
      for (const int x0 : live) {
        for (int x = x0; x < std::min(x0 + kBlock, area.x + area.width); ++x) {
          const double fill = box_sum(active, x - hk, y - hk, k, k) / (255.0 * center_area);
          if (fill < min_fill) continue;
          ++filled;
          filled_span.x0 = std::min<double>(filled_span.x0, x), filled_span.x1 = std::max<double>(filled_span.x1, x);
          filled_span.y0 = std::min<double>(filled_span.y0, y), filled_span.y1 = std::max<double>(filled_span.y1, y);
          // Scattered events seldom fill a sparse box anywhere: over the image, filled centres beyond
          // one surround square are a second blob, and the background is not scattered noise (the
          // texture of a hovering camera fires in clumps). Nothing is reported; the scan stops
          // here. A track's gate is searched for its best blob all the same.
          if (sparse && !in_gate && std::max(filled_span.width(), filled_span.height()) > 2 * hs) return std::nullopt;
          const double inner = count_sum(x - hk, y - hk, k, k);
          const double surround = (count_sum(x - hs, y - hs, 2 * hs + 1, 2 * hs + 1) - inner) / ring_area;
          const double contrast = inner / center_area / std::max(surround, image_density);
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
  if (!sparse) {  // the diagnostics are the dense search's
    diagnostics.contrast = best;
    diagnostics.fill = best_fill;
    diagnostics.filled_centers = filled;
  }
  if (at.x < 0 || best < cc.min_contrast) return std::nullopt;
  // The blob's box: Algorithm 1 on the events above the surround's level, I − max(surround, mean),
  // within the surround square around the densest centre (zero elsewhere), from that square.
  const double level = std::max(best_surround, image_density);
  const cv::Rect outer = cv::Rect(at.x - hs, at.y - hs, 2 * hs + 1, 2 * hs + 1) & cv::Rect(0, 0, w, h);
  zero_rect(excess_, excess_bounds_);
  cv::Mat excess = excess_(outer);
  ti.count(outer).convertTo(excess, CV_32F, 1.0, -level);
  cv::max(excess, 0.0, excess);
  excess_bounds_ = outer;
  const GaussianFit f = iterative_gaussian_fit(excess_, Eigen::Vector2d(at.x, at.y),
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
  cand.events = static_cast<int>(cv::sum(ti.count(box))[0]);
  cand.event_density = static_cast<double>(cand.events) / box.area();
  // A sparse blob is below the density gate by construction; the still-camera test stands for it.
  if (cand.events < o.roi_min_events || (!sparse && cand.event_density < o.min_event_density)) return std::nullopt;
  // Its events must not follow the background's time profile: their mean time stands out from all
  // events' by θ's margin a‖ω‖ + b‖v‖ + c, in N's units (the margin by which a pixel of S stands out
  // from mean(N)); early or late, since a late burst of background events (a jerk of the camera)
  // moves the image's mean time, not the object's.
  cand.t_mean_s = cv::sum(ti.sum_time_s(box))[0] / cand.events;
  const std::span<const float> all_t = in.events.window_t_s;
  const double image_t_mean_s = all_t.empty() ? cv::sum(ti.sum_time_s)[0] / ti.events
                                              : std::accumulate(all_t.begin(), all_t.end(), 0.0) / static_cast<double>(all_t.size());
  diagnostics.time_offset = (cand.t_mean_s - image_t_mean_s) / (ti.t_max_s - ti.t_min_s);
  const bool passes = sparse ? still_camera_object(in, cand, box, image_density, in_gate, diagnostics)
                              : in_gate || std::abs(diagnostics.time_offset) >= in.theta - ti.mean_normalized ||
                                    still_camera_object(in, cand, box, image_density, false, diagnostics);
  if (!passes) return std::nullopt;
  cand.score = 1.0 - 1.0 / best;  // the fraction of the centre's events above the background level
  return cand;
}

bool CountContrastSource::still_camera_object(const SourceWindow& in, const Candidate& cand, const cv::Rect& box,
                                              double image_density, bool in_gate,
                                              CountContrastDiagnostics& diagnostics) const {
  const CountContrastSourceOptions& cc = options_.count_contrast;
  if (!camera_still(in)) return false;
  diagnostics.isolation = isolation(in.ti.count, box, cand.events, image_density);
  if (!(diagnostics.isolation >= cc.still_min_isolation)) return false;
  if (in_gate) return true;  // a track's gate: its track is the evidence of motion
  diagnostics.motion_z = motion_z(in.events, box);
  return diagnostics.motion_z >= cc.still_min_motion_z;
}

}  // namespace fdv
