// The detector's allocation-free passes (segment, Preprocessor, the Gaussian fit's marginals,
// label_components / retrieve_region) against the OpenCV calls they replaced, on random images:
// the same results to the bit, except the mean filter (within a stated tolerance).
#include <array>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <utility>

#include "fdv/detection/gaussian_fit.h"
#include "fdv/detection/segmentation.h"

namespace fdv {
namespace {

/// A sparse non-negative image like a segmentation: blobs of random values (some touching the
/// border), isolated pixels, and a few thin lines.
cv::Mat random_sparse(int w, int h, std::mt19937& rng, double noise_fraction = 0.01) {
  cv::Mat S = cv::Mat::zeros(h, w, CV_32F);
  std::uniform_real_distribution<float> value(0.05f, 1.0f);
  std::uniform_int_distribution<int> x(0, w - 1), y(0, h - 1),
      side(1, std::max(2, std::min(w, h) / 5));
  for (int b = 0; b < 6; ++b) {
    const cv::Rect r =
        cv::Rect(x(rng) - 2, y(rng) - 2, side(rng), side(rng)) & cv::Rect(0, 0, w, h);
    for (int yy = r.y; yy < r.y + r.height; ++yy)
      for (int xx = r.x; xx < r.x + r.width; ++xx)
        if (rng() % 5 != 0) S.at<float>(yy, xx) = value(rng);
  }
  const int noise = static_cast<int>(noise_fraction * w * h);
  for (int i = 0; i < noise; ++i) S.at<float>(y(rng), x(rng)) = value(rng);
  const int row = y(rng);
  for (int xx = 0; xx < w; xx += 2) S.at<float>(row, xx) = value(rng);
  return S;
}

TEST(OpenCvEquivalence, SegmentMatchesThresholdCompareAndCount) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int w = 37 + trial * 13, h = 23 + trial * 7;
    TimeImages ti;
    ti.normalized = cv::Mat::zeros(h, w, CV_32F);
    ti.count = cv::Mat::zeros(h, w, CV_32S);
    std::uniform_real_distribution<float> n(0.0f, 1.0f);
    for (int i = 0; i < w * h / 3; ++i) {
      const int p = static_cast<int>(rng() % static_cast<unsigned>(w * h));
      ti.normalized.at<float>(p / w, p % w) = (rng() % 10 == 0) ? 0.0f : n(rng);
      ti.count.at<std::int32_t>(p / w, p % w) = 1 + static_cast<int>(rng() % 4);
    }
    ti.normalized.at<float>(0, 0) = 0.5f;  // exactly at θ = 0.5
    ti.count.at<std::int32_t>(0, 0) = 3;
    for (const double theta : {-1.0, 0.0, 0.5, 0.73, 1.0})
      for (const int min_events : {1, 2, 3}) {
        // The earlier OpenCV formulation.
        cv::Mat expected, low;
        const float th =
            std::nextafter(static_cast<float>(theta), -std::numeric_limits<float>::infinity());
        cv::threshold(ti.normalized, expected, th, 0.0, cv::THRESH_TOZERO);
        if (min_events > 1) {
          cv::compare(ti.count, min_events, low, cv::CMP_LT);
          expected.setTo(0, low);
        }
        cv::Mat S;
        const SegmentResult r = segment(ti, theta, min_events, S);
        EXPECT_EQ(r.pixels, cv::countNonZero(expected));
        EXPECT_EQ(cv::norm(S, expected, cv::NORM_INF), 0.0);
        cv::Mat nz;
        cv::compare(expected, 0, nz, cv::CMP_NE);
        EXPECT_EQ(r.bounds, cv::boundingRect(nz)) << theta << " " << min_events;
      }
  }
}

/// The earlier pre-processing: OpenCV's box filter, opening and square.
cv::Mat opencv_preprocess(const cv::Mat& S, int k1, int k2) {
  const cv::Mat box = cv::Mat::ones(1, k1, CV_32F) / static_cast<double>(k1);
  cv::Mat M, P;
  cv::sepFilter2D(S, M, CV_32F, box, box, cv::Point(-1, -1), 0, cv::BORDER_CONSTANT);
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k2, k2));
  cv::erode(M, P, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::dilate(P, P, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::multiply(P, P, P);
  return P;
}

TEST(OpenCvEquivalence, PreprocessorMatchesBoxFilterOpeningAndSquare) {
  // Tolerance: the mean is summed in another order than OpenCV's (which multiplies each axis by
  // float(1/k) and may fuse multiply-adds), a few float roundings of values ≤ 1; P = D² doubles the
  // relative error. The opening is exact, so P is zero exactly where OpenCV's is.
  constexpr double kTolerance = 1e-6;
  double max_difference = 0;
  std::mt19937 rng(11);
  for (const auto& [k1, k2] : std::initializer_list<std::pair<int, int>>{
           {3, 3}, {1, 3}, {3, 1}, {5, 3}, {3, 5}, {7, 7}, {1, 1}}) {
    DetectorOptions o;
    o.mean_filter_px = k1;
    o.opening_px = k2;
    Preprocessor pre(o);
    for (int trial = 0; trial < 12; ++trial) {
      const int w = 20 + static_cast<int>(rng() % 200), h = 15 + static_cast<int>(rng() % 150);
      cv::Mat S = random_sparse(w, h, rng);
      if (trial == 5) S.setTo(0);
      cv::Mat nz;
      cv::compare(S, 0, nz, cv::CMP_GT);
      const cv::Mat expected = opencv_preprocess(S, k1, k2);
      const cv::Mat& P = pre.run(S, cv::boundingRect(nz));
      SCOPED_TRACE(::testing::Message() << "k1 " << k1 << " k2 " << k2 << " trial " << trial);
      ASSERT_EQ(P.size(), S.size());
      const double difference = cv::norm(P, expected, cv::NORM_INF);
      EXPECT_LE(difference, kTolerance);
      max_difference = std::max(max_difference, difference);
      cv::Mat zero_here, zero_there;
      cv::compare(P, 0, zero_here, cv::CMP_EQ);
      cv::compare(expected, 0, zero_there, cv::CMP_EQ);
      EXPECT_EQ(cv::countNonZero(zero_here != zero_there), 0);
      // Zero outside the reported bounds.
      cv::Mat outside = P.clone();
      outside(pre.nonzero_bounds()).setTo(0);
      EXPECT_EQ(cv::countNonZero(outside), 0);
      // The whole-image function gives the same image to the bit.
      cv::Mat P2, scratch;
      preprocess(S, o, P2, scratch);
      EXPECT_EQ(cv::norm(P, P2, cv::NORM_INF), 0.0);
    }
  }
  RecordProperty("max_abs_difference", ::testing::PrintToString(max_difference));
}

TEST(OpenCvEquivalence, AReusedPreprocessorLeavesNothingOfEarlierImages) {
  // Same image size at every call (buffers reused): S is a random sparse patch at a random place,
  // so the written rectangle moves, shrinks and grows; P must equal a fresh computation.
  std::mt19937 rng(13);
  const DetectorOptions o;
  Preprocessor pre(o);
  for (int trial = 0; trial < 30; ++trial) {
    cv::Mat S = cv::Mat::zeros(120, 160, CV_32F);
    const int w = 1 + static_cast<int>(rng() % 80), h = 1 + static_cast<int>(rng() % 60);
    const cv::Rect at(static_cast<int>(rng() % (160 - w + 1)),
                      static_cast<int>(rng() % (120 - h + 1)), w, h);
    random_sparse(w, h, rng, 0.05).copyTo(S(at));
    cv::Mat nz;
    cv::compare(S, 0, nz, cv::CMP_GT);
    const cv::Rect bounds = trial % 7 == 3 ? cv::Rect() : cv::boundingRect(nz);
    if (bounds.area() == 0) S.setTo(0);
    cv::Mat expected, scratch;
    preprocess(S, o, expected, scratch);
    SCOPED_TRACE(trial);
    EXPECT_EQ(cv::norm(pre.run(S, bounds), expected, cv::NORM_INF), 0.0);
  }
}

/// The earlier Algorithm 1 (cv::reduce for the marginals), kept here as the reference.
GaussianFit reduce_fit(const cv::Mat& P, const Eigen::Vector2d& c0, const Eigen::Vector2d& l0,
                       const DetectorOptions& o) {
  GaussianFit fit;
  Eigen::Vector2d c = c0, l = l0;
  cv::Mat col_sums, row_sums;
  for (int k = 0; k < o.fit_max_iterations; ++k) {
    fit.iterations = k + 1;
    const cv::Rect r = box_pixels(
        {c.x() - 0.5 * l.x(), c.y() - 0.5 * l.y(), c.x() + 0.5 * l.x(), c.y() + 0.5 * l.y()},
        P.cols, P.rows);
    double sw = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
    if (r.area() > 0) {
      cv::reduce(P(r), col_sums, 0, cv::REDUCE_SUM, CV_32F);
      cv::reduce(P(r), row_sums, 1, cv::REDUCE_SUM, CV_32F);
      for (int i = 0; i < r.width; ++i) {
        const double p = col_sums.at<float>(i), x = r.x + i;
        sw += p;
        sx += p * x;
        sxx += p * x * x;
      }
      for (int j = 0; j < r.height; ++j) {
        const double p = row_sums.at<float>(j), y = r.y + j;
        sy += p * y;
        syy += p * y * y;
      }
    }
    if (!(sw > 0)) {
      fit.empty_roi = true;
      break;
    }
    const Eigen::Vector2d mu(sx / sw, sy / sw);
    const Eigen::Vector2d var(std::max(0.0, sxx / sw - mu.x() * mu.x()),
                              std::max(0.0, syy / sw - mu.y() * mu.y()));
    const Eigen::Vector2d l_next(std::max(o.fit_min_size_px, 4 * std::sqrt(var.x())),
                                 std::max(o.fit_min_size_px, 4 * std::sqrt(var.y())));
    const double relative = o.fit_delta_fraction * l.minCoeff();
    const double delta_c = std::max(o.fit_delta_center_px, relative), delta_l = std::max(o.fit_delta_size_px, relative);
    const bool done = (mu - c).norm() < delta_c && std::abs(l_next.x() - l.x()) < delta_l &&
                      std::abs(l_next.y() - l.y()) < delta_l;
    c = mu;
    l = l_next;
    if (done) {
      fit.converged = true;
      break;
    }
    if (l.x() > l0.x() && l.y() > l0.y()) {
      fit.diverged = true;
      break;
    }
  }
  fit.center = c;
  fit.size = l;
  return fit;
}

TEST(OpenCvEquivalence, FirstMaximumMatchesMinMaxLoc) {
  std::mt19937 rng(21);
  for (int trial = 0; trial < 200; ++trial) {
    const int w = 1 + static_cast<int>(rng() % 200), h = 1 + static_cast<int>(rng() % 150);
    cv::Mat m = random_sparse(w, h, rng, trial % 2 ? 0.01 : 0.3);
    // Ties: a few pixels set to the image's maximum, so that the first in raster order must win.
    if (trial % 4 == 0) {
      double mx = 0;
      cv::minMaxLoc(m, nullptr, &mx);
      for (int k = 0; k < 3; ++k) m.at<float>(static_cast<int>(rng() % h), static_cast<int>(rng() % w)) = static_cast<float>(mx);
    }
    std::uniform_int_distribution<int> x(-10, w + 10), y(-10, h + 10);
    const int x0 = x(rng), y0 = y(rng);
    const cv::Rect r(x0, y0, 1 + static_cast<int>(rng() % (w + 20)), 1 + static_cast<int>(rng() % (h + 20)));
    const cv::Rect c = r & cv::Rect(0, 0, w, h);
    if (c.area() == 0) continue;
    double mx = 0;
    cv::Point at;
    cv::minMaxLoc(m(c), nullptr, &mx, nullptr, &at);
    const MaxLocation ours = first_maximum(m, r);
    SCOPED_TRACE(trial);
    EXPECT_EQ(ours.value, static_cast<float>(mx));
    EXPECT_EQ(ours.at, at + c.tl());
  }
  const cv::Mat zeros = cv::Mat::zeros(4, 4, CV_32F);
  EXPECT_EQ(first_maximum(zeros, {1, 2, 2, 2}).at, cv::Point(1, 2));  // all equal: the first pixel
  EXPECT_EQ(first_maximum(zeros, {10, 10, 2, 2}).value, 0.0f);         // outside: nothing, 0
}

TEST(OpenCvEquivalence, GaussianFitMatchesTheReduceVersionToTheBit) {
  std::mt19937 rng(3);
  DetectorOptions o;
  for (int trial = 0; trial < 40; ++trial) {
    const int w = 30 + static_cast<int>(rng() % 400), h = 20 + static_cast<int>(rng() % 300);
    cv::Mat P = random_sparse(w, h, rng, 0.002);
    cv::multiply(P, P, P);
    std::uniform_real_distribution<double> u(0, 1);
    const Eigen::Vector2d c0(u(rng) * w, u(rng) * h),
        l0(0.1 * w + u(rng) * w, 0.1 * h + u(rng) * h);
    const GaussianFit a = iterative_gaussian_fit(P, c0, l0, o), b = reduce_fit(P, c0, l0, o);
    SCOPED_TRACE(trial);
    EXPECT_EQ(a.iterations, b.iterations);
    EXPECT_EQ(a.converged, b.converged);
    EXPECT_EQ(a.empty_roi, b.empty_roi);
    EXPECT_EQ(a.diverged, b.diverged);
    EXPECT_EQ(a.center, b.center);
    EXPECT_EQ(a.size, b.size);
  }
}

TEST(OpenCvEquivalence, LabelsAndStatsMatchConnectedComponentsWithStats) {
  std::mt19937 rng(5);
  RegionScratch scratch;  // reused, as in the detector (labels larger than some images: top-left corner)
  for (int trial = 0; trial < 40; ++trial) {
    const int w = 1 + static_cast<int>(rng() % 120), h = 1 + static_cast<int>(rng() % 90);
    // Densities from sparse to nearly full, so that components merge in every direction.
    const double density = (trial % 8) / 8.0 + 0.05;
    cv::Mat image = cv::Mat::zeros(h, w, CV_32F);
    std::bernoulli_distribution on(density);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (on(rng)) image.at<float>(y, x) = 0.5f;
    cv::Mat mask, cv_labels, cv_stats, centroids;
    cv::compare(image, 0.0, mask, cv::CMP_GT);
    const int n_cv =
        cv::connectedComponentsWithStats(mask, cv_labels, cv_stats, centroids, 8, CV_32S);
    const int n = label_components(image, scratch);
    const cv::Mat& labels = scratch.labels;
    const std::vector<ComponentStats>& stats = scratch.stats;
    SCOPED_TRACE(::testing::Message() << trial << ": " << w << "x" << h << " density " << density);
    ASSERT_EQ(n, n_cv);
    EXPECT_EQ(cv::norm(labels(cv::Rect(0, 0, w, h)), cv_labels, cv::NORM_INF), 0.0);
    for (int i = 1; i < n; ++i) {
      const int* st = cv_stats.ptr<int>(i);
      EXPECT_EQ(stats[i].left, st[cv::CC_STAT_LEFT]) << i;
      EXPECT_EQ(stats[i].top, st[cv::CC_STAT_TOP]) << i;
      EXPECT_EQ(stats[i].width, st[cv::CC_STAT_WIDTH]) << i;
      EXPECT_EQ(stats[i].height, st[cv::CC_STAT_HEIGHT]) << i;
      EXPECT_EQ(stats[i].area, st[cv::CC_STAT_AREA]) << i;
    }
  }
}

/// The earlier retrieval (OpenCV's connected components), kept here as the reference.
std::optional<Region> opencv_retrieve(const cv::Mat& P, const Box2D& roi, const cv::Rect& search,
                                      const DetectorOptions& o) {
  const cv::Rect area = search & cv::Rect(0, 0, P.cols, P.rows);
  if (area.area() == 0) return std::nullopt;
  const cv::Mat Ps = P(area);
  cv::Mat mask, labels, stats, centroids;
  cv::compare(Ps, 0.0, mask, cv::CMP_GT);
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  if (n <= 1) return std::nullopt;
  cv::Rect roi_px = box_pixels(roi, P.cols, P.rows);
  roi_px.x -= area.x;
  roi_px.y -= area.y;
  std::vector<double> mass(3 * static_cast<std::size_t>(n), 0.0);
  int best = -1;
  for (int i = 1; i < n; ++i) {
    const int* st = stats.ptr<int>(i);
    if (st[cv::CC_STAT_AREA] < o.region_min_area_px) continue;
    const cv::Rect comp(st[cv::CC_STAT_LEFT], st[cv::CC_STAT_TOP], st[cv::CC_STAT_WIDTH],
                        st[cv::CC_STAT_HEIGHT]);
    if ((comp & roi_px).area() == 0) continue;
    double* m = &mass[3 * static_cast<std::size_t>(i)];
    for (int y = comp.y; y < comp.y + comp.height; ++y)
      for (int x = comp.x; x < comp.x + comp.width; ++x) {
        if (labels.at<std::int32_t>(y, x) != i) continue;
        const float p = Ps.at<float>(y, x);
        m[0] += p;
        m[1] += static_cast<double>(p) * x;
        m[2] += static_cast<double>(p) * y;
      }
    if (best < 0 || m[0] > mass[3 * static_cast<std::size_t>(best)]) best = i;
  }
  if (best < 0 || !(mass[3 * static_cast<std::size_t>(best)] > 0)) return std::nullopt;
  const int* st = stats.ptr<int>(best);
  const double* m = &mass[3 * static_cast<std::size_t>(best)];
  const double left = area.x + st[cv::CC_STAT_LEFT], top = area.y + st[cv::CC_STAT_TOP];
  Region r;
  r.box = {left - 0.5, top - 0.5, left + st[cv::CC_STAT_WIDTH] - 0.5,
           top + st[cv::CC_STAT_HEIGHT] - 0.5};
  r.center = {area.x + m[1] / m[0], area.y + m[2] / m[0]};
  r.mass = m[0];
  r.area_px = st[cv::CC_STAT_AREA];
  return r;
}

void expect_same_region(const Region& a, const Region& b) {
  EXPECT_EQ(a.box.x0, b.box.x0);
  EXPECT_EQ(a.box.y0, b.box.y0);
  EXPECT_EQ(a.box.x1, b.box.x1);
  EXPECT_EQ(a.box.y1, b.box.y1);
  EXPECT_EQ(a.center, b.center);
  EXPECT_EQ(a.mass, b.mass);
  EXPECT_EQ(a.area_px, b.area_px);
}

TEST(OpenCvEquivalence, RetrievalMatchesTheConnectedComponentsVersion) {
  std::mt19937 rng(9);
  DetectorOptions o;
  RegionScratch scratch;
  scratch.reserve(320, 240);
  int found = 0, second_used = 0;
  for (int trial = 0; trial < 150; ++trial) {
    const int w = 40 + static_cast<int>(rng() % 280), h = 30 + static_cast<int>(rng() % 210);
    cv::Mat P = random_sparse(w, h, rng, 0.02);
    if (trial % 3 == 0) {  // equal masses: identical blobs, the tie goes to the lower label
      P.setTo(0);
      P(cv::Rect(5, 6, 3, 3)).setTo(0.25f);
      P(cv::Rect(20, 5, 3, 3)).setTo(0.25f);
    }
    std::uniform_int_distribution<int> x(0, w - 1), y(0, h - 1);
    const cv::Rect search(x(rng) - w / 3, y(rng) - h / 3, w / 2 + x(rng) / 2, h / 2 + y(rng) / 2);
    const double cx = x(rng), cy = y(rng);
    const Box2D roi{cx - w / 4.0, cy - h / 4.0, cx + w / 4.0, cy + h / 4.0};
    const auto a = retrieve_region(P, roi, search, o, scratch),
               b = opencv_retrieve(P, roi, search, o);
    SCOPED_TRACE(trial);
    ASSERT_EQ(a.has_value(), b.has_value());
    // Several ROIs on one labelling (the detector's "the failed fit's ROI, else the search area"):
    // the reference called for each ROI in turn until one yields a region.
    const std::array<Box2D, 2> rois{Box2D{cx - 4.0, cy - 4.0, cx + 4.0, cy + 4.0}, roi};
    const auto several = retrieve_region(P, rois, search, o, scratch);
    auto first_yielding = opencv_retrieve(P, rois[0], search, o);
    if (!first_yielding && b) {
      first_yielding = b;
      ++second_used;
    }
    ASSERT_EQ(several.has_value(), first_yielding.has_value());
    if (several) expect_same_region(*several, *first_yielding);
    if (!a) continue;
    ++found;
    expect_same_region(*a, *b);
  }
  EXPECT_GE(found, 20);        // the comparison was exercised
  EXPECT_GE(second_used, 10);  // and the fallback to the second ROI
}

}  // namespace
}  // namespace fdv
