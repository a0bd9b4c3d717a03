// The optimised time-image builder (time_images.cpp: block-sparse passes, buffers reused between
// windows) against the plain reference (reference_time_images.h). Both follow the arithmetic
// time_images.h defines, so the images, counts and min/max T must be identical; only
// mean_normalized may differ, in the last bits (its Σ T is summed in a different order).
#include <gtest/gtest.h>

#include <random>

#include "fdv/detection/reference_time_images.h"
#include "fdv/detection/time_images.h"

namespace fdv {
namespace {

struct Window {
  int width = 0, height = 0;
  std::vector<std::int32_t> pixel;
  std::vector<float> t_s;
  CompensatedEventsView view() const {
    CompensatedEventsView v;
    v.width = width;
    v.height = height;
    v.pixel = pixel;
    v.t_s = t_s;
    return v;
  }
};

// n events: a dense blob (many events per pixel) plus scattered ones; a few indices out of range.
Window random_window(int w, int h, int n, unsigned seed, float t_lo = 0.0f) {
  Window win{w, h, {}, {}};
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> px(0, w * h - 1), bx(w / 3, w / 3 + 20), by(h / 3, h / 3 + 20);
  std::uniform_real_distribution<float> t(t_lo, 0.025f);
  for (int i = 0; i < n; ++i) {
    win.pixel.push_back(i % 3 == 0 ? by(rng) * w + bx(rng) : px(rng));
    win.t_s.push_back(t(rng));
  }
  if (n > 6) {
    win.pixel[5] = -1;
    win.pixel[6] = w * h;
  }
  return win;
}

void expect_identical(const TimeImages& a, const TimeImages& b) {
  EXPECT_EQ(cv::norm(a.count, b.count, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.sum_time_s, b.sum_time_s, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.mean_time_s, b.mean_time_s, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.normalized, b.normalized, cv::NORM_INF), 0);
  EXPECT_EQ(a.events, b.events);
  EXPECT_EQ(a.pixels_with_events, b.pixels_with_events);
  EXPECT_EQ(a.t_min_s, b.t_min_s);
  EXPECT_EQ(a.t_max_s, b.t_max_s);
  EXPECT_NEAR(a.mean_normalized, b.mean_normalized, 1e-12);
}

// Builds `win` into `fast` (reused over windows) with `threads` and compares it with the reference.
void build_and_compare(const Window& win, int threads, TimeImages& fast) {
  SCOPED_TRACE(testing::Message() << threads << " threads, " << win.pixel.size() << " events");
  CompensatedEventsView v = win.view();
  v.threads = threads;
  TimeImages ref;
  build_time_images(v, fast);
  reference_time_images(win.view(), ref);
  expect_identical(fast, ref);
}

TEST(TimeImagesReference, OptimisedEqualsReferenceOverConsecutiveWindows) {
  // One TimeImages reused over windows of different content (the optimised builder blanks only
  // the blocks the previous window used), including an empty one and one with negative times.
  // 346x260: the pixel count is not a multiple of the 16-pixel block (a partial last block).
  for (const auto& [w, h] : {std::pair{640, 480}, std::pair{346, 260}}) {
    TimeImages fast;
    const Window windows[] = {random_window(w, h, 120'000, 1), random_window(w, h, 3'000, 2),
                              Window{w, h, {}, {}},            random_window(w, h, 50'000, 3, -0.01f),
                              random_window(w, h, 1, 4),       random_window(w, h, 120'000, 5)};
    for (const Window& win : windows) {
      SCOPED_TRACE(testing::Message() << w << "x" << h << ", " << win.pixel.size() << " events");
      TimeImages ref;
      build_time_images(win.view(), fast);
      reference_time_images(win.view(), ref);
      expect_identical(fast, ref);
    }
  }
}

TEST(TimeImagesReference, AnyThreadCountGivesTheSameImagesAsOne) {
  // Split into pixel ranges: every pixel still sums its events in event order, and Σ T is summed
  // per fixed chunk, so even mean_normalized is bit-identical.
  for (const Window& win : {random_window(640, 480, 150'000, 21), random_window(346, 260, 60'000, 22)}) {
    TimeImages one;
    build_time_images(win.view(), one);
    for (int threads : {2, 3, 8}) {
      CompensatedEventsView v = win.view();
      v.threads = threads;
      TimeImages many;
      build_time_images(v, many);
      expect_identical(one, many);
      EXPECT_EQ(one.mean_normalized, many.mean_normalized);
    }
  }
}

TEST(TimeImagesReference, SeveralThreadsReusedOverConsecutiveWindowsEqualTheReference) {
  // The threaded builder keeps its buffers too (blocks of the previous window blanked by the part
  // that owns them): the windows of the first test, through one TimeImages per thread count.
  for (int threads : {2, 3}) {
    TimeImages fast;
    const Window windows[] = {random_window(640, 480, 120'000, 1), random_window(640, 480, 40'000, 2),
                              Window{640, 480, {}, {}}, random_window(640, 480, 50'000, 3, -0.01f),
                              random_window(640, 480, 120'000, 5)};
    for (const Window& win : windows) build_and_compare(win, threads, fast);
  }
}

// n events in a size x size patch with its corner at (u0, v0).
Window patch_window(int w, int h, int u0, int v0, int size, int n, unsigned seed) {
  Window win{w, h, {}, {}};
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(0, size - 1);
  std::uniform_real_distribution<float> t(0.0f, 0.025f);
  for (int i = 0; i < n; ++i) {
    win.pixel.push_back((v0 + d(rng)) * w + u0 + d(rng));
    win.t_s.push_back(t(rng));
  }
  return win;
}

TEST(TimeImagesReference, SparseWindowsVisitOnlyTheGroupsTheyAndThePreviousOneTouch) {
  // A far ball's windows: a patch that moves across the frame. The previous window's patch must
  // be blanked, every other group of 16 blocks (256 pixels) skipped. Each of a 20x20 patch's rows
  // lies in at most 2 groups: at most 40 groups, 640 blocks of the frame's 57,600.
  constexpr int kW = 1280, kH = 720;
  constexpr std::size_t kGroupBlocks = 16, kMaxGroupsPerPatch = 40, kAllGroups = kW * kH / 256;
  for (int threads : {1, 2}) {
    TimeImages fast;
    build_time_images(random_window(kW, kH, 120'000, 1).view(), fast);  // every group in use
    const Window windows[] = {patch_window(kW, kH, 100, 50, 20, 300, 2), patch_window(kW, kH, 900, 600, 20, 300, 3),
                              patch_window(kW, kH, 910, 605, 20, 300, 4), Window{kW, kH, {}, {}},
                              patch_window(kW, kH, 10, 700, 20, 50, 5)};
    std::size_t previous_groups = kAllGroups;
    for (const Window& win : windows) {
      build_and_compare(win, threads, fast);
      const std::size_t groups = win.pixel.empty() ? 0 : kMaxGroupsPerPatch;
      EXPECT_LE(fast.blocks_visited, (groups + previous_groups) * kGroupBlocks);
      previous_groups = groups;
    }
  }
}

TEST(TimeImagesReference, ReferenceMatchesHandComputedValues) {
  // The reference itself, on the hand-computed window of time_images_test.cpp.
  Window win{3, 2, {0, 4, 0, 2, 4, 4, 6}, {0.001f, 0.006f, 0.003f, 0.010f, 0.006f, 0.009f, 0.020f}};
  TimeImages ref;
  reference_time_images(win.view(), ref);
  EXPECT_EQ(ref.count.at<std::int32_t>(0, 0), 2);
  EXPECT_EQ(ref.count.at<std::int32_t>(1, 1), 3);
  EXPECT_NEAR(ref.mean_time_s.at<float>(1, 1), 0.007f, 1e-7);
  EXPECT_NEAR(ref.normalized.at<float>(1, 1), 0.625f, 1e-6);
  EXPECT_EQ(ref.events, 6);
  EXPECT_NEAR(ref.mean_normalized, (0 + 1 + 0.625) / 3, 1e-6);
}

TEST(TimeImagesReference, ReplacedBuffersAreRebuiltInFull) {
  // A caller that assigns its own matrices (here: filled with garbage) gets correct images.
  const Window a = random_window(64, 48, 500, 7), b = random_window(64, 48, 400, 8);
  TimeImages fast, ref;
  build_time_images(a.view(), fast);
  fast.normalized = cv::Mat(48, 64, CV_32F, cv::Scalar(3.0f));
  fast.count = cv::Mat(48, 64, CV_32S, cv::Scalar(7));
  build_time_images(b.view(), fast);
  reference_time_images(b.view(), ref);
  expect_identical(fast, ref);
}

}  // namespace
}  // namespace fdv
