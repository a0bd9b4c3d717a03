#include "fdv/detection/segmentation.h"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace fdv {

double adaptive_threshold(double mean_normalized, double omega_rad_s, double speed_m_s, const DetectorOptions& o) {
  return mean_normalized + o.threshold_a_s_per_rad * omega_rad_s + o.threshold_b_s_per_m * speed_m_s + o.threshold_c;
}

int segment(const TimeImages& ti, double theta, int min_pixel_events, cv::Mat& S, cv::Mat& scratch_mask) {
  // S = N where N ≥ θ, else 0: "to zero" thresholding keeps values strictly above its threshold,
  // so the threshold is the float just below θ. Pixels without events have N = 0 and stay 0.
  const float th = std::nextafter(static_cast<float>(theta), -std::numeric_limits<float>::infinity());
  cv::threshold(ti.normalized, S, th, 0.0, cv::THRESH_TOZERO);
  if (min_pixel_events > 1) {
    cv::compare(ti.count, min_pixel_events, scratch_mask, cv::CMP_LT);
    S.setTo(0, scratch_mask);
  }
  return cv::countNonZero(S);
}

void preprocess(const cv::Mat& S, const DetectorOptions& o, cv::Mat& P, cv::Mat& scratch) {
  // Mean filter as a separable box kernel (cv::sepFilter2D is several times faster than cv::blur
  // on float images here), then opening = erosion followed by dilation, then the square.
  const cv::Mat box = cv::Mat::ones(1, o.mean_filter_px, CV_32F) / static_cast<double>(o.mean_filter_px);
  cv::sepFilter2D(S, scratch, CV_32F, box, box, cv::Point(-1, -1), 0, cv::BORDER_CONSTANT);
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(o.opening_px, o.opening_px));
  cv::erode(scratch, P, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::dilate(P, P, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::multiply(P, P, P);
}

}  // namespace fdv
