#include "fdv/depth/depth_segmentation.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/core/numeric.h"

namespace fdv {

namespace {

/// std of the depths of a sphere's visible cap (orthographic, uniform over the disc): the height
/// h = sqrt(r² - ρ²) has mean 2r/3 and variance r²/2 - 4r²/9 = r²/18.
constexpr double kCapSpreadPerRadius = 0.23570226039551584;  // 1/sqrt(18)
constexpr double kCapMeanPerRadius = 2.0 / 3.0;

}  // namespace

const char* to_string(DepthRejection r) {
  switch (r) {
    case DepthRejection::kNone:
      return "none";
    case DepthRejection::kInvalidInput:
      return "invalid input";
    case DepthRejection::kRoiOutsideImage:
      return "ROI outside the image";
    case DepthRejection::kTooFewValidPixels:
      return "too few valid depth pixels";
    case DepthRejection::kNoSignificantPeak:
      return "no significant depth peak";
    case DepthRejection::kSpreadTooLarge:
      return "depth spread too large";
    case DepthRejection::kFootprintTooLarge:
      return "footprint too large";
    case DepthRejection::kOffCenter:
      return "segment off the track's centre";
    case DepthRejection::kSizeInconsistent:
      return "size inconsistent with the object";
    case DepthRejection::kDepthInconsistent:
      return "depth inconsistent with the trajectory";
  }
  return "?";
}

std::string DepthNoiseModel::validate() const {
  if (!positive_finite(subpixel_px) || !positive_finite(focal_px) || !positive_finite(baseline_m))
    return "noise: subpixel_px, focal_px and baseline_m must be > 0";
  return {};
}

std::string DepthSegmentationOptions::validate() const {
  if (!(roi_scale >= 1) || !std::isfinite(roi_scale)) return "roi_scale must be >= 1";
  if (!positive_finite(bin_width_m)) return "bin_width_m must be > 0";
  if (!(min_depth_m >= 0) || !(max_depth_m > min_depth_m) || !std::isfinite(max_depth_m))
    return "need 0 <= min_depth_m < max_depth_m";
  if ((max_depth_m - min_depth_m) / bin_width_m > 1e6)
    return "bin_width_m too small for the depth range";
  if (min_peak_pixels < 1) return "min_peak_pixels must be >= 1";
  if (!(min_peak_fraction >= 0 && min_peak_fraction < 1))
    return "min_peak_fraction must be in [0, 1)";
  if (max_peaks < 1) return "max_peaks must be >= 1";
  if (!positive_finite(window_sigmas)) return "window_sigmas must be > 0";
  if (!(object_radius_m >= 0) || !std::isfinite(object_radius_m))
    return "object_radius_m must be >= 0";
  if (!positive_finite(default_window_radius_m)) return "default_window_radius_m must be > 0";
  if (!positive_finite(spread_gate)) return "spread_gate must be > 0";
  if (!positive_finite(max_fill_ratio)) return "max_fill_ratio must be > 0";
  if (!positive_finite(max_centroid_offset)) return "max_centroid_offset must be > 0";
  if (!(radius_ratio_gate > 1) || !std::isfinite(radius_ratio_gate))
    return "radius_ratio_gate must be > 1";
  if (!(radius_relative_sigma >= 0) || !std::isfinite(radius_relative_sigma))
    return "radius_relative_sigma must be >= 0";
  if (!(min_sigma_m >= 0) || !std::isfinite(min_sigma_m)) return "min_sigma_m must be >= 0";
  return noise.validate();
}

PixelRect depth_roi(const DepthQuery& q, double roi_scale, int width, int height) {
  const Eigen::Vector2d half = 0.5 * roi_scale * q.box_size_px;
  PixelRect roi;
  roi.x0 = std::max(0, static_cast<int>(std::ceil(q.center_px.x() - half.x())));
  roi.x1 = std::min(width - 1, static_cast<int>(std::floor(q.center_px.x() + half.x())));
  roi.y0 = std::max(0, static_cast<int>(std::ceil(q.center_px.y() - half.y())));
  roi.y1 = std::min(height - 1, static_cast<int>(std::floor(q.center_px.y() + half.y())));
  return roi;
}

DepthHistogram depth_histogram(const DepthImageView& depth, const PixelRect& roi,
                               const DepthSegmentationOptions& o) {
  DepthHistogram h;
  h.min_depth_m = o.min_depth_m;
  h.bin_width_m = o.bin_width_m;
  const int bins = static_cast<int>(std::ceil((o.max_depth_m - o.min_depth_m) / o.bin_width_m));
  h.counts.assign(static_cast<std::size_t>(bins), 0);
  for (int y = roi.y0; y <= roi.y1; ++y) {
    const float* row = depth.depth_m.data() + static_cast<std::size_t>(y) * depth.width;
    for (int x = roi.x0; x <= roi.x1; ++x) {
      ++h.roi_pixels;
      const double d = row[x];
      if (!(d >= o.min_depth_m && d < o.max_depth_m)) continue;  // 0, NaN, out of range
      ++h.valid_pixels;
      ++h.counts[static_cast<std::size_t>(
          std::min(bins - 1, static_cast<int>((d - o.min_depth_m) / o.bin_width_m)))];
    }
  }
  return h;
}

std::optional<DepthPeak> nearest_significant_peak(const DepthHistogram& h, int from,
                                                  double threshold) {
  const int bins = h.bins();
  int i = from;
  while (i < bins && h.at(i - 1) + h.at(i) + h.at(i + 1) < threshold) ++i;
  if (i >= bins) return std::nullopt;
  int p = i;
  for (int j = i - 1; j <= i + 1; ++j)
    if (j >= 0 && j < bins && h.at(j) > h.at(p)) p = j;
  double m0 = 0, n0 = 0;
  for (int j = p - 1; j <= p + 1; ++j) {
    m0 += h.at(j) * h.bin_center_m(j);
    n0 += h.at(j);
  }
  m0 /= n0;
  return DepthPeak{p, m0};
}

namespace {

// The phases of segment_object_depth not in the header, in the order it calls them.

/// Why the inputs cannot be segmented (buffer, grid, box or focal length); nullptr when they can.
const char* invalid_input(const DepthImageView& depth, const PinholeCamera& cam,
                          const DepthQuery& q) {
  if (depth.width <= 0 || depth.height <= 0 ||
      depth.depth_m.size() != static_cast<std::size_t>(depth.width) * depth.height)
    return "depth buffer does not hold width x height values";
  if (depth.width != cam.width || depth.height != cam.height)
    return "depth image is not in the event camera's grid (size differs)";
  if (!std::isfinite(q.center_px.x()) || !std::isfinite(q.center_px.y()) ||
      !positive_finite(q.box_size_px.x()) || !positive_finite(q.box_size_px.y()))
    return "box centre not finite or box size not > 0";
  if (!positive_finite(std::sqrt(cam.fx * cam.fy))) return "camera focal length not > 0";
  return nullptr;
}

/// Pixels a 3-bin sum needs to be a significant peak: min_peak_pixels, and min_peak_fraction of
/// the ROI's valid pixels.
double peak_threshold_pixels(int valid_pixels, const DepthSegmentationOptions& o) {
  return std::max<double>(o.min_peak_pixels, o.min_peak_fraction * valid_pixels);
}

/// Half-width w of the segmentation window about the peak's depth m₀ [m]: the object's radius
/// (or default_window_radius_m) plus window_sigmas·σ(m₀), at least one bin.
double window_half_width_m(double m0, const DepthSegmentationOptions& o) {
  const double r_window = o.object_radius_m > 0 ? o.object_radius_m : o.default_window_radius_m;
  return std::max(o.bin_width_m, r_window + o.window_sigmas * o.noise.sigma_m(m0));
}

/// The first bin to search for the next peak: beyond this peak's window m₀ + w.
int next_search_bin(const DepthPeak& p, double w, const DepthSegmentationOptions& o) {
  return std::max(p.bin + 2, static_cast<int>((p.depth_m + w - o.min_depth_m) / o.bin_width_m) + 1);
}

/// The segment: the ROI's pixels with a valid depth within the window.
struct WindowStats {
  int count = 0;
  double mean = 0, std = 0;  ///< of the depths [m]
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  Eigen::Vector2d variance = Eigen::Vector2d::Zero();  ///< of the pixels' x and y [px²]
};

/// Mean, std and count of the ROI's valid depths in [lo, hi], and the centroid and variance of
/// their pixels: the paper's "mean and variance of segmented depth pixels".
WindowStats window_stats(const DepthImageView& depth, const PixelRect& roi, double lo, double hi,
                         const DepthSegmentationOptions& o) {
  WindowStats s;
  double sum = 0, sum2 = 0;
  for (int y = roi.y0; y <= roi.y1; ++y) {
    const float* row = depth.depth_m.data() + static_cast<std::size_t>(y) * depth.width;
    for (int x = roi.x0; x <= roi.x1; ++x) {
      const double d = row[x];
      if (!(d >= lo && d <= hi && d >= o.min_depth_m && d < o.max_depth_m)) continue;
      ++s.count;
      sum += d;
      sum2 += d * d;
      s.centroid += Eigen::Vector2d(x, y);
      s.variance += Eigen::Vector2d(double(x) * x, double(y) * y);
    }
  }
  if (s.count > 0) {
    s.mean = sum / s.count;
    s.std = std::sqrt(std::max(0.0, sum2 / s.count - s.mean * s.mean));
    s.centroid /= s.count;
    s.variance = (s.variance / s.count - s.centroid.cwiseProduct(s.centroid)).cwiseMax(0.0);
  }
  return s;
}

/// The sphere the segmented pixels would be, at their mean depth m.
struct ObjectGeometry {
  double cos_theta;        ///< of the centroid's ray from the optical axis
  double r_box;            ///< radius the query's box implies at this depth [m]
  double r;                ///< radius used: the known one, else from the silhouette [m]
  double z_c;              ///< centre depth m + (2/3)·r·cosθ [m]
  double sigma_z;          ///< σ(z_c) [m]
  double expected_spread;  ///< std of a sphere's visible cap plus sensor noise [m]
};

ObjectGeometry object_geometry(const WindowStats& s, const PinholeCamera& cam, const DepthQuery& q,
                               const DepthSegmentationOptions& o) {
  const double f = std::sqrt(cam.fx * cam.fy);
  ObjectGeometry g;
  Eigen::Vector2d xn = cam.pixel_to_normalized(s.centroid);
  g.cos_theta = std::isfinite(xn.x()) ? 1.0 / std::sqrt(1.0 + xn.squaredNorm()) : 1.0;
  // Silhouette radius ρ px at centre depth z_c = m + 2r/3 gives r = ρ·z_c/f = ρ·m / (f − 2ρ/3).
  auto radius_at_depth = [&](double rho_px) {
    return rho_px * s.mean / std::max(1e-9, f - kCapMeanPerRadius * rho_px);
  };
  // The box's radius is for the size gate (a known radius): the tracked box is the events' box,
  // which can be a thin crescent across the motion.
  g.r_box = radius_at_depth(0.5 * q.box_size_px.minCoeff());
  // Unknown radius: from the segmented pixels themselves. A filled disc of radius ρ has variance
  // ρ²/4 along any axis, whatever fraction of its pixels the registration left as holes; the
  // larger axis, because the ROI (the box × roi_scale) may cut the disc across a thin box.
  const double silhouette_px = 2.0 * std::sqrt(s.variance.maxCoeff());
  g.r = o.object_radius_m > 0 ? o.object_radius_m : radius_at_depth(silhouette_px);
  g.z_c = s.mean + kCapMeanPerRadius * g.r * g.cos_theta;
  g.sigma_z = o.noise.sigma_m(g.z_c);
  g.expected_spread = std::hypot(kCapSpreadPerRadius * g.r, o.noise.sigma_m(s.mean));
  return g;
}

struct GateFailure {
  DepthRejection why;
  std::string text;
};

/// The object gates, in order: enough pixels; the paper's variance gate (spread against a
/// sphere's); footprint; centroid position; size (known radius); the trajectory's expected depth.
/// The first that fails, or nothing.
std::optional<GateFailure> failed_gate(const WindowStats& s, const ObjectGeometry& g,
                                       const DepthQuery& q, const DepthSegmentationOptions& o) {
  const double ellipse_area = std::numbers::pi / 4 * q.box_size_px.x() * q.box_size_px.y();
  const Eigen::Vector2d off = (s.centroid - q.center_px).cwiseQuotient(0.5 * q.box_size_px);
  if (s.count < o.min_peak_pixels)
    return GateFailure{DepthRejection::kNoSignificantPeak,
                       fmt::format("{} pixels in the window", s.count)};
  if (s.std > o.spread_gate * g.expected_spread)
    return GateFailure{
        DepthRejection::kSpreadTooLarge,
        fmt::format("spread {:.3f} m > {:.1f} x expected {:.3f} m", s.std, o.spread_gate, g.expected_spread)};
  if (s.count > o.max_fill_ratio * ellipse_area)
    return GateFailure{
        DepthRejection::kFootprintTooLarge,
        fmt::format("{} pixels > {:.2f} x box ellipse {:.0f} px", s.count, o.max_fill_ratio, ellipse_area)};
  if (off.norm() > o.max_centroid_offset)
    return GateFailure{DepthRejection::kOffCenter,
                       fmt::format("centroid {:.2f} box half-sizes from the track's centre", off.norm())};
  if (o.object_radius_m > 0 &&
      (g.r_box > o.radius_ratio_gate * g.r || g.r_box * o.radius_ratio_gate < g.r))
    return GateFailure{
        DepthRejection::kSizeInconsistent,
        fmt::format("box at this depth implies radius {:.3f} m, object has {:.3f} m", g.r_box, g.r)};
  if (q.expected_depth_m &&
      std::abs(g.z_c - *q.expected_depth_m) >
          q.expected_depth_gate_sigmas * std::hypot(g.sigma_z, q.expected_depth_sigma_m))
    return GateFailure{
        DepthRejection::kDepthInconsistent,
        fmt::format("centre depth {:.2f} m, trajectory expects {:.2f} m", g.z_c, *q.expected_depth_m)};
  return std::nullopt;
}

/// The observation of a segment that passed every gate: centre depth z_c, and its std σ(z_c) ⊕
/// the estimated radius' contribution, floored at min_sigma_m.
DepthObservation depth_observation(TimeNs t, const WindowStats& s, const ObjectGeometry& g,
                                   const DepthSegmentationOptions& o) {
  const bool radius_known = o.object_radius_m > 0;
  DepthObservation obs;
  obs.t = t;
  obs.depth_m = g.z_c;
  obs.surface_depth_m = s.mean;
  obs.radius_m = g.r;
  obs.radius_estimated = !radius_known;
  const double sigma_r = radius_known ? 0.0 : o.radius_relative_sigma * g.r;
  obs.sigma_m =
      std::max(o.min_sigma_m, std::hypot(g.sigma_z, kCapMeanPerRadius * g.cos_theta * sigma_r));
  obs.pixel_count = s.count;
  obs.spread_m = s.std;
  obs.expected_spread_m = g.expected_spread;
  obs.center_px = s.centroid;
  return obs;
}

/// Records why the segment at peak index `peak` (0 = nearest) failed: the result carries the
/// nearest peak's rejection, and its reason lists every peak tried.
void add_failed_peak(DepthSegmentation& out, int peak, double mean_m, const GateFailure& failed) {
  if (peak == 0) out.rejection = failed.why;
  if (!out.reason.empty()) out.reason += "; ";
  out.reason += fmt::format("peak {} at {:.2f} m: ", peak + 1, mean_m) + to_string(failed.why) + " (" +
                failed.text + ")";
}

DepthSegmentation rejected(DepthSegmentation out, DepthRejection r, std::string why) {
  out.rejection = r;
  out.reason = std::move(why);
  return out;
}

}  // namespace

DepthSegmentation segment_object_depth(const DepthImageView& depth, const PinholeCamera& cam,
                                       const DepthQuery& q, const DepthSegmentationOptions& o) {
  if (auto e = o.validate(); !e.empty()) throw ConfigError("DepthSegmentationOptions: " + e);
  DepthSegmentation out;
  if (const char* why = invalid_input(depth, cam, q))
    return rejected(out, DepthRejection::kInvalidInput, why);
  const PixelRect roi = depth_roi(q, o.roi_scale, depth.width, depth.height);
  if (roi.empty())
    return rejected(out, DepthRejection::kRoiOutsideImage, "the x2 box lies outside the image");
  const DepthHistogram hist = depth_histogram(depth, roi, o);
  out.roi_pixels = hist.roi_pixels;
  out.valid_pixels = hist.valid_pixels;
  if (out.valid_pixels < o.min_peak_pixels)
    return rejected(out, DepthRejection::kTooFewValidPixels,
                    fmt::format("{} valid depth pixels of {} in the ROI (holes)", out.valid_pixels,
                        out.roi_pixels));
  const double threshold = peak_threshold_pixels(out.valid_pixels, o);
  int from = 0;  // peaks from near to far, each search beyond the previous peak's window
  for (int peak = 0; peak < o.max_peaks; ++peak) {
    const std::optional<DepthPeak> p = nearest_significant_peak(hist, from, threshold);
    if (!p && peak == 0)
      return rejected(
          out, DepthRejection::kNoSignificantPeak,
          fmt::format("no depth peak reaches {:.0f} pixels ({} valid)", threshold, out.valid_pixels));
    if (!p) break;
    ++out.peaks_tried;
    const double w = window_half_width_m(p->depth_m, o);
    const WindowStats s = window_stats(depth, roi, p->depth_m - w, p->depth_m + w, o);
    from = next_search_bin(*p, w, o);
    const ObjectGeometry g = object_geometry(s, cam, q, o);
    const std::optional<GateFailure> failed = failed_gate(s, g, q, o);
    if (!failed) {
      out.observation = depth_observation(depth.t, s, g, o);
      out.rejection = DepthRejection::kNone;
      return out;
    }
    add_failed_peak(out, peak, s.mean, *failed);
  }
  return out;
}

}  // namespace fdv
