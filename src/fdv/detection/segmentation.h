#pragma once
/// Dynamic obstacle segmentation (paper §IV-B.1) and the pre-processing before the Gaussian fit
/// (§IV-B.2).
///
///   double theta = adaptive_threshold(ti.mean_normalized, omega, speed, options);
///   int kept = segment(ti, theta, S);           // S = N where N ≥ θ (and I > 0), else 0
///   preprocess(S, options, P, scratch);         // P = (open(mean_filter(S)))²
#include <opencv2/core.hpp>

#include "fdv/detection/detector_options.h"
#include "fdv/detection/time_images.h"

namespace fdv {

/// θ(ω, v) = mean_N + a·‖ω‖ + b·‖v‖ + c, mean_N = mean of N over pixels with events.
double adaptive_threshold(double mean_normalized, double omega_rad_s, double speed_m_s, const DetectorOptions& o);

/// S_ij = N_ij where N_ij ≥ θ and I_ij ≥ min_pixel_events (≥ 1), else 0 (CV_32F). Returns the
/// number of kept pixels. `scratch_mask` is reused.
int segment(const TimeImages& ti, double theta, int min_pixel_events, cv::Mat& S, cv::Mat& scratch_mask);

/// P = (open_k2(mean_k1(S)))², element-wise square, CV_32F. `scratch` is reused.
void preprocess(const cv::Mat& S, const DetectorOptions& o, cv::Mat& P, cv::Mat& scratch);

}  // namespace fdv
