#pragma once
/// Relative contrast η between a moving object and the background in a motion-compensated
/// image (paper §V-B, Table I):
///
///     η = (max_{M} img − max_{B} img) / max_{M} img,
///
/// M = the pixels of the object's box, B = every other pixel of the image. Like the paper, η is
/// computed after one "unified denoising" that is the same for every compensation method:
///
///   cv::Mat clean = denoise_for_contrast(time_images.mean_time_s);   // CV_32F in, CV_32F out
///   std::optional<double> eta = relative_contrast(clean, box_pixels);  // nothing if undefined
///
/// Unified denoising = a 3x3 median filter of the mean-time image T (seconds since the window
/// start, 0 where no event fell). A pixel keeps a value only when most of its 3x3 neighbourhood
/// has events, so the isolated noise events the paper warns about (their timestamps spread "from
/// oldest to newest" and would otherwise set both maxima) are removed, while the object's and the
/// background's extended patterns survive. See docs/DETECTION.md.
#include <opencv2/core.hpp>
#include <optional>

namespace fdv {

/// The shared denoising step: 3x3 median filter (cv::medianBlur) of a CV_32F image.
cv::Mat denoise_for_contrast(const cv::Mat& image);

/// η of `image` for the object box `M` (pixel rectangle, clipped to the image). Nothing when
/// the box is empty after clipping, covers the whole image, or max over M is not positive.
std::optional<double> relative_contrast(const cv::Mat& image, const cv::Rect& M);

}  // namespace fdv
