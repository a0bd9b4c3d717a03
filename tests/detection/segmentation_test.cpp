// Adaptive threshold, segmentation and pre-processing on hand-made images.
#include <gtest/gtest.h>

#include "fdv/detection/segmentation.h"

namespace fdv {
namespace {

TEST(Segmentation, ThresholdIsMeanPlusMotionTermsPlusConstant) {
  DetectorOptions o;
  o.threshold_a_s_per_rad = 0.1;
  o.threshold_b_s_per_m = 0.2;
  o.threshold_c = 0.05;
  // 0.4 + 0.1·2 + 0.2·1.5 + 0.05 = 0.95
  EXPECT_NEAR(adaptive_threshold(0.4, 2.0, 1.5, o), 0.95, 1e-12);
}

TEST(Segmentation, KeepsNWhereItReachesTheThreshold) {
  // A 4x1 image: N = [0.2, 0.5, 0.7, 0.9], all pixels with events, and one 5th pixel without.
  TimeImages ti;
  ti.count = (cv::Mat_<std::int32_t>(1, 5) << 1, 2, 1, 3, 0);
  ti.normalized = (cv::Mat_<float>(1, 5) << 0.2f, 0.5f, 0.7f, 0.9f, 0.0f);
  cv::Mat S;
  const SegmentResult first = segment(ti, 0.5, 1, S);
  EXPECT_EQ(first.pixels, 3);  // N ≥ θ keeps the boundary value 0.5
  EXPECT_EQ(first.bounds, cv::Rect(1, 0, 3, 1));
  const float expected[5] = {0, 0.5f, 0.7f, 0.9f, 0};
  for (int i = 0; i < 5; ++i) EXPECT_FLOAT_EQ(S.at<float>(0, i), expected[i]) << i;
  EXPECT_EQ(segment(ti, 0.8, 1, S).pixels, 1);
  EXPECT_FLOAT_EQ(S.at<float>(0, 2), 0.0f);
  EXPECT_FLOAT_EQ(S.at<float>(0, 3), 0.9f);
  // θ ≤ 0 cannot turn pixels without events into foreground.
  EXPECT_EQ(segment(ti, -1.0, 1, S).pixels, 4);
  EXPECT_FLOAT_EQ(S.at<float>(0, 4), 0.0f);
  // At least 2 events per pixel: the single-event pixels (0.7) drop out, 0.5 (2) and 0.9 (3) stay.
  EXPECT_EQ(segment(ti, 0.5, 2, S).pixels, 2);
  EXPECT_FLOAT_EQ(S.at<float>(0, 1), 0.5f);
  EXPECT_FLOAT_EQ(S.at<float>(0, 2), 0.0f);
  EXPECT_FLOAT_EQ(S.at<float>(0, 3), 0.9f);
}

TEST(Segmentation, PreprocessingSuppressesIsolatedPixelsAndSquares) {
  DetectorOptions o;
  o.mean_filter_px = 3;
  o.opening_px = 3;
  cv::Mat S = cv::Mat::zeros(40, 40, CV_32F);
  S(cv::Rect(5, 5, 7, 7)).setTo(0.8);  // a 7x7 block
  S.at<float>(30, 30) = 0.9f;           // an isolated pixel
  cv::Mat P, scratch;
  preprocess(S, o, P, scratch);
  // Block centre: mean of a uniform 3x3 = 0.8, kept by the opening, squared: 0.64.
  EXPECT_NEAR(P.at<float>(8, 8), 0.64, 1e-6);
  // Isolated pixel: the mean filter spreads it into a 3x3 plateau of 0.1; erosion by 3x3 keeps
  // only its centre, dilation restores the plateau; squared: 0.01.
  EXPECT_NEAR(P.at<float>(30, 30), 0.01, 1e-6);
  EXPECT_NEAR(P.at<float>(29, 31), 0.01, 1e-6);
  EXPECT_EQ(P.at<float>(28, 30), 0.0f);
  // With a 5x5 opening the plateau is removed altogether, the block's core survives.
  o.opening_px = 5;
  preprocess(S, o, P, scratch);
  EXPECT_EQ(P.at<float>(30, 30), 0.0f);
  EXPECT_NEAR(P.at<float>(8, 8), 0.64, 1e-6);
}

}  // namespace
}  // namespace fdv
