// Adaptive threshold, segmentation and pre-processing on hand-made images.
#include <gtest/gtest.h>

#include <random>

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

TEST(Segmentation, PreprocessorReportsTheFirstMaximumInRasterOrder) {
  // Two equal plateaus: the higher row wins, and in it the leftmost pixel; a third, lower block
  // above both does not. Checked for one and for several threads (bands of rows), where the
  // plateaus fall in different bands.
  cv::Mat S = cv::Mat::zeros(200, 100, CV_32F);
  S(cv::Rect(60, 120, 5, 5)).setTo(0.9);
  S(cv::Rect(10, 150, 5, 5)).setTo(0.9);
  S(cv::Rect(30, 20, 5, 5)).setTo(0.5);
  DetectorOptions o;
  for (int threads : {1, 2, 5}) {
    Preprocessor pre(o);
    pre.run(S, cv::Rect(10, 20, 55, 135), threads);
    // 3x3 mean then 3x3 opening of a 5x5 block of 0.9: the inner 3x3 keeps 0.9, squared 0.81,
    // first reached at the block's top-left + 1.
    EXPECT_NEAR(pre.first_max().value, 0.81f, 1e-6) << threads;
    EXPECT_EQ(pre.first_max().at, cv::Point(61, 121)) << threads;
  }
  Preprocessor empty(o);
  empty.run(cv::Mat::zeros(200, 100, CV_32F), cv::Rect());
  EXPECT_EQ(empty.first_max().value, 0.0f);
}

TEST(Segmentation, BandsOfRowsOnSeveralThreadsGiveTheSameImages) {
  // segment() and Preprocessor::run split the rows between threads; S, its bounds, P and P's
  // nonzero bounds must be those of one thread, over consecutive calls whose supports differ
  // (the preprocessor zeroes what the previous call wrote). Random N and I on 640x480, with the
  // foreground in a different rectangle each time.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> n01(0.0f, 1.0f);
  std::uniform_int_distribution<int> events(0, 3);
  DetectorOptions o;
  Preprocessor one(o), many(o);
  const cv::Rect areas[] = {{0, 0, 640, 480}, {100, 50, 200, 300}, {600, 400, 40, 80}, {0, 0, 0, 0}, {3, 200, 500, 33}};
  for (const cv::Rect& area : areas) {
    SCOPED_TRACE(testing::Message() << area);
    TimeImages ti;
    ti.normalized = cv::Mat::zeros(480, 640, CV_32F);
    ti.count = cv::Mat::zeros(480, 640, CV_32S);
    for (int y = area.y; y < area.y + area.height; ++y)
      for (int x = area.x; x < area.x + area.width; ++x) {
        ti.count.at<std::int32_t>(y, x) = events(rng);
        ti.normalized.at<float>(y, x) = ti.count.at<std::int32_t>(y, x) > 0 ? n01(rng) : 0.0f;
      }
    cv::Mat S1, S2;
    const SegmentResult r1 = segment(ti, 0.6, 1, S1);
    const cv::Mat& P1 = one.run(S1, r1.bounds);
    for (int threads : {2, 3, 8}) {
      SCOPED_TRACE(testing::Message() << threads << " threads");
      const SegmentResult r2 = segment(ti, 0.6, 1, S2, threads);
      EXPECT_EQ(r2.pixels, r1.pixels);
      EXPECT_EQ(r2.bounds, r1.bounds);
      EXPECT_EQ(cv::norm(S1, S2, cv::NORM_INF), 0);
      const cv::Mat& P2 = many.run(S2, r2.bounds, threads);
      EXPECT_EQ(cv::norm(P1, P2, cv::NORM_INF), 0);
      EXPECT_EQ(many.nonzero_bounds(), one.nonzero_bounds());
      const MaxLocation searched = first_maximum(P2, many.nonzero_bounds());
      EXPECT_EQ(many.first_max().value, searched.value);
      EXPECT_EQ(many.first_max().at, searched.at);
    }
    if (area.area() > 0) {
      EXPECT_GT(r1.pixels, 0);  // the case is not vacuous
    }
  }
}

// Windows of events in bands of rows (as a window of the events near a few gates is), built into
// time images: segment() given the last result's bounds computes only the time images' event rows
// and blanks the rest of the last S, and must give the S, pixel count and bounds of a whole-image
// pass, window after window, on one and two threads.
TEST(Segmentation, OnlyTheRowsWithEventsGiveTheWholeImagesResult) {
  constexpr int kWidth = 346, kHeight = 260;
  std::mt19937 rng(11);
  const cv::Rect bands[] = {{0, 0, 346, 260}, {40, 20, 60, 30}, {200, 180, 90, 70},
                            {0, 0, 0, 0},     {10, 100, 30, 5}, {300, 0, 46, 12}};
  TimeImages ti;
  cv::Mat S_band[2];
  cv::Rect nonzero[2];
  for (const cv::Rect& band : bands) {
    SCOPED_TRACE(testing::Message() << band);
    std::vector<std::int32_t> pixel;
    std::vector<float> t_s;
    std::uniform_real_distribution<float> t(0.0f, 0.025f);
    for (int y = band.y; y < band.y + band.height; ++y)
      for (int x = band.x; x < band.x + band.width; ++x)
        for (int k = static_cast<int>(rng() % 3); k > 0; --k)
          pixel.push_back(y * kWidth + x), t_s.push_back(t(rng));
    const CompensatedEventsView view{0, 25 * kNsPerMs, kWidth, kHeight, pixel, t_s};
    build_time_images(view, ti);
    if (band.area() > 0 && band.height < kHeight) {  // the band is found, and it is not the image
      EXPECT_LE(ti.event_rows.start, band.y);
      EXPECT_GE(ti.event_rows.end, band.y + band.height);
      EXPECT_LT(ti.event_rows.size(), kHeight);
    }
    cv::Mat S_full;
    const SegmentResult full = segment(ti, 0.5, 1, S_full);
    for (int threads : {1, 2}) {
      SCOPED_TRACE(testing::Message() << threads << " threads");
      cv::Mat& S = S_band[threads - 1];
      if (S.empty()) S = cv::Mat::zeros(kHeight, kWidth, CV_32F);
      const SegmentResult rows = segment(ti, 0.5, 1, S, threads, nonzero[threads - 1]);
      nonzero[threads - 1] = rows.bounds;
      EXPECT_EQ(rows.pixels, full.pixels);
      EXPECT_EQ(rows.bounds, full.bounds);
      EXPECT_EQ(cv::norm(S, S_full, cv::NORM_INF), 0);
    }
    if (band.area() > 0) {
      EXPECT_GT(full.pixels, 0);  // the case is not vacuous
    }
  }
}

}  // namespace
}  // namespace fdv
