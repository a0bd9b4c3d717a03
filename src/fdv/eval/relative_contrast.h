#pragma once
/// Relative contrast η between a moving object and the background in a motion-compensated
/// image (paper §V-B, Table I):
///
///     η = (max_{M} img − max_{B} img) / max_{M} img,
///
/// M = the pixels of the object's box, B = every other pixel of the image. Like the paper, η is
/// computed after one "unified denoising" that is the same for every compensation method:
///
///   cv::Mat clean = denoise_for_contrast(time_images.mean_time_s, 3, 3);  // CV_32F in and out
///   std::optional<double> eta = relative_contrast(clean, box_pixels);  // nothing if undefined
///
/// Unified denoising = the paper's own denoising (§IV-B.2: "mean filter and morphological
/// operations ... to eliminate salt-and-pepper noise") applied to the mean-time image T (seconds
/// since the window start, 0 where no event fell): a k x k mean filter, then a morphological opening
/// with a square element, with the detector's sizes (mean_filter_px, opening_px). The isolated noise
/// events the paper warns about (timestamps spread "from oldest to newest", which would otherwise
/// set both maxima) are removed; the object's and the background's extended patterns keep their
/// interior values. The element-wise square that follows in the detector enhances contrast and is
/// not denoising, so it is not applied. See docs/DETECTION.md.
#include <opencv2/core.hpp>
#include <optional>

namespace fdv {

/// The shared denoising step of a CV_32F image: mean filter (cv::blur, `mean_filter_px` square),
/// then opening (cv::morphologyEx, `opening_px` square). Sizes must be odd and positive.
cv::Mat denoise_for_contrast(const cv::Mat& image, int mean_filter_px, int opening_px);

/// η of `image` for the object box `M` (pixel rectangle, clipped to the image). Nothing when
/// the box is empty after clipping, covers the whole image, or max over M is not positive.
std::optional<double> relative_contrast(const cv::Mat& image, const cv::Rect& M);

}  // namespace fdv
