#include "fdv/detection/gaussian_fit.h"

#include <algorithm>
#include <cmath>

#include "fdv/core/lanes.h"

namespace fdv {

cv::Rect box_pixels(const Box2D& box, int width, int height) {
  const int x0 = std::max(0, static_cast<int>(std::ceil(box.x0)));
  const int y0 = std::max(0, static_cast<int>(std::ceil(box.y0)));
  const int x1 = std::min(width - 1, static_cast<int>(std::floor(box.x1)));
  const int y1 = std::min(height - 1, static_cast<int>(std::floor(box.y1)));
  if (x1 < x0 || y1 < y0) return {};
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

namespace {

// The marginals as cv::reduce(..., REDUCE_SUM, CV_32F) computes them (float accumulators; the
// earlier version called it, which allocated its outputs at each iteration), so that the fit's
// results do not change.

/// Σ over the rows of r, per column, top to bottom; then Σ w·x and Σ w·x² of the sums in double.
void column_moments(const cv::Mat& P, const cv::Rect& r, double& sw, double& sx, double& sxx) {
  constexpr int kChunk = 128;  // columns per pass: the accumulators stay on the stack
  float acc[kChunk];
  for (int c0 = 0; c0 < r.width; c0 += kChunk) {
    const int n = std::min(kChunk, r.width - c0);
    const float* first = P.ptr<float>(r.y) + r.x + c0;
    std::copy(first, first + n, acc);
    for (int y = r.y + 1; y < r.y + r.height; ++y) {
      const float* p = P.ptr<float>(y) + r.x + c0;
      for (int i = 0; i < n; ++i) acc[i] += p[i];
    }
    for (int i = 0; i < n; ++i) {
      const double w = acc[i], x = r.x + c0 + i;
      sw += w;
      sx += w * x;
      sxx += w * x * x;
    }
  }
}

/// One row's sum in cv::reduce's order for a single channel: two interleaved accumulators.
float row_sum(const float* p, int width) {
  if (width == 1) return p[0];
  float a0 = p[0], a1 = p[1];
  int i = 2;
  for (; i <= width - 4; i += 4) {
    a0 += p[i];
    a1 += p[i + 1];
    a0 += p[i + 2];
    a1 += p[i + 3];
  }
  for (; i < width; ++i) a0 += p[i];
  return a0 + a1;
}

/// row_sum of four rows at once: eight independent accumulator chains instead of two, so the adds
/// overlap (one row's sum is a chain of dependent adds). Each row's result is row_sum's, to the bit.
void row_sums4(const float* const p[4], int width, float out[4]) {
  if (width == 1) {
    for (int r = 0; r < 4; ++r) out[r] = p[r][0];
    return;
  }
  float a0[4], a1[4];
  for (int r = 0; r < 4; ++r) a0[r] = p[r][0], a1[r] = p[r][1];
  int i = 2;
  for (; i <= width - 4; i += 4)
    for (int r = 0; r < 4; ++r) {
      a0[r] += p[r][i];
      a1[r] += p[r][i + 1];
      a0[r] += p[r][i + 2];
      a1[r] += p[r][i + 3];
    }
  for (; i < width; ++i)
    for (int r = 0; r < 4; ++r) a0[r] += p[r][i];
  for (int r = 0; r < 4; ++r) out[r] = a0[r] + a1[r];
}

}  // namespace

// AVX2 clone (chosen at run time): the column sums vectorise 8 lanes wide; lane-wise adds, the same
// results to the bit.
FDV_AVX2_CLONES __attribute__((flatten)) GaussianFit
iterative_gaussian_fit(const cv::Mat& P, const Eigen::Vector2d& c0, const Eigen::Vector2d& l0, const DetectorOptions& o) {
  CV_Assert(P.type() == CV_32F);
  GaussianFit fit;
  Eigen::Vector2d c = c0, l = l0;
  for (int k = 0; k < o.fit_max_iterations; ++k) {
    fit.iterations = k + 1;
    const Box2D roi{c.x() - 0.5 * l.x(), c.y() - 0.5 * l.y(), c.x() + 0.5 * l.x(), c.y() + 0.5 * l.y()};
    const cv::Rect r = box_pixels(roi, P.cols, P.rows);
    // Marginal sums, then 1-D weighted moments: the 2-D Gaussian fit with a diagonal covariance
    // needs only the two marginals.
    double sw = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
    if (r.area() > 0) {
      column_moments(P, r, sw, sx, sxx);
      auto add_row = [&](double p, int j) {
        const double y = r.y + j;
        sy += p * y;
        syy += p * y * y;
      };
      int j = 0;
      for (; j + 4 <= r.height; j += 4) {
        const float* rows[4] = {P.ptr<float>(r.y + j) + r.x, P.ptr<float>(r.y + j + 1) + r.x,
                                P.ptr<float>(r.y + j + 2) + r.x, P.ptr<float>(r.y + j + 3) + r.x};
        float sums[4];
        row_sums4(rows, r.width, sums);
        for (int q = 0; q < 4; ++q) add_row(sums[q], j + q);
      }
      for (; j < r.height; ++j) add_row(row_sum(P.ptr<float>(r.y + j) + r.x, r.width), j);
    }
  if (!(sw > 0)) {
      fit.empty_roi = true;
      break;
    }
    const Eigen::Vector2d mu(sx / sw, sy / sw);
    const Eigen::Vector2d var(std::max(0.0, sxx / sw - mu.x() * mu.x()), std::max(0.0, syy / sw - mu.y() * mu.y()));
    const Eigen::Vector2d l_next(std::max(o.fit_min_size_px, 4 * std::sqrt(var.x())),
                                 std::max(o.fit_min_size_px, 4 * std::sqrt(var.y())));
    // δ_C, δ_L in pixels, or a fraction of the side for a large pattern.
    const double relative = o.fit_delta_fraction * l.minCoeff();
    const double delta_c = std::max(o.fit_delta_center_px, relative), delta_l = std::max(o.fit_delta_size_px, relative);
    const bool done = (mu - c).norm() < delta_c && std::abs(l_next.x() - l.x()) < delta_l &&
                      std::abs(l_next.y() - l.y()) < delta_l;
    c = mu;
    l = l_next;
    if (done) {
      fit.converged = true;
      break;
    }
    // Diverging: the ROI outgrew the initial one on both sides (the weight is spread over the
    // image, no dominant pattern). It can only end "too large", so stop here.
    if (l.x() > l0.x() && l.y() > l0.y()) {
      fit.diverged = true;
      break;
    }
  }
  fit.center = c;
  fit.size = l;
  return fit;
}

namespace {

/// First x in [x, w) with p[x] > 0, else w. P is mostly background: 16 pixels per test.
int next_foreground(const float* p, int x, int w) {
  using lanes::load;
  const lanes::vf zero{};
  for (; x + 16 <= w; x += 16)
    if (lanes::any((load(p + x) > zero) | (load(p + x + 4) > zero) | (load(p + x + 8) > zero) |
                   (load(p + x + 12) > zero)))
      break;
  while (x < w && !(p[x] > 0)) ++x;
  return x;
}

std::int32_t find_root(std::vector<std::int32_t>& parent, std::int32_t i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];  // path halving
    i = parent[i];
  }
  return i;
}

}  // namespace

int label_runs(const cv::Mat& image, RegionScratch& s) {
  CV_Assert(image.type() == CV_32F);
  const int w = image.cols, h = image.rows;
  s.runs.clear();
  s.parent.clear();
  // Runs row by row; each is joined with the runs of the row above that touch it (8-connected:
  // columns overlap or meet diagonally). Both rows' runs are sorted by x: one merge-like sweep.
  std::size_t above_begin = 0, above_end = 0;
  for (int y = 0; y < h; ++y) {
    const float* p = image.ptr<float>(y);
    const std::size_t row_begin = s.runs.size();
    std::size_t j = above_begin;
    for (int x = 0; x < w;) {
      x = next_foreground(p, x, w);
      if (x == w) break;
      const int x0 = x;
      while (x < w && p[x] > 0) ++x;
      const auto self = static_cast<std::int32_t>(s.runs.size());
      s.runs.push_back({y, x0, x - 1, 0});
      s.parent.push_back(self);
      while (j < above_end && s.runs[j].x1 < x0 - 1) ++j;
      for (std::size_t k = j; k < above_end && s.runs[k].x0 <= x; ++k) {
        const std::int32_t a = find_root(s.parent, self), b = find_root(s.parent, static_cast<std::int32_t>(k));
        if (a != b) s.parent[std::max(a, b)] = std::min(a, b);  // the earlier run stays the root
      }
    }
    above_begin = row_begin;
    above_end = s.runs.size();
  }
  // Components: bounds, area and first 2x2 block (the key of OpenCV's numbering), per root run.
  const auto n_runs = static_cast<std::int32_t>(s.runs.size());
  const std::int32_t blocks_per_row = (w + 1) / 2;
  s.roots.clear();
  s.key.resize(s.runs.size());
  s.root_stats.resize(s.runs.size());
  for (std::int32_t i = 0; i < n_runs; ++i) {
    const std::int32_t r = find_root(s.parent, i);
    s.parent[i] = r;
    const PixelRun& run = s.runs[i];
    const std::int32_t key = (run.y / 2) * blocks_per_row + run.x0 / 2;
    ComponentStats& st = s.root_stats[r];  // (x_lo, y_lo, x_hi, y_hi, area) while collecting
    if (r == i) {  // a root is its component's first run in raster order
      s.roots.push_back(r);
      s.key[r] = key;
      st = {run.x0, run.y, run.x1, run.y, 0};
    }
    s.key[r] = std::min(s.key[r], key);
    st.left = std::min(st.left, run.x0);
    st.width = std::max(st.width, run.x1);
    st.height = run.y;  // runs come in raster order
    st.area += run.x1 - run.x0 + 1;
  }
  std::sort(s.roots.begin(), s.roots.end(), [&](std::int32_t a, std::int32_t b) { return s.key[a] < s.key[b]; });
  s.stats.resize(s.roots.size() + 1);
  s.stats[0] = {};
  for (std::size_t i = 0; i < s.roots.size(); ++i) {
    const std::int32_t r = s.roots[i];
    const ComponentStats& c = s.root_stats[r];
    s.stats[i + 1] = {c.left, c.top, c.width - c.left + 1, c.height - c.top + 1, c.area};
    s.key[r] = static_cast<std::int32_t>(i + 1);  // root → label
  }
  for (std::int32_t i = 0; i < n_runs; ++i) s.runs[i].label = s.key[s.parent[i]];
  return static_cast<int>(s.stats.size());
}

int label_components(const cv::Mat& image, RegionScratch& s) {
  const int n = label_runs(image, s);
  const int w = image.cols, h = image.rows;
  if (s.labels.type() != CV_32S || s.labels.cols < w || s.labels.rows < h) s.labels.create(image.size(), CV_32S);
  for (int y = 0; y < h; ++y) std::fill_n(s.labels.ptr<std::int32_t>(y), w, 0);  // (setTo allocates)
  for (const PixelRun& r : s.runs) std::fill(s.labels.ptr<std::int32_t>(r.y) + r.x0, s.labels.ptr<std::int32_t>(r.y) + r.x1 + 1, r.label);
  return n;
}

void RegionScratch::reserve(int width, int height) {
  // (`labels` is not reserved: only label_components writes it, and retrieval does not need it.)
  // At most one run per two pixels of a row, one component per 2x2 block.
  const std::size_t max_runs = static_cast<std::size_t>((width + 1) / 2) * static_cast<std::size_t>(height);
  const std::size_t max_components = static_cast<std::size_t>((width + 1) / 2) * static_cast<std::size_t>((height + 1) / 2);
  runs.reserve(max_runs);
  parent.reserve(max_runs);
  key.reserve(max_runs);
  root_stats.reserve(max_runs);
  roots.reserve(max_components);
  stats.reserve(max_components + 1);
  mass.reserve(3 * (max_components + 1));
}

std::optional<Region> retrieve_region(const cv::Mat& P, const Box2D& roi, const cv::Rect& search,
                                      const DetectorOptions& o, RegionScratch& scratch) {
  return retrieve_region(P, std::span<const Box2D>(&roi, 1), search, o, scratch);
}

std::optional<Region> retrieve_region(const cv::Mat& P, std::span<const Box2D> rois, const cv::Rect& search,
                                      const DetectorOptions& o, RegionScratch& scratch) {
  const cv::Rect area = search & cv::Rect(0, 0, P.cols, P.rows);
  if (area.area() == 0) return std::nullopt;
  const cv::Mat Ps = P(area);
  const int n = label_runs(Ps, scratch);
  if (n <= 1) return std::nullopt;
  // The ROIs in search-area pixels; a component is a candidate for an ROI when it is large enough
  // and its bounding box overlaps the ROI.
  auto roi_px = [&](const Box2D& roi) {
    cv::Rect r = box_pixels(roi, P.cols, P.rows);
    r.x -= area.x;
    r.y -= area.y;
    return r;
  };
  auto candidate = [&](int label, const cv::Rect& r) {
    const ComponentStats& st = scratch.stats[static_cast<std::size_t>(label)];
    return st.area >= o.region_min_area_px && (cv::Rect(st.left, st.top, st.width, st.height) & r).area() > 0;
  };
  // Mass and weighted centroid (search-area coordinates) of every component that is a candidate
  // for some ROI, summed pixel by pixel in raster order (runs come in raster order).
  std::vector<double>& mass = scratch.mass;
  mass.assign(3 * static_cast<std::size_t>(n), -1.0);  // −1: not needed
  for (const Box2D& roi : rois) {
    const cv::Rect r = roi_px(roi);
    for (int i = 1; i < n; ++i)
      if (mass[3 * i] < 0 && candidate(i, r)) std::fill_n(mass.begin() + 3 * i, 3, 0.0);
  }
  for (const PixelRun& run : scratch.runs) {
    double* m = mass.data() + 3 * static_cast<std::size_t>(run.label);
    if (m[0] < 0) continue;
    const float* p = Ps.ptr<float>(run.y);
    for (int x = run.x0; x <= run.x1; ++x) {
      m[0] += p[x];
      m[1] += static_cast<double>(p[x]) * x;
      m[2] += static_cast<double>(p[x]) * run.y;
    }
  }
  for (const Box2D& roi : rois) {
    const cv::Rect r = roi_px(roi);
    int best = -1;
    for (int i = 1; i < n; ++i)  // the heaviest; on a tie, the lower label
      if (candidate(i, r) && (best < 0 || mass[3 * i] > mass[3 * best])) best = i;
    if (best < 0 || !(mass[3 * best] > 0)) continue;
    const ComponentStats& st = scratch.stats[static_cast<std::size_t>(best)];
    const double* m = mass.data() + 3 * best;
    const double left = area.x + st.left, top = area.y + st.top;
    Region region;
    region.box = {left - 0.5, top - 0.5, left + st.width - 0.5, top + st.height - 0.5};
    region.center = {area.x + m[1] / m[0], area.y + m[2] / m[0]};
    region.mass = m[0];
    region.area_px = st.area;
    return region;
  }
  return std::nullopt;
}

}  // namespace fdv
