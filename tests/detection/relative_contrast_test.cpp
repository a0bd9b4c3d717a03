// Relative contrast η (paper §V-B) on hand-made images.
#include <gtest/gtest.h>

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
  // Denoised (3x3 median): the isolated pixel is gone, blocks keep their interior values.
  const cv::Mat clean = denoise_for_contrast(img);
  EXPECT_EQ(clean.at<float>(2, 25), 0.0f);
  EXPECT_FLOAT_EQ(clean.at<float>(7, 7), 0.020f);
  EXPECT_NEAR(*relative_contrast(clean, cv::Rect(5, 5, 5, 5)), 0.5, 1e-6);
}

}  // namespace
}  // namespace fdv
