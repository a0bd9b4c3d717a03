#include "fdv/detection/gaussian_fit.h"

#include <algorithm>
#include <cmath>

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

}  // namespace

GaussianFit iterative_gaussian_fit(const cv::Mat& P, const Eigen::Vector2d& c0, const Eigen::Vector2d& l0,
                                   const DetectorOptions& o) {
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
      for (int j = 0; j < r.height; ++j) {
        const double p = row_sum(P.ptr<float>(r.y + j) + r.x, r.width), y = r.y + j;
        sy += p * y;
        syy += p * y * y;
      }
    }
  if (!(sw > 0)) {
      fit.empty_roi = true;
      break;
    }
    const Eigen::Vector2d mu(sx / sw, sy / sw);
    const Eigen::Vector2d var(std::max(0.0, sxx / sw - mu.x() * mu.x()), std::max(0.0, syy / sw - mu.y() * mu.y()));
    const Eigen::Vector2d l_next(std::max(o.fit_min_size_px, 4 * std::sqrt(var.x())),
                                 std::max(o.fit_min_size_px, 4 * std::sqrt(var.y())));
    const bool done = (mu - c).norm() < o.fit_delta_center_px && std::abs(l_next.x() - l.x()) < o.fit_delta_size_px &&
                      std::abs(l_next.y() - l.y()) < o.fit_delta_size_px;
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

int label_components(const cv::Mat& image, cv::Mat& labels, std::vector<ComponentStats>& stats,
                     std::vector<std::int32_t>& stack) {
  CV_Assert(image.type() == CV_32F);
  const int w = image.cols, h = image.rows;
  if (labels.type() != CV_32S || labels.cols < w || labels.rows < h) labels.create(image.size(), CV_32S);
  cv::Mat lab = labels(cv::Rect(0, 0, w, h));
  for (int y = 0; y < h; ++y) std::fill(lab.ptr<std::int32_t>(y), lab.ptr<std::int32_t>(y) + w, 0);  // (setTo allocates)
  stats.clear();
  stats.push_back({});  // label 0: background (not filled)
  auto fg = [&](int x, int y) { return image.ptr<float>(y)[x] > 0; };
  // Flood fill (explicit stack of pixel indices y·w + x) from the first unlabelled foreground
  // pixel of each 2x2 block, blocks in raster order: every foreground pixel of a block is
  // 8-adjacent to the others, so a component's first block is the one OpenCV's block-based scan
  // opens its label at, and the labels come out in OpenCV's order.
  for (int by = 0; by < h; by += 2)
    for (int bx = 0; bx < w; bx += 2)
      for (int q = 0; q < 4; ++q) {
        const int sx = bx + (q & 1), sy = by + (q >> 1);
        if (sx >= w || sy >= h || !fg(sx, sy) || lab.ptr<std::int32_t>(sy)[sx] != 0) continue;
        const auto label = static_cast<std::int32_t>(stats.size());
        int x_lo = sx, x_hi = sx, y_lo = sy, y_hi = sy, area = 0;
        lab.ptr<std::int32_t>(sy)[sx] = label;
        stack.clear();
        stack.push_back(sy * w + sx);
        while (!stack.empty()) {
          const std::int32_t i = stack.back();
          stack.pop_back();
          const int y = i / w, x = i - y * w;
          ++area;
          x_lo = std::min(x_lo, x);
          x_hi = std::max(x_hi, x);
          y_lo = std::min(y_lo, y);
          y_hi = std::max(y_hi, y);
          for (int ny = std::max(0, y - 1); ny <= std::min(h - 1, y + 1); ++ny) {
            std::int32_t* l = lab.ptr<std::int32_t>(ny);
            for (int nx = std::max(0, x - 1); nx <= std::min(w - 1, x + 1); ++nx) {
              if (l[nx] != 0 || !fg(nx, ny)) continue;
              l[nx] = label;
              stack.push_back(ny * w + nx);
            }
          }
        }
        stats.push_back({x_lo, y_lo, x_hi - x_lo + 1, y_hi - y_lo + 1, area});
      }
  return static_cast<int>(stats.size());
}

void RegionScratch::reserve(int width, int height) {
  if (labels.type() != CV_32S || labels.cols < width || labels.rows < height) labels.create(height, width, CV_32S);
  stats.reserve(static_cast<std::size_t>((width + 1) / 2) * static_cast<std::size_t>((height + 1) / 2) + 1);
  stack.reserve(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
}

std::optional<Region> retrieve_region(const cv::Mat& P, const Box2D& roi, const cv::Rect& search,
                                      const DetectorOptions& o, RegionScratch& scratch) {
  const cv::Rect area = search & cv::Rect(0, 0, P.cols, P.rows);
  if (area.area() == 0) return std::nullopt;
  const cv::Mat Ps = P(area);
  const int n = label_components(Ps, scratch.labels, scratch.stats, scratch.stack);
  if (n <= 1) return std::nullopt;
  cv::Rect roi_px = box_pixels(roi, P.cols, P.rows);
  roi_px.x -= area.x;
  roi_px.y -= area.y;
  // Candidates: large enough and overlapping the ROI; mass and weighted centroid summed over each
  // candidate's bounding box only (search-area coordinates).
  int best = -1;
  double best_m[3] = {0, 0, 0};
  for (int i = 1; i < n; ++i) {
    const ComponentStats& st = scratch.stats[static_cast<std::size_t>(i)];
    if (st.area < o.region_min_area_px) continue;
    const cv::Rect comp(st.left, st.top, st.width, st.height);
    if ((comp & roi_px).area() == 0) continue;
    double m[3] = {0, 0, 0};
    for (int y = comp.y; y < comp.y + comp.height; ++y) {
      const float* p = Ps.ptr<float>(y);
      const std::int32_t* lab = scratch.labels.ptr<std::int32_t>(y);
      for (int x = comp.x; x < comp.x + comp.width; ++x) {
        if (lab[x] != i) continue;
        m[0] += p[x];
        m[1] += static_cast<double>(p[x]) * x;
        m[2] += static_cast<double>(p[x]) * y;
      }
    }
    if (best < 0 || m[0] > best_m[0]) {
      best = i;
      std::copy(m, m + 3, best_m);
    }
  }
  if (best < 0 || !(best_m[0] > 0)) return std::nullopt;
  const ComponentStats& st = scratch.stats[static_cast<std::size_t>(best)];
  const double left = area.x + st.left, top = area.y + st.top;
  Region r;
  r.box = {left - 0.5, top - 0.5, left + st.width - 0.5, top + st.height - 0.5};
  r.center = {area.x + best_m[1] / best_m[0], area.y + best_m[2] / best_m[0]};
  r.mass = best_m[0];
  r.area_px = st.area;
  return r;
}

}  // namespace fdv
