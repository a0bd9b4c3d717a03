#include "fdv/detection/event_refinement.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "fdv/core/lanes.h"
#include "fdv/detection/gaussian_fit.h"

namespace fdv {
namespace {

/// The events' pixels are tested for a rectangle's columns in float: exact while the band of rows
/// holds fewer pixels than this (the row's error stays below half a pixel's share of the row).
constexpr std::uint32_t kMaxBandForColumns = 1u << 22;

/// What bin_slice() bins of the rectangle `r` of a w-wide image: its columns, or its whole rows
/// when it spans more than half of them (the column test costs more per event than blanking the
/// rest of the rows saves) or they hold kMaxBandForColumns pixels or more.
cv::Rect binned_part(const cv::Rect& r, int w) {
  const bool columns =
      2 * r.width <= w &&
      static_cast<std::uint32_t>(r.height) * static_cast<std::uint32_t>(w) < kMaxBandForColumns;
  return columns ? r : cv::Rect(0, r.y, w, r.height);
}

/// The refinement's scan: the events k in [begin, end) in `part` (a binned_part() of a w-wide
/// image) whose time lies in [t_lo, t_hi] are added to acc (per pixel: count, Σt; row-major, w
/// wide), in event order. Events in and out of it alternate in no pattern, so a branch per event
/// mispredicts (docs/DETECTION.md, "Tuning"): the tests run four events at a time and write the
/// passing ones to a short list, branch-free; then the list is added in order. A pixel index d's
/// column is found in float, x = d − ⌊(d + ½)/w⌋·w: no integer division.
void bin_slice(const std::int32_t* __restrict pixel, const float* __restrict t_s, std::size_t begin,
               std::size_t end, std::uint32_t w, const cv::Rect& part, float t_lo, float t_hi,
               float* __restrict acc) {
  using lanes::vf;
  using lanes::vi;
  using vu = std::uint32_t __attribute__((vector_size(16)));
  typedef std::uint32_t vu_u __attribute__((vector_size(16), aligned(4)));
  const bool columns = part.width < static_cast<int>(w);
  const std::uint32_t first = static_cast<std::uint32_t>(part.y) * w,
                      band = static_cast<std::uint32_t>(part.height) * w;
  const std::uint32_t x0 = static_cast<std::uint32_t>(part.x),
                      x1 = x0 + static_cast<std::uint32_t>(part.width);
  const vu first_v = vu{} + first, band_v = vu{} + band;
  const vf lo = vf{} + t_lo, hi = vf{} + t_hi;
  const vf wf = vf{} + static_cast<float>(w), inv_w = vf{} + 1.0f / static_cast<float>(w);
  const vf x0f = vf{} + static_cast<float>(x0), x1f = vf{} + static_cast<float>(x1);
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
      vi pass = (d < band_v) & (t >= lo) & (t <= hi);
      if (columns) {  // exact where d < band (kMaxBandForColumns); other lanes failed above
        const vf df = __builtin_convertvector(reinterpret_cast<const vi&>(d), vf);
        const vf row =
            __builtin_convertvector(__builtin_convertvector((df + 0.5f) * inv_w, vi), vf);
        const vf x = df - row * wf;
        pass &= (x >= x0f) & (x < x1f);
      }
      for (int j = 0; j < 4; ++j) {
        at[n] = d[j];
        time[n] = t[j];
        n += static_cast<std::size_t>(pass[j] & 1);
      }
    }
    for (; k < chunk_end; ++k) {
      const std::uint32_t d = static_cast<std::uint32_t>(pixel[k]) - first;
      const float t = t_s[k];
      const std::uint32_t x = d % w;
      at[n] = d;
      time[n] = t;
      n += d < band && x >= x0 && x < x1 && t >= t_lo && t <= t_hi;
    }
    for (std::size_t i = 0; i < n; ++i) {
      float* a = acc + 2 * (static_cast<std::size_t>(first) + at[i]);
      a[0] += 1.0f;
      a[1] += time[i];
    }
  }
}

/// Σ count and Σ count·x over the pixels [x0, x1) of one row of the refinement's accumulator
/// (count, Σt per pixel). The counts are whole numbers below 2^24 and x below 2^16, so every
/// partial sum is an integer below 2^53: exact in any order. Two pixels per double vector and two
/// vectors per step, then, where one chain of dependent scalar additions was the refinement's main
/// cost.
struct RowMoments {
  double n = 0, sx = 0;
};
FDV_AVX2_CLONES RowMoments row_moments(const float* __restrict acc, int x0, int x1) {
  using v2d = double __attribute__((vector_size(16)));
  v2d n_lo{}, n_hi{}, sx_lo{}, sx_hi{};
  v2d x_lo{static_cast<double>(x0), static_cast<double>(x0 + 1)};
  v2d x_hi = x_lo + 2.0;
  int x = x0;
  for (; x + 4 <= x1; x += 4) {
    const float* p = acc + 2 * static_cast<std::ptrdiff_t>(x);
    const v2d c_lo{p[0], p[2]}, c_hi{p[4], p[6]};
    n_lo += c_lo;
    n_hi += c_hi;
    sx_lo += c_lo * x_lo;
    sx_hi += c_hi * x_hi;
    x_lo += 4.0;
    x_hi += 4.0;
  }
  const v2d n = n_lo + n_hi, sx = sx_lo + sx_hi;
  RowMoments out{n[0] + n[1], sx[0] + sx[1]};
  for (; x < x1; ++x) {
    const double count = acc[2 * x];
    out.n += count;
    out.sx += count * x;
  }
  return out;
}

}  // namespace

void EventRefiner::allocate(int width, int height) {
  acc_.create(height, width, CV_32FC2);
  acc_.setTo(0);  // every page faulted in here, not in the first window with a detection
  if (options_.refine_fit_outline) warm_up_outline_fit();
}

// cv::fitEllipseDirect falls back, for a point set with no elliptical solution, to a fit through
// OpenCV's SVD, which runs LAPACK. Its first call in a process binds the LAPACK symbols and faults
// in their code: 1-5 ms once, measured in the first window of the DAVIS346 recording
// (docs/BENCHMARKS.md, "No cold first window"). Both paths run once here, the fallback's own calls
// on systems of its shapes (n x 5 decomposed and back-substituted; n x 3 and 2 x 2 solved).
void EventRefiner::warm_up_outline_fit() {
  std::vector<cv::Point2f> circle;
  for (int i = 0; i < 16; ++i)
    circle.emplace_back(static_cast<float>(8 + 5 * std::cos(0.4 * i)), static_cast<float>(8 + 4 * std::sin(0.4 * i)));
  (void)cv::fitEllipseDirect(circle);
  cv::Mat a(64, 5, CV_64F), b(64, 1, CV_64F, cv::Scalar(1)), w, u, vt, x;
  for (int i = 0; i < a.rows; ++i)
    for (int j = 0; j < a.cols; ++j) a.at<double>(i, j) = std::sin(1.0 + 0.7 * i + 1.3 * j * j);
  cv::SVDecomp(a, w, u, vt);
  cv::SVBackSubst(w, u, vt, b, x);
  cv::solve(a.colRange(0, 3), b, x, cv::DECOMP_SVD);
  cv::solve(a(cv::Rect(0, 0, 2, 2)), b.rowRange(0, 2), x, cv::DECOMP_SVD);
}

// The object's edges make events in proportion to the pixels they sweep: a ball that comes closer
// as it moves sweeps more with its leading edge (growth plus motion) than with its trailing one
// (their difference), and its events' centroid lies ahead of its centre. Each pixel with an event
// counts once for the ellipse (cv::fitEllipseDirect, least squares on the conic), so the outline's
// shape, not its event rate, places the centre. Kept when it is a plausible outline of the object:
// its centre within half the extent of the centroid's, its longer axis within [0.5, 2] × the extent.
std::optional<Eigen::Vector2d> EventRefiner::outline_center(const cv::Rect& square, const Eigen::Vector2d& centroid,
                                                            double extent) const {
  std::vector<cv::Point2f> lit;
  for (int y = square.y; y < square.y + square.height; ++y) {
    const float* acc = acc_.ptr<float>(y);
    for (int x = square.x; x < square.x + square.width; ++x)
      if (acc[2 * x] > 0) lit.emplace_back(static_cast<float>(x), static_cast<float>(y));
  }
  if (lit.size() < 6) return std::nullopt;  // fewer points than a conic needs, with one to spare
  const cv::RotatedRect ellipse = cv::fitEllipseDirect(lit);
  const Eigen::Vector2d center(ellipse.center.x, ellipse.center.y);
  const double axis = std::max(ellipse.size.width, ellipse.size.height);
  if (!center.allFinite() || (center - centroid).norm() > 0.5 * extent || !(axis > 0.5 * extent && axis < 2 * extent))
    return std::nullopt;
  return center;
}

std::optional<RefinedCenter> EventRefiner::refine(const CompensatedEventsView& window, const Box2D& box,
                                                  double t_box_s) {
  // A time slice symmetric about the box's mean event time, as wide as the window allows, and a
  // region large enough to hold the object throughout that slice: the object's events in it are
  // then complete, and their centroid is the object's position at their mean time (exact for
  // constant image velocity and a time-uniform event rate).
  const double duration_s = to_seconds(window.t_end - window.t_start);
  const double tau = std::min(t_box_s, duration_s - t_box_s);
  if (!(tau > 0)) return std::nullopt;
  const float t_lo = static_cast<float>(t_box_s - tau), t_hi = static_cast<float>(t_box_s + tau);
  const Eigen::Vector2d c = box.center();
  // Square: the segmented sweep can be a thin crescent across the motion, while the object
  // extends along it as well.
  const double longer_side = std::max(box.width(), box.height());
  const double initial_half = 0.5 * options_.refine_box_scale * longer_side;
  double half = initial_half;
  // A box on a fragment of a large object (part of its crescent) gives a square that cuts the
  // object: its events go on past the square's edge. The square then grows by kGrowth, up to an
  // object of fills_view_fraction × the shorter side, while a side of the band just outside it is
  // at least refine_grow_density × as dense as the square and refine_grow_contrast × the image's
  // mean (docs/DETECTION.md, "A box on a fragment grows").
  constexpr double kGrowth = 1.5;
  const double max_half = 0.5 * options_.refine_box_scale * options_.fills_view_fraction *
                          std::min(window.width, window.height);
  const std::int32_t w = window.width;
  CV_Assert(acc_.isContinuous() && acc_.cols == window.width);
  // Time-ordered windows (the compensators keep the input's order): only the slice is scanned.
  std::size_t begin = 0, end = std::min(window.pixel.size(), window.t_s.size());
  if (window.time_sorted) {
    const auto t_begin = window.t_s.begin();
    begin = static_cast<std::size_t>(std::lower_bound(t_begin, t_begin + static_cast<std::ptrdiff_t>(end), t_lo) - t_begin);
    end = static_cast<std::size_t>(std::upper_bound(t_begin, t_begin + static_cast<std::ptrdiff_t>(end), t_hi) - t_begin);
  }
  // The slice's mean density over the image: the band must stand out from it as an object does.
  // Of the whole window's events when only a part was searched (CompensatedEventsView::window_t_s).
  const std::span<const float> all_t = window.window_t_s;
  const double slice_events =
      all_t.empty() ? (window.time_sorted ? static_cast<double>(end - begin)
                                          : static_cast<double>(end) * 2 * tau / duration_s)
                    : (window.time_sorted ? static_cast<double>(std::upper_bound(all_t.begin(), all_t.end(), t_hi) -
                                                                std::lower_bound(all_t.begin(), all_t.end(), t_lo))
                                          : static_cast<double>(all_t.size()) * 2 * tau / duration_s);
  const double slice_density = slice_events / (static_cast<double>(window.width) * window.height);
  auto square = [&](const Eigen::Vector2d& at, double half_side) {
    return box_pixels({at.x() - half_side, at.y() - half_side, at.x() + half_side, at.y() + half_side}, window.width,
                      window.height);
  };
  auto events_in = [&](const cv::Rect& r) {
    double sum = 0;
    for (int y = r.y; y < r.y + r.height; ++y)
      sum += row_moments(acc_.ptr<float>(y), r.x, r.x + r.width).n;
    return sum;
  };
  std::optional<RefinedCenter> refined;
  // The mean time of `refined`'s square and the outline's fit of it are made only when `refined` is
  // returned: a square that grows is measured again, and a fit costs 0.05-0.2 ms. Its pixels are
  // binned alike until then: a grown pass bins the same slice over a superset of the last pass's
  // area.
  cv::Rect refined_square;
  long refined_events = 0;
  struct OutlineFit {
    cv::Rect square;
    Eigen::Vector2d centroid;
    double extent;
  };
  std::optional<OutlineFit> pending_fit;
  auto result = [&]() {
    if (!refined) return refined;
    // Σt in raster order: floats summed in double, so the order is kept.
    double st = 0;
    for (int y = refined_square.y; y < refined_square.y + refined_square.height; ++y) {
      const float* acc = acc_.ptr<float>(y);
      for (int x = refined_square.x; x < refined_square.x + refined_square.width; ++x)
        st += acc[2 * x + 1];
    }
    refined->t_mean_s = st / static_cast<double>(refined_events);
    if (pending_fit)
      if (const auto outline =
              outline_center(pending_fit->square, pending_fit->centroid, pending_fit->extent))
        refined->center = *outline;
    return refined;
  };
  Eigen::Vector2d center = c;
  for (;;) {
    // The clutter guard below keeps the centre within the object's size (one box size, or the
    // grown square's) of the box's centre: the squares of all passes, and the band around the
    // last, lie inside `outer`, whose slice events are binned once per pixel (count, Σt).
    const double reach = longer_side * half / initial_half;
    const double band_half = kGrowth * half;
    const cv::Rect outer = square(c, reach + band_half);
    if (outer.area() == 0) return result();
    // What bin_slice() writes of outer, blanked first.
    const cv::Rect binned = binned_part(outer, w);
    for (int y = binned.y; y < binned.y + binned.height; ++y)
      std::fill_n(acc_.ptr<float>(y) + 2 * binned.x, 2 * static_cast<std::size_t>(binned.width),
                  0.0f);
    bin_slice(window.pixel.data(), window.t_s.data(), begin, end, static_cast<std::uint32_t>(w),
              binned, t_lo, t_hi, acc_.ptr<float>(0));
    // Mean shift with a flat square kernel: the square starts on the box, whose centre lies ahead of
    // the object (the box holds the latest sweep), and residual background events inside it pull the
    // centroid towards that centre. Re-centring the square on the centroid removes the pull: the
    // fixed point is the square centred on the object's events.
    double sx = 0, sy = 0;
    long n = 0;
    cv::Rect e;
    for (int pass = 0; pass <= options_.refine_recenter_passes; ++pass) {
      e = square(center, half) & outer;
      if (e.area() == 0) return result();
      sx = sy = 0;
      n = 0;
      for (int y = e.y; y < e.y + e.height; ++y) {
        const RowMoments row = row_moments(acc_.ptr<float>(y), e.x, e.x + e.width);
        n += static_cast<long>(row.n);
        sx += row.sx;
        sy += row.n * y;
      }
      if (n < options_.roi_min_events) return result();
      const Eigen::Vector2d next = Eigen::Vector2d(sx, sy) / static_cast<double>(n);
      const bool settled = (next - center).norm() < 0.25;
      center = next;
      // Clutter guard: the object was inside the box at the end of its sweep, so within the slice
      // its centre is at most about its size away; a centroid further off is background.
      if ((center - c).norm() > reach) return result();
      if (settled) break;
    }
    // Grown, the object's radius lies between the previous half-side (its band was dense) and this
    // one (its band is not): the extent is their geometric mean, doubled.
    const double extent = half > initial_half ? 2 * half / std::sqrt(kGrowth) : longer_side;
    refined = RefinedCenter{center, 0.0, extent};  // its mean time: result()
    refined_square = e;
    refined_events = n;
    // Not for an object cut by the border: its centre is the visible part's, which the outline's
    // ellipse is not.
    const bool in_view = center.x() - half >= 0 && center.y() - half >= 0 && center.x() + half <= window.width &&
                         center.y() + half <= window.height;
    pending_fit.reset();
    if (half > initial_half && options_.refine_fit_outline && in_view)
      pending_fit = OutlineFit{e, center, extent};
    if (!(options_.refine_grow_density > 0) || kGrowth * half > max_half) return result();
    // The band's four sides, each alone: the centroid lags towards the fragment, so the object's
    // far part shows in the side facing it.
    const cv::Rect band = square(center, band_half) & outer;
    const cv::Rect sides[] = {{band.x, band.y, e.x - band.x, band.height},
                              {e.x + e.width, band.y, band.x + band.width - e.x - e.width, band.height},
                              {e.x, band.y, e.width, e.y - band.y},
                              {e.x, e.y + e.height, e.width, band.y + band.height - e.y - e.height}};
    double band_density = 0;
    for (const cv::Rect& side : sides)
      if (side.area() > 0) band_density = std::max(band_density, events_in(side) / side.area());
    if (band_density < options_.refine_grow_density * static_cast<double>(n) / e.area() ||
        band_density < options_.refine_grow_contrast * slice_density)
      return result();
    half = band_half;
  }
}

}  // namespace fdv
