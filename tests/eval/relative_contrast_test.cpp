// Relative contrast η (paper §V-B) on hand-made images.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "fdv/eval/relative_contrast.h"

namespace fdv {
namespace {

TEST(RelativeContrast, HandComputed) {
  cv::Mat img = cv::Mat::zeros(20, 30, CV_32F);
  img(cv::Rect(5, 5, 4, 4)).setTo(0.020);  // object: newest mean time 20 ms
  img.at<float>(6, 6) = 0.024f;
  img(cv::Rect(15, 10, 10, 5)).setTo(0.012);  // background pattern, 12 ms
  // η = (0.024 − 0.012) / 0.024 = 0.5
  EXPECT_NEAR(*relative_contrast(img, cv::Rect(4, 4, 6, 6)), 0.5, 1e-6);
  // A box on the background: max_M = 0.012, max_B = 0.024 -> η = −1.
  EXPECT_NEAR(*relative_contrast(img, cv::Rect(14, 9, 12, 7)), -1.0, 1e-6);
  // Undefined: empty box, box over everything, box with no positive value.
  EXPECT_FALSE(relative_contrast(img, cv::Rect(40, 40, 5, 5)));
  EXPECT_FALSE(relative_contrast(img, cv::Rect(0, 0, 30, 20)));
  EXPECT_FALSE(relative_contrast(img, cv::Rect(0, 15, 3, 3)));
}

TEST(RelativeContrast, UnifiedDenoisingRemovesIsolatedNoise) {
  cv::Mat img = cv::Mat::zeros(20, 30, CV_32F);
  img(cv::Rect(5, 5, 5, 5)).setTo(0.020);  // object
  img(cv::Rect(15, 10, 10, 5)).setTo(0.010);  // background
  img.at<float>(2, 25) = 0.0249f;              // one noise event with the newest timestamp
  // Raw: the noise pixel beats the object: η = (0.020 − 0.0249) / 0.020 < 0.
  EXPECT_LT(*relative_contrast(img, cv::Rect(5, 5, 5, 5)), 0);
  // Denoised (3x3 mean, 3x3 opening): the isolated pixel falls to 1/9 of its value (the mean
  // spreads it over a 3x3 block, which a 3x3 opening keeps), below the background; the blocks keep
  // their interior values.
  const cv::Mat clean = denoise_for_contrast(img, 3, 3);
  EXPECT_NEAR(clean.at<float>(2, 25), 0.0249f / 9, 1e-6);
  EXPECT_FLOAT_EQ(clean.at<float>(7, 7), 0.020f);
  EXPECT_NEAR(*relative_contrast(clean, cv::Rect(5, 5, 5, 5)), 0.5, 1e-6);
}

TEST(RelativeContrast, UnifiedDenoisingRemovesAThinStreakOfLateTimes) {
  // A 2-pixel-wide streak of late mean times (a background edge revealed at the window's end):
  // a 3x3 median keeps it whole (6 of the 9 values are the streak's), the paper's mean filter +
  // opening does not; a 6x6 object pattern keeps its value either way.
  cv::Mat img = cv::Mat::zeros(30, 40, CV_32F);
  img(cv::Rect(5, 5, 6, 6)).setTo(0.020);
  img(cv::Rect(20, 2, 2, 20)).setTo(0.024);
  cv::Mat median;
  cv::medianBlur(img, median, 3);
  EXPECT_NEAR(*relative_contrast(median, cv::Rect(5, 5, 6, 6)), (0.020 - 0.024) / 0.020, 1e-6);
  const cv::Mat clean = denoise_for_contrast(img, 3, 3);
  EXPECT_FLOAT_EQ(clean.at<float>(7, 7), 0.020f);
  // Mean filter: the streak becomes columns 1/3, 2/3, 2/3, 1/3 of 0.024; the 3-wide erosion takes
  // each column's minimum with a neighbour: 0.008 at most is left.
  double streak_max = 0;
  cv::minMaxLoc(clean(cv::Rect(18, 0, 6, 24)), nullptr, &streak_max);
  EXPECT_NEAR(streak_max, 0.024 / 3, 1e-6);
  EXPECT_NEAR(*relative_contrast(clean, cv::Rect(5, 5, 6, 6)), (0.020 - 0.008) / 0.020, 1e-6);
}

TEST(RelativeContrast, UnifiedDenoisingRejectsBadSizes) {
  const cv::Mat img = cv::Mat::zeros(8, 8, CV_32F);
  EXPECT_THROW(denoise_for_contrast(img, 2, 3), std::invalid_argument);
  EXPECT_THROW(denoise_for_contrast(img, 3, 0), std::invalid_argument);
  EXPECT_THROW(denoise_for_contrast(cv::Mat::zeros(8, 8, CV_8U), 3, 3), std::invalid_argument);
}

}  // namespace
}  // namespace fdv
