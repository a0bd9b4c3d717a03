// Iterative Gaussian fitting (Algorithm 1) on a synthetic blob with background noise, and
// moving-region retrieval picking the right connected component.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fdv/detection/gaussian_fit.h"

namespace fdv {
namespace {

// Fixed point of L ← 4σ for a Gaussian blob of standard deviation s: the ROI half-side a
// satisfies a = 2·σ_t(a), σ_t = std of the Gaussian truncated to [−a, a]:
//   σ_t² = s²·(1 − 2(a/s)·φ(a/s) / (2Φ(a/s) − 1)).
double fixed_point_side(double s) {
  double a = 2 * s;
  for (int i = 0; i < 200; ++i) {
    const double z = a / s;
    const double phi = std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI);
    const double big_phi_2m1 = std::erf(z / std::sqrt(2.0));
    a = 2 * s * std::sqrt(1 - 2 * z * phi / big_phi_2m1);
  }
  return 2 * a;
}

TEST(GaussianFit, ConvergesOnABlobInNoise) {
  const double sigma = 4.0;
  const Eigen::Vector2d center(100.3, 80.7);
  cv::Mat P(240, 320, CV_32F);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> noise(0.0f, 0.002f);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) {
      const double d2 = (x - center.x()) * (x - center.x()) + (y - center.y()) * (y - center.y());
      P.at<float>(y, x) = static_cast<float>(std::exp(-0.5 * d2 / (sigma * sigma))) + noise(rng);
    }
  DetectorOptions o;
  // Start where the detector would: the brightest pixel, half-image ROI.
  o.fit_delta_center_px = 0.05;  // tight stopping: the test checks the fixed point of L ← 4σ
  o.fit_delta_size_px = 0.05;
  const GaussianFit fit = iterative_gaussian_fit(P, {100, 81}, {160, 120}, o);
  EXPECT_TRUE(fit.converged);
  EXPECT_LT(fit.iterations, o.fit_max_iterations);
  EXPECT_NEAR(fit.center.x(), center.x(), 0.3);
  EXPECT_NEAR(fit.center.y(), center.y(), 0.3);
  // Continuous fixed point ≈ 2.9 σ. On the pixel grid the ROI takes whole pixels whose centres
  // lie inside it, which widens the effective window by up to half a pixel each side: the
  // discrete fixed point of the noise-free blob (iterated here on its own, in 1-D about the true
  // centre) is larger.
  const double L = fixed_point_side(sigma);
  EXPECT_NEAR(L / sigma, 2.9, 0.05);
  double Ld = L;
  for (int it = 0; it < 100; ++it) {
    double sw = 0, sxx = 0;
    for (int x = static_cast<int>(std::ceil(center.x() - Ld / 2)); x <= std::floor(center.x() + Ld / 2); ++x) {
      const double d = x - center.x(), p = std::exp(-0.5 * d * d / (sigma * sigma));
      sw += p;
      sxx += p * d * d;
    }
    Ld = 4 * std::sqrt(sxx / sw);
  }
  EXPECT_GT(Ld, L);
  EXPECT_LT(Ld, L + 1.5);
  // The discrete map L ← 4σ is a step function of L (the pixel set changes in whole pixels), so
  // neighbouring pixel sets can both be self-consistent: one pixel of tolerance.
  EXPECT_NEAR(fit.size.x(), Ld, 1.0);
  EXPECT_NEAR(fit.size.y(), Ld, 1.0);
}

TEST(GaussianFit, UniformImageDiverges) {
  // No blob: a uniform ROI of side w has σ = w/√12 and 4σ = 1.155 w, so the ROI grows: after one
  // iteration it is 92.4 x 69.3, larger than the initial 80 x 60 on both sides, and the fit stops
  // as diverged (unconverged).
  cv::Mat P(120, 160, CV_32F, cv::Scalar(0.5));
  const GaussianFit fit = iterative_gaussian_fit(P, {79.5, 59.5}, {80, 60}, DetectorOptions{});
  EXPECT_FALSE(fit.converged);
  EXPECT_TRUE(fit.diverged);
  EXPECT_EQ(fit.iterations, 1);
  // The ROI [39.5, 119.5] holds the 80 pixels 40..119: σ² = (80² − 1)/12.
  EXPECT_NEAR(fit.size.x(), 4 * std::sqrt((80.0 * 80.0 - 1) / 12), 1e-3);
  EXPECT_NEAR(fit.size.y(), 4 * std::sqrt((60.0 * 60.0 - 1) / 12), 1e-3);
}

TEST(GaussianFit, EmptyRoiEndsUnconverged) {
  cv::Mat P = cv::Mat::zeros(50, 50, CV_32F);
  const GaussianFit fit = iterative_gaussian_fit(P, {25, 25}, {25, 25}, DetectorOptions{});
  EXPECT_FALSE(fit.converged);
  EXPECT_TRUE(fit.empty_roi);
}

TEST(RegionRetrieval, PicksTheHeaviestComponentInTheRoi) {
  cv::Mat P = cv::Mat::zeros(100, 100, CV_32F);
  P(cv::Rect(10, 10, 20, 10)).setTo(0.01);   // A: 200 px, mass 2, in the ROI
  P(cv::Rect(40, 40, 3, 3)).setTo(0.9);      // B: 9 px, mass 8.1, in the ROI
  P.at<float>(40, 41) = 1.8f;                //    (heavier at one pixel: centroid shifts right/up)
  P(cv::Rect(70, 20, 2, 1)).setTo(10.0);     // C: 2 px, mass 20, in the ROI but too small
  P(cv::Rect(80, 80, 10, 10)).setTo(1.0);    // D: mass 100, outside the ROI
  DetectorOptions o;
  o.region_min_area_px = 4;
  RegionScratch scratch;
  scratch.reserve(100, 100);
  const Box2D roi{0, 0, 75, 75};
  const cv::Rect full(0, 0, 100, 100);
  const auto r = retrieve_region(P, roi, full, o, scratch);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->area_px, 9);
  EXPECT_NEAR(r->mass, 8 * 0.9 + 1.8, 1e-5);
  EXPECT_DOUBLE_EQ(r->box.x0, 39.5);
  EXPECT_DOUBLE_EQ(r->box.y0, 39.5);
  EXPECT_DOUBLE_EQ(r->box.x1, 42.5);
  EXPECT_DOUBLE_EQ(r->box.y1, 42.5);
  // Weighted centroid: x = (0.9·(3·40 + 2·41 + 3·42) + 1.8·41) / 9 = 41 (symmetric in x);
  // y = (0.9·(2·40 + 3·41 + 3·42) + 1.8·40) / 9 = (0.9·329 + 72) / 9 = 40.9.
  EXPECT_NEAR(r->center.x(), 41.0, 1e-6);
  EXPECT_NEAR(r->center.y(), 40.9, 1e-6);
  // With an ROI around D only, D is chosen.
  const auto d = retrieve_region(P, {78, 78, 95, 95}, full, o, scratch);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->area_px, 100);
  // Components are computed inside the search area only: D cut to its left 5 columns is still
  // found (area 50), and B is out of reach when the search area excludes it.
  const auto cut = retrieve_region(P, {78, 78, 95, 95}, cv::Rect(60, 60, 25, 40), o, scratch);
  ASSERT_TRUE(cut);
  EXPECT_EQ(cut->area_px, 50);
  EXPECT_DOUBLE_EQ(cut->box.x0, 79.5);
  EXPECT_DOUBLE_EQ(cut->box.x1, 84.5);
  const auto only_a = retrieve_region(P, roi, cv::Rect(0, 0, 35, 35), o, scratch);
  ASSERT_TRUE(only_a);
  EXPECT_EQ(only_a->area_px, 200);
  // An ROI over nothing: no region.
  EXPECT_FALSE(retrieve_region(P, {50, 60, 60, 70}, full, o, scratch));
}

}  // namespace
}  // namespace fdv
