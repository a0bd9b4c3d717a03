#include "fdv/detection/event_refinement.h"

#include <algorithm>
#include <array>
#include <cstdint>

#include "fdv/core/lanes.h"
#include "fdv/detection/gaussian_fit.h"

namespace fdv {
namespace {

/// The refinement's scan: the events k in [begin, end) on the image rows [row0, row0 + rows) of a
/// w-wide image whose time lies in [t_lo, t_hi] are added to acc (per pixel: count, Σt; row-major,
/// w wide), in event order. Events on and off the band alternate in no pattern, so a branch per
/// event mispredicts (docs/DETECTION.md, "Tuning"): the tests run four events at a time and write
/// the passing ones to a short list, branch-free; then the list is added in order.
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

}  // namespace

void EventRefiner::allocate(int width, int height) { acc_.create(height, width, CV_32FC2); }

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
  const double half = 0.5 * options_.refine_box_scale * std::max(box.width(), box.height());
  // The clutter guard below keeps the centre within one box size of the box's: the squares of all
  // passes lie inside `outer`, whose slice events are binned once per pixel (count, Σt).
  const double reach = std::max(box.width(), box.height());
  const cv::Rect outer = box_pixels({c.x() - reach - half, c.y() - reach - half, c.x() + reach + half, c.y() + reach + half},
                                    window.width, window.height);
  if (outer.area() == 0) return std::nullopt;
  // The band of outer's rows, whole (bin_slice counts whole rows).
  CV_Assert(acc_.isContinuous() && acc_.cols == window.width);
  std::fill_n(acc_.ptr<float>(outer.y), 2 * static_cast<std::size_t>(outer.height) * window.width, 0.0f);
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
            acc_.ptr<float>(0));
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
      const float* acc = acc_.ptr<float>(y);
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
  return RefinedCenter{centre, st / static_cast<double>(n)};
}

}  // namespace fdv
