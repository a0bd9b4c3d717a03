#include "fdv/detection/dense_motion_source.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace fdv {

std::string DenseMotionSourceOptions::validate() const {
  for (double v : {min_r2, min_span})
    if (!std::isfinite(v)) return "non-finite detector parameter";
  std::ostringstream why;
  if (!(density_px >= 1 && density_px % 2 == 1 && density_px <= 31))
    why << "dense_motion_density_px must be odd in [1, 31], got " << density_px;
  else if (radius_px < 1 || radius_px > 100) why << "dense_motion_radius_px must be in [1, 100], got " << radius_px;
  else if (!(min_r2 >= 0 && min_r2 <= 1)) why << "dense_motion_min_r2 must be in [0, 1], got " << min_r2;
  else if (min_pixels < 3) why << "dense_motion_min_pixels must be at least 3, got " << min_pixels;
  else if (!(min_span >= 0)) why << "dense_motion_min_span must be >= 0, got " << min_span;
  return why.str();
}

void DenseMotionSource::allocate(int width, int height) {
  active_.create(height, width, CV_32F);
  active_integral_.create(height + 1, width + 1, CV_64F);
}

std::optional<Candidate> DenseMotionSource::find(SourceWindow& in, DetectionResult& res) {
  if (!(in.window_s > 0)) return std::nullopt;
  for (const std::span<const Box2D> gates : {in.gates, in.tentative_gates}) {
    for (const Box2D& gate : gates) {
      std::optional<Candidate> found = find_in(in, box_pixels(gate, in.events.width, in.events.height), res);
      if (found && gate.contains(found->center)) {
        res.track_aided = true;
        return found;
      }
    }
  }
  return std::nullopt;
}

std::optional<Candidate> DenseMotionSource::find_in(const SourceWindow& in, const cv::Rect& search,
                                                    DetectionResult& res) {
  const DetectorOptions& o = options_;
  const DenseMotionSourceOptions& m = o.dense_motion;
  const TimeImages& ti = in.ti;
  const int w = ti.count.cols, h = ti.count.rows;
  const cv::Rect area = search & cv::Rect(0, 0, w, h);
  if (area.area() == 0) return std::nullopt;
  DenseMotionDiagnostics& diagnostics = res.diagnostics_of(kName).write<DenseMotionDiagnostics>();
  // The box with the most active pixels (I ≥ min_pixel_events) in the search area (its centre
  // pixel; boxes are clipped at the area's border). Counting pixels, not events, keeps a hot pixel
  // from being "dense".
  for (int y = 0; y < area.height; ++y) {
    const std::int32_t* count = ti.count.ptr<std::int32_t>(area.y + y) + area.x;
    float* active = active_.ptr<float>(y);
    for (int x = 0; x < area.width; ++x) active[x] = count[x] >= o.min_pixel_events ? 1.0f : 0.0f;
  }
  cv::Mat integral = active_integral_(cv::Rect(0, 0, area.width + 1, area.height + 1));
  cv::integral(active_(cv::Rect(0, 0, area.width, area.height)), integral, CV_64F);
  const int hk = m.density_px / 2;
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
  const int r = m.radius_px;
  const cv::Rect square = cv::Rect(at.x - r, at.y - r, 2 * r + 1, 2 * r + 1) & cv::Rect(0, 0, w, h);
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double n_sum = 0, t_sum = 0, tt_sum = 0, xx_sum = 0, yy_sum = 0;
  int active_pixels = 0;
  for (int y = square.y; y < square.y + square.height; ++y) {
    const std::int32_t* count = ti.count.ptr<std::int32_t>(y);
    const float* mean_time = ti.mean_time_s.ptr<float>(y);
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
  if (active_pixels < m.min_pixels || n_sum < o.roi_min_events) return std::nullopt;
  const double total_ss = tt_sum - t_sum * t_sum / n_sum;
  if (!(total_ss > 0)) return std::nullopt;
  const Eigen::Vector3d plane = A.ldlt().solve(b);
  const double residual_ss = tt_sum - 2.0 * plane.dot(b) + plane.dot(A * plane);
  diagnostics.r2 = 1.0 - residual_ss / total_ss;
  diagnostics.span = std::hypot(plane.y(), plane.z()) * square.width / in.window_s;
  if (!(diagnostics.r2 >= m.min_r2) || !(diagnostics.span >= m.min_span)) return std::nullopt;
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
  cand.events = static_cast<int>(cv::sum(ti.count(box))[0]);
  cand.event_density = static_cast<double>(cand.events) / box.area();
  if (cand.events < o.roi_min_events || cand.event_density < o.min_event_density) return std::nullopt;
  cand.score = std::clamp(diagnostics.r2, 0.0, 1.0);
  cand.t_mean_s = cv::sum(ti.sum_time_s(box))[0] / cand.events;
  return cand;
}

}  // namespace fdv
