#include "fdv/eval/relative_contrast.h"

#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace fdv {

cv::Mat denoise_for_contrast(const cv::Mat& image, int mean_filter_px, int opening_px) {
  if (image.type() != CV_32F) throw std::invalid_argument("denoise_for_contrast: expected a CV_32F image");
  if (mean_filter_px < 1 || mean_filter_px % 2 == 0 || opening_px < 1 || opening_px % 2 == 0)
    throw std::invalid_argument("denoise_for_contrast: filter sizes must be odd and positive");
  cv::Mat out;
  cv::blur(image, out, cv::Size(mean_filter_px, mean_filter_px));
  cv::morphologyEx(out, out, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(opening_px, opening_px)));
  return out;
}

std::optional<double> relative_contrast(const cv::Mat& image, const cv::Rect& M) {
  if (image.type() != CV_32F) throw std::invalid_argument("relative_contrast: expected a CV_32F image");
  const cv::Rect m = M & cv::Rect(0, 0, image.cols, image.rows);
  if (m.area() == 0 || m.area() == image.cols * image.rows) return std::nullopt;
  double max_m = 0;
  cv::minMaxLoc(image(m), nullptr, &max_m);
  if (!(max_m > 0)) return std::nullopt;
  // Max over the background: the whole image with M masked out.
  cv::Mat mask(image.rows, image.cols, CV_8U, cv::Scalar(255));
  mask(m).setTo(0);
  double max_b = 0;
  cv::minMaxLoc(image, nullptr, &max_b, nullptr, nullptr, mask);
  return (max_m - max_b) / max_m;
}

}  // namespace fdv
