// border_cut (border_cut.h): discs cut by the sensor's border, against their geometry integrated
// numerically over a fine grid (independent of the closed forms border_cut uses).
#include "fdv/detection/border_cut.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace fdv {
namespace {

constexpr int kDavisWidth = 346, kDavisHeight = 260;  // the DAVIS346; its border is at -0.5 and W - 0.5

struct Visible {
  Eigen::Vector2d centroid;
  double fraction;
};

/// The part of a disc inside the sensor, by summing a 0.05 px grid.
Visible integrate(const Eigen::Vector2d& center, double r) {
  constexpr double kStep = 0.05;
  double n = 0, inside = 0;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (double y = center.y() - r; y <= center.y() + r; y += kStep)
    for (double x = center.x() - r; x <= center.x() + r; x += kStep) {
      if ((Eigen::Vector2d(x, y) - center).squaredNorm() > r * r) continue;
      ++n;
      if (x < -0.5 || x > kDavisWidth - 0.5 || y < -0.5 || y > kDavisHeight - 0.5) continue;
      ++inside;
      sum += Eigen::Vector2d(x, y);
    }
  return {sum / inside, inside / n};
}

/// What the detector reports: a square of the disc's diameter on the visible part's centroid.
Box2D square_on(const Eigen::Vector2d& c, double r) { return {c.x() - r, c.y() - r, c.x() + r, c.y() + r}; }

TEST(DiscSegment, ClosedFormsAgainstKnownValues) {
  EXPECT_NEAR(disc_segment_fraction(10, 10), 0.5, 1e-12);
  EXPECT_NEAR(disc_segment_fraction(20, 10), 1.0, 1e-12);
  EXPECT_NEAR(disc_segment_fraction(0, 10), 0.0, 1e-12);
  // Depth R/2: the segment of a 120° chord, (π/3 − √3/4) / π of the disc.
  EXPECT_NEAR(disc_segment_fraction(5, 10), (std::numbers::pi / 3 - std::sqrt(3.0) / 4) / std::numbers::pi, 1e-12);
  EXPECT_NEAR(disc_segment_centroid(10, 10), 4 * 10 / (3 * std::numbers::pi), 1e-12);  // a half disc
  EXPECT_NEAR(disc_segment_centroid(20, 10), 0.0, 1e-9);
}

TEST(BorderCut, ClearOfTheBorderIsNotCut) {
  EXPECT_FALSE(border_cut(square_on({100, 100}, 20), kDavisWidth, kDavisHeight));
  // 3 px from the left border: beyond the 2 px margin (5 %) of a 40 px square.
  EXPECT_FALSE(border_cut(square_on({22.5, 100}, 20), kDavisWidth, kDavisHeight));
  EXPECT_TRUE(border_cut(square_on({21.5, 100}, 20), kDavisWidth, kDavisHeight));
}

TEST(BorderCut, WholeCenterAndFractionFromTheVisibleCentroid) {
  // Discs cut by the left, bottom, right and top borders, centre inside and outside the frame.
  const double r = 30;
  const Eigen::Vector2d centers[] = {{-0.5 + 12, 120}, {-0.5 - 14, 90}, {150, kDavisHeight - 0.5 + 9},
                                     {kDavisWidth - 0.5 - 20, 130}, {200, -0.5 + 3}};
  for (const Eigen::Vector2d& center : centers) {
    SCOPED_TRACE(testing::Message() << "centre " << center.transpose());
    const Visible v = integrate(center, r);
    const auto cut = border_cut(square_on(v.centroid, r), kDavisWidth, kDavisHeight);
    ASSERT_TRUE(cut);
    EXPECT_NEAR(cut->visible_fraction, v.fraction, 0.005);
    ASSERT_TRUE(cut->center_full);
    EXPECT_NEAR((*cut->center_full - center).norm(), 0.0, 0.1);
    EXPECT_GE(cut->visible.x0, -0.5);
    EXPECT_LE(cut->visible.x1, kDavisWidth - 0.5);
    EXPECT_GE(cut->visible.y0, -0.5);
    EXPECT_LE(cut->visible.y1, kDavisHeight - 0.5);
  }
}

TEST(BorderCut, CornerGivesTheFractionOnly) {
  const double r = 20;
  const Visible v = integrate({5, 8}, r);
  const auto cut = border_cut(square_on(v.centroid, r), kDavisWidth, kDavisHeight);
  ASSERT_TRUE(cut);
  EXPECT_FALSE(cut->center_full);
  // The two cuts taken as independent: near the true share, not exact.
  EXPECT_NEAR(cut->visible_fraction, v.fraction, 0.1);
}

}  // namespace
}  // namespace fdv
