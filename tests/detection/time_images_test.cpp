// Time images (paper eqs. 1-4) on hand-made events, with hand-computed I, T, N.
#include <gtest/gtest.h>

#include "fdv/detection/time_images.h"

namespace fdv {
namespace {

CompensatedEventsView view(int w, int h, const std::vector<std::int32_t>& px, const std::vector<float>& t) {
  CompensatedEventsView v;
  v.width = w;
  v.height = h;
  v.pixel = px;
  v.t_s = t;
  return v;
}

TEST(TimeImages, HandComputedCountMeanTimeAndNormalised) {
  // 3x2 image. Pixel 0: t = 1, 3 ms; pixel 2: 10 ms; pixel 4: 6, 6, 9 ms. Pixel index 6 is out of
  // range and ignored.
  const std::vector<std::int32_t> px{0, 4, 0, 2, 4, 4, 6};
  const std::vector<float> t{0.001f, 0.006f, 0.003f, 0.010f, 0.006f, 0.009f, 0.020f};
  TimeImages ti;
  build_time_images(view(3, 2, px, t), ti);
  // I: [2 0 1; 0 3 0]
  const int I[6] = {2, 0, 1, 0, 3, 0};
  // T: pixel 0 = 2 ms, pixel 2 = 10 ms, pixel 4 = 7 ms; min 2 ms, max 10 ms over pixels with events.
  const float T[6] = {0.002f, 0, 0.010f, 0, 0.007f, 0};
  // N = (T − 2 ms) / 8 ms: 0, 1, 0.625; pixels without events are 0.
  const float N[6] = {0.0f, 0, 1.0f, 0, 0.625f, 0};
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(ti.count.at<std::int32_t>(i / 3, i % 3), I[i]) << i;
    EXPECT_NEAR(ti.mean_time_s.at<float>(i / 3, i % 3), T[i], 1e-7) << i;
    EXPECT_NEAR(ti.normalized.at<float>(i / 3, i % 3), N[i], 1e-6) << i;
  }
  EXPECT_EQ(ti.count.type(), CV_32S);
  EXPECT_EQ(ti.mean_time_s.type(), CV_32F);
  EXPECT_EQ(ti.normalized.type(), CV_32F);
  EXPECT_EQ(ti.events, 6);
  EXPECT_EQ(ti.pixels_with_events, 3);
  EXPECT_NEAR(ti.t_min_s, 0.002, 1e-7);
  EXPECT_NEAR(ti.t_max_s, 0.010, 1e-7);
  EXPECT_NEAR(ti.mean_normalized, (0 + 1 + 0.625) / 3, 1e-6);  // over pixels with events only
}

TEST(TimeImages, BuffersAreResetBetweenWindows) {
  TimeImages ti;
  build_time_images(view(3, 2, {0, 1, 2}, {0.001f, 0.002f, 0.003f}), ti);
  build_time_images(view(3, 2, {5}, {0.004f}), ti);
  EXPECT_EQ(cv::countNonZero(ti.count), 1);
  EXPECT_EQ(ti.count.at<std::int32_t>(1, 2), 1);
  // A single pixel with events: no temporal contrast, N is 0 everywhere.
  EXPECT_EQ(cv::countNonZero(ti.normalized), 0);
  EXPECT_NEAR(ti.mean_time_s.at<float>(1, 2), 0.004, 1e-7);
}

// Prepared ahead (as Detector's constructor does): the first window writes into those buffers,
// with the same images as unprepared ones.
TEST(TimeImages, PreparedBuffersAreTheFirstWindowsAndGiveTheSameImages) {
  TimeImages prepared, fresh;
  prepare_time_images(prepared, 3, 2);
  ASSERT_EQ(prepared.count.size(), cv::Size(3, 2));
  EXPECT_EQ(cv::countNonZero(prepared.count), 0);
  const void* count_data = prepared.count.data;
  const void* accumulator_data = prepared.accumulator.data;
  const std::vector<std::int32_t> px{0, 4, 0, 2};
  const std::vector<float> t{0.001f, 0.006f, 0.003f, 0.010f};
  const CompensatedEventsView first = view(3, 2, px, t);
  build_time_images(first, prepared);
  build_time_images(first, fresh);
  EXPECT_EQ(prepared.count.data, count_data);
  EXPECT_EQ(prepared.accumulator.data, accumulator_data);
  EXPECT_EQ(cv::countNonZero(prepared.count != fresh.count), 0);
  EXPECT_EQ(cv::countNonZero(prepared.normalized != fresh.normalized), 0);
  EXPECT_EQ(prepared.events, fresh.events);
  // Prepared again at the same size: nothing is re-made or blanked (the next window relies on it).
  prepare_time_images(prepared, 3, 2);
  EXPECT_EQ(prepared.count.data, count_data);
  EXPECT_EQ(prepared.count.at<std::int32_t>(0, 0), 2);
}

TEST(TimeImages, EmptyWindow) {
  TimeImages ti;
  build_time_images(view(4, 3, {}, {}), ti);
  EXPECT_EQ(ti.events, 0);
  EXPECT_EQ(ti.pixels_with_events, 0);
  EXPECT_EQ(cv::countNonZero(ti.count), 0);
  EXPECT_EQ(ti.mean_normalized, 0);
}

}  // namespace
}  // namespace fdv
