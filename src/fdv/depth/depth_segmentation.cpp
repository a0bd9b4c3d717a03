#include "fdv/depth/depth_segmentation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "fdv/core/error.h"

namespace fdv {

namespace {

bool positive_finite(double v) { return std::isfinite(v) && v > 0; }

/// std of the depths of a sphere's visible cap (orthographic, uniform over the disc): the height
/// h = sqrt(r² - ρ²) has mean 2r/3 and variance r²/2 - 4r²/9 = r²/18.
constexpr double kCapSpreadPerRadius = 0.23570226039551584;  // 1/sqrt(18)
constexpr double kCapMeanPerRadius = 2.0 / 3.0;

std::string fmt(const char* f, double a, double b = 0, double c = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b, c);
  return buf;
}

struct WindowStats {
  int count = 0;
  double mean = 0, std = 0;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  Eigen::Vector2d variance = Eigen::Vector2d::Zero();  ///< of the pixels' x and y [px²]
};

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
    case DepthRejection::kOffCentre:
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

DepthSegmentation segment_object_depth(const DepthImageView& depth, const PinholeCamera& cam,
                                       const DepthQuery& q, const DepthSegmentationOptions& o) {
  if (auto e = o.validate(); !e.empty()) throw ConfigError("DepthSegmentationOptions: " + e);
  DepthSegmentation out;
  auto reject = [&out](DepthRejection r, std::string why) {
    out.rejection = r;
    out.reason = std::move(why);
    return out;
  };
  if (depth.width <= 0 || depth.height <= 0 ||
      depth.depth_m.size() != static_cast<std::size_t>(depth.width) * depth.height)
    return reject(DepthRejection::kInvalidInput,
                  "depth buffer does not hold width x height values");
  if (depth.width != cam.width || depth.height != cam.height)
    return reject(DepthRejection::kInvalidInput,
                  "depth image is not in the event camera's grid (size differs)");
  if (!std::isfinite(q.centre_px.x()) || !std::isfinite(q.centre_px.y()) ||
      !positive_finite(q.box_size_px.x()) || !positive_finite(q.box_size_px.y()))
    return reject(DepthRejection::kInvalidInput, "box centre not finite or box size not > 0");
  const double f = std::sqrt(cam.fx * cam.fy);
  if (!positive_finite(f))
    return reject(DepthRejection::kInvalidInput, "camera focal length not > 0");

  // ROI: pixels whose centres lie inside the box scaled by roi_scale about its centre.
  const Eigen::Vector2d half = 0.5 * o.roi_scale * q.box_size_px;
  const int x0 = std::max(0, static_cast<int>(std::ceil(q.centre_px.x() - half.x())));
  const int x1 =
      std::min(depth.width - 1, static_cast<int>(std::floor(q.centre_px.x() + half.x())));
  const int y0 = std::max(0, static_cast<int>(std::ceil(q.centre_px.y() - half.y())));
  const int y1 =
      std::min(depth.height - 1, static_cast<int>(std::floor(q.centre_px.y() + half.y())));
  if (x0 > x1 || y0 > y1)
    return reject(DepthRejection::kRoiOutsideImage, "the x2 box lies outside the image");

  // Histogram of valid depths.
  const int bins = static_cast<int>(std::ceil((o.max_depth_m - o.min_depth_m) / o.bin_width_m));
  std::vector<int> hist(static_cast<std::size_t>(bins), 0);
  for (int y = y0; y <= y1; ++y) {
    const float* row = depth.depth_m.data() + static_cast<std::size_t>(y) * depth.width;
    for (int x = x0; x <= x1; ++x) {
      ++out.roi_pixels;
      const double d = row[x];
      if (!(d >= o.min_depth_m && d < o.max_depth_m)) continue;  // 0, NaN, out of range
      ++out.valid_pixels;
      ++hist[static_cast<std::size_t>(
          std::min(bins - 1, static_cast<int>((d - o.min_depth_m) / o.bin_width_m)))];
    }
  }
  if (out.valid_pixels < o.min_peak_pixels)
    return reject(DepthRejection::kTooFewValidPixels,
                  fmt("%.0f valid depth pixels of %.0f in the ROI (holes)", out.valid_pixels,
                      out.roi_pixels));
  const double threshold =
      std::max<double>(o.min_peak_pixels, o.min_peak_fraction * out.valid_pixels);
  auto h = [&](int i) { return i < 0 || i >= bins ? 0 : hist[static_cast<std::size_t>(i)]; };
  auto bin_centre = [&](int i) { return o.min_depth_m + (i + 0.5) * o.bin_width_m; };

  // Statistics of the pixels with depth in [lo, hi].
  auto window_stats = [&](double lo, double hi) {
    WindowStats s;
    double sum = 0, sum2 = 0;
    for (int y = y0; y <= y1; ++y) {
      const float* row = depth.depth_m.data() + static_cast<std::size_t>(y) * depth.width;
      for (int x = x0; x <= x1; ++x) {
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
  };

  const bool radius_known = o.object_radius_m > 0;
  const double box_radius_px = 0.5 * q.box_size_px.minCoeff();
  const double ellipse_area = std::numbers::pi / 4 * q.box_size_px.x() * q.box_size_px.y();
  int start = 0;
  for (int peak = 0; peak < o.max_peaks; ++peak) {
    // Nearest bin from `start` whose 3-bin sum is significant; the peak is the fullest of the
    // three.
    int i = start;
    while (i < bins && h(i - 1) + h(i) + h(i + 1) < threshold) ++i;
    if (i >= bins) {
      if (peak == 0)
        return reject(
            DepthRejection::kNoSignificantPeak,
            fmt("no depth peak reaches %.0f pixels (%.0f valid)", threshold, out.valid_pixels));
      break;
    }
    int p = i;
    for (int j = i - 1; j <= i + 1; ++j)
      if (j >= 0 && j < bins && h(j) > h(p)) p = j;
    double m0 = 0, n0 = 0;
    for (int j = p - 1; j <= p + 1; ++j) {
      m0 += h(j) * bin_centre(j);
      n0 += h(j);
    }
    m0 /= n0;
    ++out.peaks_tried;

    const double r_window = radius_known ? o.object_radius_m : o.default_window_radius_m;
    const double w = std::max(o.bin_width_m, r_window + o.window_sigmas * o.noise.sigma_m(m0));
    const WindowStats s = window_stats(m0 - w, m0 + w);
    start = std::max(p + 2, static_cast<int>((m0 + w - o.min_depth_m) / o.bin_width_m) + 1);

    // Object geometry at this depth.
    Eigen::Vector2d xn = cam.pixel_to_normalized(s.centroid);
    const double cos_theta = std::isfinite(xn.x()) ? 1.0 / std::sqrt(1.0 + xn.squaredNorm()) : 1.0;
    // Silhouette radius ρ px at centre depth z_c = m + 2r/3 gives r = ρ·z_c/f = ρ·m / (f − 2ρ/3).
    auto radius_at_depth = [&](double rho_px) { return rho_px * s.mean / std::max(1e-9, f - kCapMeanPerRadius * rho_px); };
    // The box's radius is for the size gate (a known radius): the tracked box is the events' box,
    // which can be a thin crescent across the motion.
    const double r_box = radius_at_depth(box_radius_px);
    // Unknown radius: from the segmented pixels themselves. A filled disc of radius ρ has variance
    // ρ²/4 along any axis, whatever fraction of its pixels the registration left as holes; the
    // larger axis, because the ROI (the box × roi_scale) may cut the disc across a thin box. The
    // box's shorter side underestimated it by ~2x on crescents (depth 4 cm short at 3 m).
    const double silhouette_px = 2.0 * std::sqrt(s.variance.maxCoeff());
    const double r = radius_known ? o.object_radius_m : radius_at_depth(silhouette_px);
    const double z_c = s.mean + kCapMeanPerRadius * r * cos_theta;
    const double sigma_z = o.noise.sigma_m(z_c);
    const double expected_spread = std::hypot(kCapSpreadPerRadius * r, o.noise.sigma_m(s.mean));

    DepthRejection why = DepthRejection::kNone;
    std::string text;
    const Eigen::Vector2d off = (s.centroid - q.centre_px).cwiseQuotient(0.5 * q.box_size_px);
    if (s.count < o.min_peak_pixels) {
      why = DepthRejection::kNoSignificantPeak;
      text = fmt("%.0f pixels in the window", s.count);
    } else if (s.std > o.spread_gate * expected_spread) {
      why = DepthRejection::kSpreadTooLarge;
      text = fmt("spread %.3f m > %.1f x expected %.3f m", s.std, o.spread_gate, expected_spread);
    } else if (s.count > o.max_fill_ratio * ellipse_area) {
      why = DepthRejection::kFootprintTooLarge;
      text =
          fmt("%.0f pixels > %.2f x box ellipse %.0f px", s.count, o.max_fill_ratio, ellipse_area);
    } else if (off.norm() > o.max_centroid_offset) {
      why = DepthRejection::kOffCentre;
      text = fmt("centroid %.2f box half-sizes from the track's centre", off.norm());
    } else if (radius_known &&
               (r_box > o.radius_ratio_gate * r || r_box * o.radius_ratio_gate < r)) {
      why = DepthRejection::kSizeInconsistent;
      text = fmt("box at this depth implies radius %.3f m, object has %.3f m", r_box, r);
    } else if (q.expected_depth_m &&
               std::abs(z_c - *q.expected_depth_m) >
                   q.expected_depth_gate_sigmas * std::hypot(sigma_z, q.expected_depth_sigma_m)) {
      why = DepthRejection::kDepthInconsistent;
      text = fmt("centre depth %.2f m, trajectory expects %.2f m", z_c, *q.expected_depth_m);
    }
    if (why == DepthRejection::kNone) {
      DepthObservation obs;
      obs.t = depth.t;
      obs.depth_m = z_c;
      obs.surface_depth_m = s.mean;
      obs.radius_m = r;
      obs.radius_estimated = !radius_known;
      const double sigma_r = radius_known ? 0.0 : o.radius_relative_sigma * r;
      obs.sigma_m =
          std::max(o.min_sigma_m, std::hypot(sigma_z, kCapMeanPerRadius * cos_theta * sigma_r));
      obs.pixel_count = s.count;
      obs.spread_m = s.std;
      obs.expected_spread_m = expected_spread;
      obs.centre_px = s.centroid;
      out.observation = obs;
      out.rejection = DepthRejection::kNone;
      return out;
    }
    if (peak == 0) out.rejection = why;
    if (!out.reason.empty()) out.reason += "; ";
    out.reason +=
        fmt("peak %.0f at %.2f m: ", peak + 1, s.mean) + to_string(why) + " (" + text + ")";
  }
  return out;
}

}  // namespace fdv
