// Ground-truth box of a sphere against analytic silhouettes and a brute-force raster.
#include "fdv/eval/ground_truth_box.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fdv {
namespace {

constexpr double kF = 500.0, kCx = 319.5, kCy = 239.5;

/// A camera at the world origin looking along +z (T_B_E identity, body at rest at identity).
Calibration camera(Distortion d = {}) {
  Calibration c;
  c.event_camera = {640, 480, kF, kF, kCx, kCy, d};
  return c;
}

std::vector<OdometrySample> still_body() {
  std::vector<OdometrySample> body(2);
  body[0].t = 0;
  body[1].t = kNsPerS;
  return body;
}

std::vector<ObjectState> ball_at(const Eigen::Vector3d& p) {
  return {{0, 1, p, Eigen::Vector3d::Zero()}, {kNsPerS, 1, p, Eigen::Vector3d::Zero()}};
}

TEST(GroundTruthBox, SphereStraightAheadMatchesTheTangentCone) {
  const double r = 0.105, z = 2.0;
  const auto box = ground_truth_box(ball_at({0, 0, z}), 1, r, still_body(), camera(), 0, kNsPerMs);
  ASSERT_TRUE(box.visible);
  // Tangent rays at asin(r / z) from the axis: half-width f tan(asin(r/z)) = f r / sqrt(z² - r²).
  const double half = kF * r / std::sqrt(z * z - r * r);
  EXPECT_NEAR(box.u_max - kCx, half, 0.02);
  EXPECT_NEAR(kCx - box.u_min, half, 0.02);
  EXPECT_NEAR(box.v_max - kCy, half, 0.02);
  EXPECT_NEAR(kCy - box.v_min, half, 0.02);
  EXPECT_DOUBLE_EQ(box.fraction_in_view_min, 1.0);
  EXPECT_NEAR(box.span_px_max, 2 * half, 0.04);
  // Not the naive centre ± f r / z.
  EXPECT_GT(half - kF * r / z, 0.01);
}

TEST(GroundTruthBox, OffAxisSphereUsesTheConeNotTheCenter) {
  // Centre at angle θ = atan(X / Z) from the axis; the silhouette's horizontal extremes are the
  // rays at θ ± asin(r / L): u = cx + f tan(θ ± α). Much wider than f X/Z ± f r/Z off-axis.
  const double X = 0.8, Z = 2.5, r = 0.3, L = std::hypot(X, Z);
  const auto box = ground_truth_box(ball_at({X, 0, Z}), 1, r, still_body(), camera(), 0, 0);
  const double theta = std::atan2(X, Z), alpha = std::asin(r / L);
  EXPECT_NEAR(box.u_max, kCx + kF * std::tan(theta + alpha), 0.02);
  EXPECT_NEAR(box.u_min, kCx + kF * std::tan(theta - alpha), 0.02);
  // Vertically: the highest normalised y/z over the circle of rays at angle α around the
  // centre direction, found by a fine scan of the circle.
  const Eigen::Vector3d a(std::sin(theta), 0, std::cos(theta)),
      e1(std::cos(theta), 0, -std::sin(theta));
  double y_max = -1e9;
  for (double phi = 0; phi < 6.2832; phi += 1e-5) {
    const Eigen::Vector3d ray =
        std::cos(alpha) * a +
        std::sin(alpha) * (std::cos(phi) * e1 + std::sin(phi) * Eigen::Vector3d::UnitY());
    y_max = std::max(y_max, ray.y() / ray.z());
  }
  EXPECT_NEAR(box.v_max, kCy + kF * y_max, 0.02);
}

TEST(GroundTruthBox, UnionOverAMovingBall) {
  // Constant velocity along x at z = 5: from x = -0.5 to +0.5 in 100 ms.
  std::vector<ObjectState> states;
  for (int i = 0; i <= 100; ++i)
    states.push_back({i * kNsPerMs, 1, {-0.5 + 0.01 * i, 0.0, 5.0}, {10.0, 0.0, 0.0}});
  const double r = 0.1;
  const auto box = ground_truth_box(states, 1, r, still_body(), camera(), 0, 100 * kNsPerMs);
  const double alpha = std::asin(r / std::hypot(0.5, 5.0)), theta = std::atan2(0.5, 5.0);
  EXPECT_NEAR(box.u_min, kCx + kF * std::tan(-theta - alpha), 0.02);
  EXPECT_NEAR(box.u_max, kCx + kF * std::tan(theta + alpha), 0.02);
  // Sub-interval: only the first 10 ms (x from -0.5 to -0.4).
  const auto part = ground_truth_box(states, 1, r, still_body(), camera(), 0, 10 * kNsPerMs);
  const double theta1 = std::atan2(-0.4, 5.0), alpha1 = std::asin(r / std::hypot(0.4, 5.0));
  EXPECT_NEAR(part.u_max, kCx + kF * std::tan(theta1 + alpha1), 0.02);
  // Between truth samples the ball position is interpolated (here: 2.5 ms -> x = -0.475).
  const auto mid = ground_truth_box(states, 1, r, still_body(), camera(), 2'500'000, 2'500'000);
  const double theta2 = std::atan2(-0.475, 5.0), alpha2 = std::asin(r / std::hypot(0.475, 5.0));
  EXPECT_NEAR(mid.u_max, kCx + kF * std::tan(theta2 + alpha2), 0.02);
}

TEST(GroundTruthBox, VehicleMotionAndExtrinsicsAreApplied) {
  // Body at x = 1 m (W), camera mounted 0.5 m to the body's +x: the ball at W x = 1.5 + 0,
  // z = 3 is straight ahead of the camera.
  Calibration c = camera();
  c.T_B_E.translation() = Eigen::Vector3d(0.5, 0.0, 0.0);
  auto body = still_body();
  for (auto& b : body) b.p_W_B = {1.0, 0.0, 0.0};
  const auto box = ground_truth_box(ball_at({1.5, 0, 3}), 1, 0.1, body, c, 0, 0);
  EXPECT_NEAR(0.5 * (box.u_min + box.u_max), kCx, 0.02);  // polygon error <= 0.01 px per side
  EXPECT_NEAR(0.5 * (box.v_min + box.v_max), kCy, 0.02);
  EXPECT_GT(box.width(), 30.0);
}

TEST(GroundTruthBox, CameraHeldAtAFixedTimeLikeACompensatedImage) {
  // A ball at rest 5 m ahead; over 100 ms the vehicle moves 0.1 m along x and yaws 0.1 rad about
  // y. Seen by the moving camera the ball sweeps ~60 px; from the camera held at t = 0 (an exact
  // compensation to t0) it stays one silhouette; with only the rotation held (rotation-only
  // compensation) it sweeps the translation's parallax, f·0.1/5 = 10 px, by hand below.
  std::vector<OdometrySample> body(2);
  body[0].t = 0;
  body[1].t = 100 * kNsPerMs;
  body[1].p_W_B = {0.1, 0.0, 0.0};
  body[1].q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()));
  for (auto& b : body) b.v_W = {1.0, 0.0, 0.0}, b.omega_B = {0.0, 1.0, 0.0};
  const double r = 0.1;
  const auto states = ball_at({0, 0, 5});
  const auto at_start = ground_truth_box(states, 1, r, body, camera(), 0, 0);
  const auto moving = ground_truth_box(states, 1, r, body, camera(), 0, 100 * kNsPerMs);
  GroundTruthBoxOptions held;
  held.rotation_time = held.position_time = 0;
  const auto held_box = ground_truth_box(states, 1, r, body, camera(), 0, 100 * kNsPerMs, held);
  GroundTruthBoxOptions rotation_held;
  rotation_held.rotation_time = 0;
  const auto parallax =
      ground_truth_box(states, 1, r, body, camera(), 0, 100 * kNsPerMs, rotation_held);

  EXPECT_LT(moving.u_min, at_start.u_min - 50.0);
  EXPECT_NEAR(held_box.u_min, at_start.u_min, 1e-9);
  EXPECT_NEAR(held_box.u_max, at_start.u_max, 1e-9);
  EXPECT_NEAR(held_box.v_min, at_start.v_min, 1e-9);
  const double theta = std::atan2(0.1, 5.0), alpha = std::asin(r / std::hypot(0.1, 5.0));
  EXPECT_NEAR(parallax.u_min, kCx + kF * std::tan(-theta - alpha), 0.02);
  EXPECT_NEAR(parallax.u_max, at_start.u_max, 0.02);
}

TEST(GroundTruthBox, PartlyOutOfViewIsClippedAndCounted) {
  // Centre exactly on the left image border's ray: about half the disc is in view.
  const double z = 4.0, x = (-0.5 - kCx) / kF * z;
  const auto box = ground_truth_box(ball_at({x, 0, z}), 1, 0.2, still_body(), camera(), 0, 0);
  ASSERT_TRUE(box.visible);
  EXPECT_DOUBLE_EQ(box.u_min, -0.5);
  EXPECT_NEAR(box.fraction_in_view_mean, 0.5, 0.02);
  // Entirely outside, and behind the camera: not visible.
  EXPECT_FALSE(
      ground_truth_box(ball_at({-10, 0, 2}), 1, 0.2, still_body(), camera(), 0, 0).visible);
  const auto behind = ground_truth_box(ball_at({0, 0, -3}), 1, 0.2, still_body(), camera(), 0, 0);
  EXPECT_FALSE(behind.visible);
  EXPECT_EQ(behind.fraction_in_view_max, 0.0);
}

TEST(GroundTruthBox, DistortedLensMatchesABruteForceRaster) {
  // Independent route: undistort raw pixels (Newton inversion of the lens) and keep those whose
  // ray lies inside the tangent cone. Raster on a 0.25 px grid, then bisect each row's and
  // column's outermost inside pixel to 1e-3 px; the extremes must match the box.
  const Distortion d{-0.10, 0.06, 4e-4, -6e-4, 0.0};
  const Calibration c = camera(d);
  const Eigen::Vector3d center(1.2, -0.7, 3.0);
  const double r = 0.25;
  const auto box = ground_truth_box(ball_at(center), 1, r, still_body(), c, 0, 0);
  const Eigen::Vector3d axis = center.normalized();
  const double cos_alpha = std::cos(std::asin(r / center.norm()));
  auto inside = [&](double u, double v) {
    const Eigen::Vector2d xn = c.event_camera.pixel_to_normalized({u, v});
    return Eigen::Vector3d(xn.x(), xn.y(), 1).normalized().dot(axis) >= cos_alpha;
  };
  // Outermost inside point from an inside point p towards direction dir (step 0.25 then bisect).
  auto edge = [&](double u, double v, double du, double dv) {
    double a = 0, b = 0.25;
    while (inside(u + b * du, v + b * dv)) a = b, b += 0.25;
    while (b - a > 1e-3) {
      const double m = 0.5 * (a + b);
      (inside(u + m * du, v + m * dv) ? a : b) = m;
    }
    return a;
  };
  double u0 = 1e9, u1 = -1e9, v0 = 1e9, v1 = -1e9;
  for (double v = box.v_min - 1; v <= box.v_max + 1; v += 0.25)
    for (double u = box.u_min - 1; u <= box.u_max + 1; u += 0.25) {
      if (!inside(u, v)) continue;
      // The silhouette is convex: from the row's first inside point, both row ends.
      u0 = std::min(u0, u - edge(u, v, -1, 0)), u1 = std::max(u1, u + edge(u, v, 1, 0));
      break;
    }
  for (double u = box.u_min - 1; u <= box.u_max + 1; u += 0.25)
    for (double v = box.v_min - 1; v <= box.v_max + 1; v += 0.25) {
      if (!inside(u, v)) continue;
      v0 = std::min(v0, v - edge(u, v, 0, -1)), v1 = std::max(v1, v + edge(u, v, 0, 1));
      break;
    }
  EXPECT_NEAR(box.u_min, u0, 0.02);
  EXPECT_NEAR(box.u_max, u1, 0.02);
  EXPECT_NEAR(box.v_min, v0, 0.02);
  EXPECT_NEAR(box.v_max, v1, 0.02);
}

TEST(VisibleSilhouette, ACutBallsCenterIsItsInViewAreasCentroid) {
  // Independent route: a 0.1 px raster of the image's pixels whose ray lies in the tangent cone;
  // the mean of those in view is the visible part's centroid, their extent its clipped box.
  const double z = 4.0, r = 0.3, x = (10.5 - kCx) / kF * z;  // centre 11 px inside the left border
  const Eigen::Vector3d center(x, 0.4, z);
  const auto s = visible_silhouette(ball_at(center), 1, r, still_body(), camera(), 0);
  ASSERT_TRUE(s.visible);
  EXPECT_TRUE(s.partial());
  const Eigen::Vector3d axis = center.normalized();
  const double cos_alpha = std::cos(std::asin(r / center.norm()));
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double n = 0, u1 = -1e9, v0 = 1e9, v1 = -1e9;
  for (double v = -0.45; v < 480 - 0.5; v += 0.1)
    for (double u = -0.45; u < 640 - 0.5; u += 0.1) {
      if (u > 80) break;  // the silhouette ends ~50 px right of the border
      if (Eigen::Vector3d((u - kCx) / kF, (v - kCy) / kF, 1).normalized().dot(axis) < cos_alpha)
        continue;
      sum += Eigen::Vector2d(u, v), ++n;
      u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
    }
  ASSERT_GT(n, 0);
  EXPECT_NEAR(s.visible_center_px.x(), sum.x() / n, 0.3);
  EXPECT_NEAR(s.visible_center_px.y(), sum.y() / n, 0.3);
  EXPECT_DOUBLE_EQ(s.u_min, -0.5);
  EXPECT_NEAR(s.u_max, u1, 0.1);
  EXPECT_NEAR(s.size_px(), std::max(u1 + 0.5, v1 - v0), 0.2);
  // The projected centre is still the whole ball's: about 11 px right of the border.
  ASSERT_TRUE(s.projected_center_px);
  EXPECT_NEAR(s.projected_center_px->x(), 10.5, 1e-9);
  EXPECT_GT(s.visible_center_px.x(), 10.5 + 1);  // the cut part lies left of the centre
}

TEST(VisibleSilhouette, AWholeBallsCenterIsItsProjectedCenter) {
  const Eigen::Vector3d center(0.3, -0.2, 3);
  const auto s = visible_silhouette(ball_at(center), 1, 0.1, still_body(), camera(), kNsPerMs);
  ASSERT_TRUE(s.visible);
  EXPECT_FALSE(s.partial());
  EXPECT_DOUBLE_EQ(s.fraction_in_view, 1.0);
  const Eigen::Vector2d projected(kCx + kF * 0.1, kCy - kF * 0.2 / 3);
  EXPECT_NEAR((s.visible_center_px - projected).norm(), 0, 1e-9);
  const auto box = ground_truth_box(ball_at(center), 1, 0.1, still_body(), camera(), kNsPerMs,
                                    kNsPerMs);
  EXPECT_NEAR(s.size_px(), std::max(box.width(), box.height()), 1e-9);
  // No truth at that time: nothing.
  EXPECT_FALSE(visible_silhouette(ball_at(center), 1, 0.1, still_body(), camera(), 2 * kNsPerS)
                   .visible);
}

TEST(GroundTruthBox, OtherIdsAndMissingTruth) {
  auto states = ball_at({0, 0, 3});
  for (auto& s : states) s.id = 2;
  EXPECT_FALSE(ground_truth_box(states, 1, 0.1, still_body(), camera(), 0, 0).visible);
  EXPECT_EQ(ground_truth_box(states, 1, 0.1, still_body(), camera(), 0, 0).samples, 0);
  EXPECT_THROW(ground_truth_box(states, 2, 0.1, still_body(), camera(), 10, 0),
               std::invalid_argument);
  EXPECT_THROW(ground_truth_box(states, 2, 0.0, still_body(), camera(), 0, 10),
               std::invalid_argument);
}

}  // namespace
}  // namespace fdv
