#include "fdv/detection/time_images.h"

#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace fdv {

void build_time_images(const CompensatedEventsView& view, TimeImages& out) {
  const int w = view.width, h = view.height;
  out.count.create(h, w, CV_32S);
  out.sum_time_s.create(h, w, CV_32F);
  out.mean_time_s.create(h, w, CV_32F);
  out.normalized.create(h, w, CV_32F);
  // One interleaved accumulator: each event touches a single cache line (events arrive in time
  // order, scattered over the image). Counts are exact in float up to 2^24 per pixel.
  out.accumulator.create(h, w, CV_32FC2);
  out.accumulator.setTo(0);
  float* acc = out.accumulator.ptr<float>();
  const std::size_t npx = static_cast<std::size_t>(w) * h;
  const std::size_t n = std::min(view.pixel.size(), view.t_s.size());
  int events = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const std::int32_t p = view.pixel[k];
    if (p < 0 || static_cast<std::size_t>(p) >= npx) continue;
    acc[2 * p] += 1.0f;
    acc[2 * p + 1] += view.t_s[k];
    ++events;
  }
  // Per-pixel passes with OpenCV's vectorised operations only (a scalar pass over the image costs
  // more than all of these together).
  out.count_f.create(h, w, CV_32F);
  std::vector<cv::Mat> channels{out.count_f, out.sum_time_s};
  cv::split(out.accumulator, channels);
  out.count_f.convertTo(out.count, CV_32S);
  const int with_events = cv::countNonZero(out.count_f);
  // T = Σt / I, NaN (0/0) where no events: first replaced by +big to find min T over pixels with
  // events, then by 0.
  constexpr float kBig = 1e30f;
  cv::divide(out.sum_time_s, out.count_f, out.mean_time_s);
  cv::patchNaNs(out.mean_time_s, kBig);
  double t_min = 0, t_max = 0;
  if (with_events > 0) cv::minMaxLoc(out.mean_time_s, &t_min, nullptr);
  cv::threshold(out.mean_time_s, out.mean_time_s, 0.5 * kBig, 0.0, cv::THRESH_TOZERO_INV);
  if (with_events > 0) {
    if (t_min >= 0) {
      cv::minMaxLoc(out.mean_time_s, nullptr, &t_max);  // empty pixels (0) cannot exceed it
    } else {  // negative times (a hand-made view): mask out the empty pixels
      cv::Mat has_events;
      cv::compare(out.count_f, 0, has_events, cv::CMP_GT);
      cv::minMaxLoc(out.mean_time_s, nullptr, &t_max, nullptr, nullptr, has_events);
    }
  }
  const double range = t_max - t_min;
  const double inv = with_events > 0 && range > 0 ? 1.0 / range : 0.0;
  // N = (T − min T)/(max T − min T) on pixels with events, 0 elsewhere.
  out.mean_time_s.convertTo(out.normalized, CV_32F, inv, -t_min * inv);
  if (t_min >= 0) {
    cv::max(out.normalized, 0.0, out.normalized);  // empty pixels: (0 − min T)·inv ≤ 0 -> 0
  } else {
    cv::Mat empty;
    cv::compare(out.count_f, 0, empty, cv::CMP_EQ);
    out.normalized.setTo(0, empty);
  }
  out.events = events;
  out.pixels_with_events = with_events;
  out.t_min_s = static_cast<float>(t_min);
  out.t_max_s = static_cast<float>(t_max);
  // mean(N) = (mean(T) − min T) / (max T − min T) over pixels with events (N is affine in T).
  const double sum_t = cv::sum(out.mean_time_s)[0];
  out.mean_normalized = with_events ? (sum_t / with_events - t_min) * inv : 0;
}

}  // namespace fdv
