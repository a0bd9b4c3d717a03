#include "fdv/depth/depth_segmentation.h"

#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "fdv/core/error.h"

namespace fdv {
namespace {

// A registered depth image rendered by ray casting in the event camera (640x480, f = 536.3 px,
// no distortion): a wall, spheres and flat boards, D435 noise σ(z) = z²·0.08/(385.7·0.05) and a
// few % random holes.
const PinholeCamera kCam{640, 480, 536.3, 536.3, 320.0, 240.0, {}};

double sigma_d435(double z) { return z * z * 0.08 / (385.7 * 0.05); }

struct Sphere {
  Eigen::Vector3d c;
  double r;
};
struct Board {  // facing the camera at depth z over a pixel rectangle
  double z;
  int u0, u1, v0, v1;
};

struct Scene {
  double wall_z = 7.0;
  std::vector<Sphere> spheres;
  std::vector<Board> boards;
  std::function<double(int, int)> surface;  // replaces the wall when set
  double hole_fraction = 0.03;
  bool noise = true;
  unsigned seed = 1;
};

struct Frame {
  TimeNs t = 123;
  int width = 640, height = 480;
  std::vector<float> depth_m;
};

Frame render(const Scene& s) {
  Frame f;
  f.depth_m.assign(640 * 480, 0.0f);
  std::mt19937 rng(s.seed);
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> u01(0, 1);
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d d((u - kCam.cx) / kCam.fx, (v - kCam.cy) / kCam.fy, 1.0);
      double z = s.surface ? s.surface(u, v) : s.wall_z;
      for (const Sphere& sp : s.spheres) {
        const double b = d.dot(sp.c), a = d.squaredNorm(), c = sp.c.squaredNorm() - sp.r * sp.r;
        const double disc = b * b - a * c;
        if (disc >= 0)
          z = std::min(z, (b - std::sqrt(disc)) / a);  // ray parameter = z since d.z = 1
      }
      for (const Board& bd : s.boards)
        if (u >= bd.u0 && u <= bd.u1 && v >= bd.v0 && v <= bd.v1) z = std::min(z, bd.z);
      if (s.noise) z += sigma_d435(z) * n01(rng);
      if (u01(rng) < s.hole_fraction) z = 0;
      f.depth_m[static_cast<std::size_t>(v) * 640 + u] = static_cast<float>(z);
    }
  return f;
}

/// The sphere's image: projected centre and a box of its silhouette diameter.
DepthQuery query_for(const Sphere& s) {
  DepthQuery q;
  q.center_px = kCam.project(s.c);
  const double rho = kCam.fx * s.r / std::sqrt(s.c.squaredNorm() - s.r * s.r);  // silhouette radius
  q.box_size_px = Eigen::Vector2d(2 * rho, 2 * rho);
  return q;
}

DepthSegmentationOptions known_radius(double r) {
  DepthSegmentationOptions o;
  o.object_radius_m = r;
  return o;
}

const Sphere kBall{{0.3, -0.1, 4.0}, 0.1};

// A ball in front of a wall: the observation is the centre's z (not the surface's), with the
// noise model's sigma; the estimated radius (unknown-radius mode) is close to the true one.
TEST(DepthSegmentation, BallInFrontOfWallGivesCenterDepth) {
  Scene s;
  s.spheres = {kBall};
  const Frame f = render(s);
  const DepthSegmentation known =
      segment_object_depth(depth_view(f), kCam, query_for(kBall), known_radius(0.1));
  ASSERT_TRUE(known.observation) << known.reason;
  const DepthObservation& o = *known.observation;
  EXPECT_EQ(o.t, 123);
  EXPECT_NEAR(o.depth_m, 4.0, 0.02);
  EXPECT_LT(o.surface_depth_m, 3.96);  // the visible cap is nearer than the centre
  EXPECT_NEAR(o.sigma_m, sigma_d435(4.0), 0.01);
  EXPECT_NEAR((o.center_px - kCam.project(kBall.c)).norm(), 0, 1.0);
  EXPECT_NEAR(o.pixel_count, 0.97 * M_PI * std::pow(536.3 * 0.1 / 4.0, 2), 60);

  const DepthSegmentation est = segment_object_depth(depth_view(f), kCam, query_for(kBall), {});
  ASSERT_TRUE(est.observation) << est.reason;
  EXPECT_TRUE(est.observation->radius_estimated);
  EXPECT_NEAR(est.observation->radius_m, 0.1, 0.01);
  EXPECT_NEAR(est.observation->depth_m, 4.0, 0.03);
  EXPECT_GT(est.observation->sigma_m, o.sigma_m);  // radius uncertainty added
}

// The tracked box is the events' box: a crescent, thin along the motion. The estimated radius
// comes from the segmented depth pixels, not from the box's shorter side (which would give 0.06 m
// and a centre depth 3 cm short), even with a fifth of the pixels missing.
TEST(DepthSegmentation, EstimatedRadiusDoesNotFollowAThinBox) {
  Scene s;
  s.spheres = {kBall};
  s.hole_fraction = 0.2;
  const Frame f = render(s);
  DepthQuery q = query_for(kBall);
  q.box_size_px.y() *= 0.6;
  const DepthSegmentation est = segment_object_depth(depth_view(f), kCam, q, {});
  ASSERT_TRUE(est.observation) << est.reason;
  EXPECT_NEAR(est.observation->radius_m, 0.1, 0.01);
  EXPECT_NEAR(est.observation->depth_m, 4.0, 0.02);
}

// A flat disc-like board at a known depth: the segmented surface is that depth, and the spread
// is the sensor noise.
TEST(DepthSegmentation, FlatTargetAtKnownDepth) {
  Scene s;
  s.boards = {{3.0, 300, 330, 200, 230}};
  const Frame f = render(s);
  DepthQuery q;
  q.center_px = {315, 215};
  q.box_size_px = {31, 31};
  const DepthSegmentation r = segment_object_depth(depth_view(f), kCam, q, {});
  ASSERT_TRUE(r.observation) << r.reason;
  EXPECT_NEAR(r.observation->surface_depth_m, 3.0, 0.01);
  EXPECT_NEAR(r.observation->spread_m, sigma_d435(3.0), 0.3 * sigma_d435(3.0));
}

// Holes over the object: the wall behind must not be reported as the object.
TEST(DepthSegmentation, HolesOverTheObjectAreRejected) {
  Scene s;
  s.spheres = {kBall};
  Frame f = render(s);
  const DepthQuery q = query_for(kBall);
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u)
      if ((Eigen::Vector2d(u, v) - q.center_px).norm() <= 0.5 * q.box_size_px.x() + 1)
        f.depth_m[static_cast<std::size_t>(v) * 640 + u] = 0;
  const DepthSegmentation r = segment_object_depth(depth_view(f), kCam, q, {});
  EXPECT_FALSE(r.observation) << r.observation->depth_m;
  EXPECT_EQ(r.rejection, DepthRejection::kFootprintTooLarge) << r.reason;

  // Nothing valid at all in the ROI.
  std::fill(f.depth_m.begin(), f.depth_m.end(), 0.0f);
  const DepthSegmentation none = segment_object_depth(depth_view(f), kCam, q, {});
  EXPECT_EQ(none.rejection, DepthRejection::kTooFewValidPixels);
  EXPECT_EQ(none.valid_pixels, 0);
}

// A pole at 2 m in the left part of the ROI, not covering the ball: it is the nearest peak, is
// rejected (off the track's centre; with a known radius also too small for its depth), and the
// ball behind it is found.
TEST(DepthSegmentation, OccluderBesideTheBallIsSkipped) {
  Scene s;
  s.spheres = {kBall};
  const DepthQuery q = query_for(kBall);
  const int u_left = static_cast<int>(q.center_px.x() - q.box_size_px.x());
  s.boards = {{2.0, u_left, u_left + 8, 0, 479}};
  const Frame f = render(s);
  for (const auto& o : {DepthSegmentationOptions{}, known_radius(0.1)}) {
    const DepthSegmentation r = segment_object_depth(depth_view(f), kCam, q, o);
    ASSERT_TRUE(r.observation) << r.reason;
    EXPECT_NEAR(r.observation->depth_m, 4.0, 0.03);
    EXPECT_EQ(r.peaks_tried, 2);
    EXPECT_NE(r.reason.find("peak 1 at 2.0"), std::string::npos) << r.reason;
  }
}

// A board at 2.5 m covering the whole ROI: the object is hidden, nothing is reported.
TEST(DepthSegmentation, OccluderCoveringEverythingIsRejected) {
  Scene s;
  s.spheres = {kBall};
  s.boards = {{2.5, 0, 639, 0, 479}};
  const Frame f = render(s);
  const DepthSegmentation r = segment_object_depth(depth_view(f), kCam, query_for(kBall), {});
  EXPECT_FALSE(r.observation);
  EXPECT_EQ(r.rejection, DepthRejection::kFootprintTooLarge) << r.reason;
}

// A small object at the right place and size but not at the depth the trajectory estimate
// expects: rejected by the consistency gate.
TEST(DepthSegmentation, DepthInconsistentWithTrajectoryIsRejected) {
  Scene s;
  s.spheres = {kBall};
  const Frame f = render(s);
  DepthQuery q = query_for(kBall);
  q.expected_depth_m = 6.0;
  q.expected_depth_sigma_m = 0.2;
  const DepthSegmentation r = segment_object_depth(depth_view(f), kCam, q, {});
  EXPECT_FALSE(r.observation);
  EXPECT_EQ(r.rejection, DepthRejection::kDepthInconsistent) << r.reason;
  q.expected_depth_m = 4.1;  // consistent
  EXPECT_TRUE(segment_object_depth(depth_view(f), kCam, q, {}).observation);
}

// A steep ramp (floor seen at a grazing angle) and no object: depths spread over the window.
TEST(DepthSegmentation, RampWithoutObjectIsRejected) {
  Scene s;
  s.surface = [](int, int v) { return 3.0 + 0.02 * (v - 200); };
  const Frame f = render(s);
  DepthQuery q;
  q.center_px = {320, 230};
  q.box_size_px = {30, 30};
  const DepthSegmentation r = segment_object_depth(depth_view(f), kCam, q, {});
  EXPECT_FALSE(r.observation) << r.observation->depth_m;
  EXPECT_NE(r.rejection, DepthRejection::kNone);
}

// The variance gate: a sphere's segmented depths spread as its visible cap plus the sensor noise,
// sqrt((0.236 r)² + σ(z)²) ≈ 0.070 m at 4 m; with the default gate (2×) the ball passes, with a
// gate a third of that expectation it fails, for that reason and no other.
TEST(DepthSegmentation, SpreadGateComparesTheDepthsSpreadWithASpheresCapPlusNoise) {
  Scene s;
  s.spheres = {kBall};
  const Frame f = render(s);
  DepthSegmentationOptions o = known_radius(0.1);
  const DepthSegmentation pass = segment_object_depth(depth_view(f), kCam, query_for(kBall), o);
  ASSERT_TRUE(pass.observation) << pass.reason;
  const double expected = std::hypot(0.236 * 0.1, sigma_d435(4.0));
  EXPECT_NEAR(pass.observation->expected_spread_m, expected, 0.005);
  EXPECT_GT(pass.observation->spread_m, expected / 3);
  EXPECT_LT(pass.observation->spread_m, 2 * expected);
  o.spread_gate = 1.0 / 3;
  const DepthSegmentation fail = segment_object_depth(depth_view(f), kCam, query_for(kBall), o);
  EXPECT_FALSE(fail.observation);
  EXPECT_EQ(fail.rejection, DepthRejection::kSpreadTooLarge) << fail.reason;
}

// The ROI is the track's box scaled ×2 about its centre (paper §IV-C.2): (2·w)² pixels for a box
// of side w, here the ball's 27 px silhouette, so that it holds the ball and the wall around it.
TEST(DepthSegmentation, RoiIsTheBoxScaledTwiceAboutItsCenter) {
  Scene s;
  s.spheres = {kBall};
  s.hole_fraction = 0;
  const Frame f = render(s);
  const DepthQuery q = query_for(kBall);
  const double w = q.box_size_px.x();
  ASSERT_NEAR(w, 27, 1);
  const DepthSegmentation twice = segment_object_depth(depth_view(f), kCam, q, {});
  EXPECT_NEAR(twice.roi_pixels, 4 * w * w, 4 * w + 1);  // ± a row and a column of pixel centres
  DepthSegmentationOptions once;
  once.roi_scale = 1.0;
  EXPECT_NEAR(segment_object_depth(depth_view(f), kCam, q, once).roi_pixels, w * w, 2 * w + 1);
  ASSERT_TRUE(twice.observation) << twice.reason;
  EXPECT_NEAR(twice.observation->depth_m, 4.0, 0.03);
  EXPECT_NEAR(twice.observation->radius_m, 0.1, 0.015);
}

TEST(DepthSegmentation, InvalidInputIsReportedNotThrown) {
  Scene s;
  const Frame f = render(s);
  PinholeCamera small = kCam;
  small.width = 320;
  DepthQuery q;
  q.center_px = {320, 240};
  q.box_size_px = {20, 20};
  EXPECT_EQ(segment_object_depth(depth_view(f), small, q, {}).rejection,
            DepthRejection::kInvalidInput);
  DepthImageView truncated = depth_view(f);
  truncated.depth_m = truncated.depth_m.first(100);
  EXPECT_EQ(segment_object_depth(truncated, kCam, q, {}).rejection, DepthRejection::kInvalidInput);
  q.box_size_px = {0, 20};
  EXPECT_EQ(segment_object_depth(depth_view(f), kCam, q, {}).rejection,
            DepthRejection::kInvalidInput);
  q.box_size_px = {20, 20};
  q.center_px = {-100, 240};
  EXPECT_EQ(segment_object_depth(depth_view(f), kCam, q, {}).rejection,
            DepthRejection::kRoiOutsideImage);
  DepthSegmentationOptions bad;
  bad.bin_width_m = 0;
  EXPECT_THROW(segment_object_depth(depth_view(f), kCam, q, bad), ConfigError);
}

// Bad input keeps the work bounded: an all-invalid frame (every pixel a hole) costs the ROI's
// pixels, once, and tries no peak, even for a box as large as the image.
TEST(DepthSegmentation, AnAllInvalidFrameCostsOnlyTheRoisPixels) {
  Frame f;
  f.depth_m.assign(640 * 480, 0.0f);
  DepthQuery q;
  q.center_px = {320, 240};
  q.box_size_px = {20, 20};
  const DepthSegmentation small = segment_object_depth(depth_view(f), kCam, q, {});
  EXPECT_EQ(small.rejection, DepthRejection::kTooFewValidPixels);
  EXPECT_EQ(small.valid_pixels, 0);
  EXPECT_EQ(small.peaks_tried, 0);
  EXPECT_LE(small.roi_pixels, 41 * 41);  // the box x2: 40 px, and a border row and column
  q.box_size_px = {5000, 5000};
  const DepthSegmentation whole = segment_object_depth(depth_view(f), kCam, q, {});
  EXPECT_EQ(whole.rejection, DepthRejection::kTooFewValidPixels);
  EXPECT_EQ(whole.roi_pixels, 640 * 480);  // clipped to the image
  EXPECT_EQ(whole.peaks_tried, 0);
}

// The ROI holds the pixels whose centres lie inside the box x2: a 4 x 6 px box about (10.5, 20)
// covers x in [6.5, 14.5] and y in [14, 26], so columns 7-14 and rows 14-26 (a centre on the
// border counts); it is clipped at the image's edges and empty when the box is outside.
TEST(DepthSegmentationPhases, RoiIsTheScaledBoxsPixelCentersClippedToTheImage) {
  DepthQuery q;
  q.center_px = {10.5, 20};
  q.box_size_px = {4, 6};
  const PixelRect r = depth_roi(q, 2.0, 640, 480);
  EXPECT_EQ(r.x0, 7);
  EXPECT_EQ(r.x1, 14);
  EXPECT_EQ(r.y0, 14);
  EXPECT_EQ(r.y1, 26);
  EXPECT_FALSE(r.empty());
  q.center_px = {1, 478};
  const PixelRect corner = depth_roi(q, 2.0, 640, 480);
  EXPECT_EQ(corner.x0, 0);
  EXPECT_EQ(corner.x1, 5);
  EXPECT_EQ(corner.y0, 472);
  EXPECT_EQ(corner.y1, 479);
  q.center_px = {-10, 20};
  EXPECT_TRUE(depth_roi(q, 2.0, 640, 480).empty());
}

// Bins of 0.5 m over [1, 3): every value is exact in float, so each pixel's bin is known. Holes
// (0), NaN, infinity and depths outside [min, max) are ROI pixels but not valid ones.
TEST(DepthSegmentationPhases, HistogramCountsTheRoisValidDepthsPerBin) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<float> d = {1.0f, 1.25f, 1.75f, 2.0f,  //
                                2.5f, 2.75f, 3.0f,  0.5f,  //
                                0.0f, nan,   inf,   2.25f};
  const DepthImageView view{7, 4, 3, d};
  DepthSegmentationOptions o;
  o.min_depth_m = 1.0;
  o.max_depth_m = 3.0;
  o.bin_width_m = 0.5;
  const DepthHistogram all = depth_histogram(view, PixelRect{0, 3, 0, 2}, o);
  EXPECT_EQ(all.counts, (std::vector<int>{2, 1, 2, 2}));
  EXPECT_EQ(all.roi_pixels, 12);
  EXPECT_EQ(all.valid_pixels, 7);
  EXPECT_DOUBLE_EQ(all.bin_center_m(1), 1.75);
  EXPECT_EQ(all.at(-1), 0);
  EXPECT_EQ(all.at(4), 0);
  const DepthHistogram part = depth_histogram(view, PixelRect{1, 2, 0, 1}, o);
  EXPECT_EQ(part.counts, (std::vector<int>{1, 1, 0, 1}));
  EXPECT_EQ(part.roi_pixels, 4);
  EXPECT_EQ(part.valid_pixels, 3);
}

// Bins of 0.1 m from 0.3 m, centres c_i = 0.3 + (i + 0.5)·0.1. Counts 5, 20, 3 in bins 10-12
// and 50 in bin 40, threshold 20: bin 10 is the first whose 3-bin sum (0 + 5 + 20) reaches it,
// the peak is the fullest of bins 9-11, bin 11, and m₀ = (5 c10 + 20 c11 + 3 c12) / 28
// = 0.3 + 0.1·320/28. Searching from beyond it finds bin 40 alone, m₀ = c40.
TEST(DepthSegmentationPhases, NearestSignificantPeakIsTheWeightedCenterOfItsThreeBins) {
  DepthHistogram h;
  h.min_depth_m = 0.3;
  h.bin_width_m = 0.1;
  h.counts.assign(50, 0);
  h.counts[10] = 5;
  h.counts[11] = 20;
  h.counts[12] = 3;
  h.counts[40] = 50;
  const auto near = nearest_significant_peak(h, 0, 20);
  ASSERT_TRUE(near);
  EXPECT_EQ(near->bin, 11);
  EXPECT_NEAR(near->depth_m, 0.3 + 0.1 * 320.0 / 28.0, 1e-12);
  const auto far = nearest_significant_peak(h, 13, 20);
  ASSERT_TRUE(far);
  EXPECT_EQ(far->bin, 40);
  EXPECT_NEAR(far->depth_m, 4.35, 1e-12);
  EXPECT_FALSE(nearest_significant_peak(h, 42, 20));  // nothing beyond
  EXPECT_FALSE(nearest_significant_peak(h, 0, 60));   // nothing significant
  // Two equal bins: the nearer is the peak, m₀ halfway between their centres.
  h.counts.assign(50, 0);
  h.counts[20] = h.counts[21] = 10;
  const auto tie = nearest_significant_peak(h, 0, 15);
  ASSERT_TRUE(tie);
  EXPECT_EQ(tie->bin, 20);
  EXPECT_NEAR(tie->depth_m, 2.4, 1e-12);
}

TEST(DepthNoiseModel, MatchesDesignFigures) {
  const DepthNoiseModel m;
  EXPECT_NEAR(m.sigma_m(5.0), 0.104, 0.001);  // DESIGN.md: ≈ 0.10 m at 5 m
  EXPECT_NEAR(m.sigma_m(3.0), 0.037, 0.001);  // ≈ 0.04 m at 3 m
}

}  // namespace
}  // namespace fdv
