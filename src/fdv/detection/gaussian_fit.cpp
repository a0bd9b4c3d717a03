#include "fdv/detection/gaussian_fit.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace fdv {

cv::Rect box_pixels(const Box2D& box, int width, int height) {
  const int x0 = std::max(0, static_cast<int>(std::ceil(box.x0)));
  const int y0 = std::max(0, static_cast<int>(std::ceil(box.y0)));
  const int x1 = std::min(width - 1, static_cast<int>(std::floor(box.x1)));
  const int y1 = std::min(height - 1, static_cast<int>(std::floor(box.y1)));
  if (x1 < x0 || y1 < y0) return {};
  return {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
}

GaussianFit iterative_gaussian_fit(const cv::Mat& P, const Eigen::Vector2d& c0, const Eigen::Vector2d& l0,
                                   const DetectorOptions& o) {
  GaussianFit fit;
  Eigen::Vector2d c = c0, l = l0;
  cv::Mat col_sums, row_sums;
  for (int k = 0; k < o.fit_max_iterations; ++k) {
    fit.iterations = k + 1;
    const Box2D roi{c.x() - 0.5 * l.x(), c.y() - 0.5 * l.y(), c.x() + 0.5 * l.x(), c.y() + 0.5 * l.y()};
    const cv::Rect r = box_pixels(roi, P.cols, P.rows);
    // Marginal sums (SIMD in OpenCV), then 1-D weighted moments: the 2-D Gaussian fit with a
    // diagonal covariance needs only the two marginals.
    double sw = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
    if (r.area() > 0) {
      cv::reduce(P(r), col_sums, 0, cv::REDUCE_SUM, CV_32F);  // 1 x width
      cv::reduce(P(r), row_sums, 1, cv::REDUCE_SUM, CV_32F);  // height x 1
      const float* cs = col_sums.ptr<float>();
      for (int i = 0; i < r.width; ++i) {
        const double p = cs[i], x = r.x + i;
        sw += p;
        sx += p * x;
        sxx += p * x * x;
      }
      for (int j = 0; j < r.height; ++j) {
        const double p = row_sums.at<float>(j), y = r.y + j;
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

std::optional<Region> retrieve_region(const cv::Mat& P, const Box2D& roi, const cv::Rect& search,
                                      const DetectorOptions& o, cv::Mat& mask, cv::Mat& labels, cv::Mat& stats,
                                      cv::Mat& centroids, std::vector<double>& mass) {
  const cv::Rect area = search & cv::Rect(0, 0, P.cols, P.rows);
  if (area.area() == 0) return std::nullopt;
  const cv::Mat Ps = P(area);
  cv::compare(Ps, 0.0, mask, cv::CMP_GT);
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  if (n <= 1) return std::nullopt;
  cv::Rect roi_px = box_pixels(roi, P.cols, P.rows);
  roi_px.x -= area.x;
  roi_px.y -= area.y;
  // Candidates: large enough and overlapping the ROI; mass and weighted centroid summed over each
  // candidate's bounding box only (search-area coordinates).
  mass.assign(3 * static_cast<std::size_t>(n), 0.0);
  int best = -1;
  for (int i = 1; i < n; ++i) {
    const int* st = stats.ptr<int>(i);
    if (st[cv::CC_STAT_AREA] < o.region_min_area_px) continue;
    const cv::Rect comp(st[cv::CC_STAT_LEFT], st[cv::CC_STAT_TOP], st[cv::CC_STAT_WIDTH], st[cv::CC_STAT_HEIGHT]);
    if ((comp & roi_px).area() == 0) continue;
    double* m = &mass[3 * static_cast<std::size_t>(i)];
    for (int y = comp.y; y < comp.y + comp.height; ++y) {
      const float* p = Ps.ptr<float>(y);
      const std::int32_t* lab = labels.ptr<std::int32_t>(y);
      for (int x = comp.x; x < comp.x + comp.width; ++x) {
        if (lab[x] != i) continue;
        m[0] += p[x];
        m[1] += static_cast<double>(p[x]) * x;
        m[2] += static_cast<double>(p[x]) * y;
      }
    }
    if (best < 0 || m[0] > mass[3 * static_cast<std::size_t>(best)]) best = i;
  }
  if (best < 0 || !(mass[3 * static_cast<std::size_t>(best)] > 0)) return std::nullopt;
  const int* st = stats.ptr<int>(best);
  const double* m = &mass[3 * static_cast<std::size_t>(best)];
  const double left = area.x + st[cv::CC_STAT_LEFT], top = area.y + st[cv::CC_STAT_TOP];
  Region r;
  r.box = {left - 0.5, top - 0.5, left + st[cv::CC_STAT_WIDTH] - 0.5, top + st[cv::CC_STAT_HEIGHT] - 0.5};
  r.center = {area.x + m[1] / m[0], area.y + m[2] / m[0]};
  r.mass = m[0];
  r.area_px = st[cv::CC_STAT_AREA];
  return r;
}

}  // namespace fdv
