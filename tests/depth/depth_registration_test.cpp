// Depth registration into the event camera, against analytic depth: planes at known distance
// seen through known extrinsics.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <random>

#include "fdv/core/error.h"
#include "fdv/depth/depth_registration.h"

namespace fdv {
namespace {

// Depth camera 640x480 (f = 500), event camera 320x240 (f = 260): each event pixel receives
// about 3.5 depth pixels, so registration leaves almost no holes.
Calibration rig(const Eigen::Isometry3d& T_B_E) {
  Calibration c;
  c.event_camera = {320, 240, 260.0, 261.0, 158.0, 121.0, {-0.05, 0.01, 0.0005, -0.0003, 0.0}};
  c.depth_camera = PinholeCamera{640, 480, 500.0, 500.0, 319.5, 239.5, {}};
  c.T_B_D = Eigen::Isometry3d::Identity();
  c.T_B_E = T_B_E;
  return c;
}

DepthFrame constant_frame(const PinholeCamera& cam, float z, TimeNs t = 0) {
  DepthFrame f;
  f.t = t;
  f.width = cam.width;
  f.height = cam.height;
  f.depth_m.assign(static_cast<std::size_t>(cam.width) * cam.height, z);
  return f;
}

TEST(DepthRegistration, PlaneSeenFromAnOffsetRotatedCamera) {
  // Event camera 6 cm right, 2 cm down, 1 cm behind the depth camera, turned 4° about y and 2°
  // about x. The plane z_D = 2.5 m. For the ray X_E = s·[xn; 1] of event pixel p, the point on
  // the plane has e3·(R_D_E·X_E + t_D_E) = 2.5, so z_E = s = (2.5 − t_z) / (e3·R_D_E·[xn; 1]).
  Eigen::Isometry3d T_B_E = Eigen::Isometry3d::Identity();
  T_B_E.linear() = (Eigen::AngleAxisd(0.07, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
  T_B_E.translation() = Eigen::Vector3d(0.06, 0.02, -0.01);
  const Calibration c = rig(T_B_E);
  const DepthRegistrar reg(c);
  const DepthRegistrationResult r = reg.register_frame(constant_frame(*c.depth_camera, 2.5f, 123));
  ASSERT_TRUE(r.ok()) << r.rejected;
  const RegisteredDepth& d = r.depth;
  EXPECT_EQ(d.t, 123);
  ASSERT_EQ(d.width, 320);
  ASSERT_EQ(d.height, 240);
  const Eigen::Isometry3d T_D_E = c.T_B_D.inverse() * c.T_B_E;  // D <- E
  int checked = 0, holes = 0;
  double worst = 0;
  for (int y = 20; y < 220; ++y)
    for (int x = 20; x < 300; ++x) {
      const float z = d.at(x, y);
      if (z == 0) {
        // A hole is expected only where the plane point lies outside the depth camera's view.
        const Eigen::Vector2d xn = c.event_camera.pixel_to_normalized({x, y});
        const Eigen::Vector3d ray_D = T_D_E.linear() * Eigen::Vector3d(xn.x(), xn.y(), 1);
        const double s = (2.5 - T_D_E.translation().z()) / ray_D.z();
        const Eigen::Vector2d px_D = c.depth_camera->project(ray_D * s + T_D_E.translation());
        if (px_D.x() > 2 && px_D.y() > 2 && px_D.x() < 637 && px_D.y() < 477) ++holes;
        continue;
      }
      const Eigen::Vector2d xn = c.event_camera.pixel_to_normalized({x, y});
      const double s = (2.5 - T_D_E.translation().z()) / (T_D_E.linear() * Eigen::Vector3d(xn.x(), xn.y(), 1)).z();
      worst = std::max(worst, std::abs(z - s));
      ++checked;
    }
  // A registered value comes from a depth pixel whose projection is within 0.5 px of this pixel's
  // centre; across the tilted plane z changes by z·tan(4°)/f ≈ 2.5·0.07/260 ≈ 0.7 mm per px.
  EXPECT_LT(worst, 0.002);
  EXPECT_EQ(holes, 0);  // 3.7 depth samples per event pixel, spaced < 1 px: no cell is missed
  EXPECT_EQ(d.registered + d.invalid_input + d.no_inverse + d.behind_camera + d.outside_image, 640u * 480u);
  EXPECT_GT(d.outside_image, 0u);  // the wider depth view spills over the event image
}

TEST(DepthRegistration, NearestSurfaceWins) {
  // Same optical centre and orientation, depth pixels 2x finer: every event pixel receives a
  // 2x2 group of depth pixels along (almost) the same rays. In a checkerboard of 1 m and 3 m,
  // each group holds both, and the event pixel must take the near one.
  Calibration c;
  c.event_camera = {160, 120, 100.0, 100.0, 79.75, 59.75, {}};
  c.depth_camera = PinholeCamera{320, 240, 200.0, 200.0, 159.5, 119.5, {}};
  const DepthRegistrar reg(c);
  DepthFrame f = constant_frame(*c.depth_camera, 3.0f);
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x)
      if ((x + y) % 2 == 0) f.depth_m[static_cast<std::size_t>(y) * 320 + x] = 1.0f;
  const DepthRegistrationResult r = reg.register_frame(f);
  ASSERT_TRUE(r.ok());
  int near = 0;
  for (int y = 1; y < 119; ++y)
    for (int x = 1; x < 159; ++x) {
      EXPECT_FLOAT_EQ(r.depth.at(x, y), 1.0f) << x << "," << y;
      near += r.depth.at(x, y) == 1.0f;
    }
  EXPECT_EQ(near, 158 * 118);
  EXPECT_GT(r.depth.occluded, 0u);
}

TEST(DepthRegistration, HolesStayZeroAndInvalidDepthIsCounted) {
  Calibration c;
  c.event_camera = {160, 120, 100.0, 100.0, 79.5, 59.5, {}};
  c.depth_camera = c.event_camera;  // identical cameras: pixel (x, y) maps onto itself
  const DepthRegistrar reg(c);
  DepthFrame f = constant_frame(*c.depth_camera, 2.0f);
  for (int y = 40; y < 60; ++y)
    for (int x = 30; x < 70; ++x) f.depth_m[static_cast<std::size_t>(y) * 160 + x] = 0.0f;  // hole
  f.depth_m[0] = std::nanf("");
  f.depth_m[1] = 50.0f;  // beyond max_depth_m (20 m)
  const DepthRegistrationResult r = reg.register_frame(f);
  ASSERT_TRUE(r.ok());
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const bool hole = (y >= 40 && y < 60 && x >= 30 && x < 70) || (y == 0 && x < 2);
      EXPECT_EQ(r.depth.at(x, y), hole ? 0.0f : 2.0f) << x << "," << y;
    }
  EXPECT_EQ(r.depth.invalid_input, 20u * 40u + 2u);
}

TEST(DepthRegistration, IdenticalDistortedCamerasMapEachPixelOntoItself) {
  // Back-projection through the depth lens and projection through the same event lens must
  // return every pixel to itself: a check of both lens directions.
  Calibration c;
  c.event_camera = {200, 150, 150.0, 151.0, 101.0, 74.0, {-0.15, 0.03, 0.001, -0.0008, 0.0}};
  c.depth_camera = c.event_camera;
  const DepthRegistrar reg(c);
  DepthFrame f = constant_frame(*c.depth_camera, 1.0f);
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) f.depth_m[static_cast<std::size_t>(y) * 200 + x] = 1.0f + 0.01f * static_cast<float>(x) + 0.001f * static_cast<float>(y);
  const DepthRegistrationResult r = reg.register_frame(f);
  ASSERT_TRUE(r.ok());
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) EXPECT_FLOAT_EQ(r.depth.at(x, y), f.at(x, y)) << x << "," << y;
}

TEST(DepthRegistration, WrongSizeIsRejectedWithAReason) {
  const Calibration c = rig(Eigen::Isometry3d::Identity());
  const DepthRegistrar reg(c);
  DepthFrame f = constant_frame({320, 240, 250.0, 250.0, 160.0, 120.0, {}}, 2.0f);
  DepthRegistrationResult r = reg.register_frame(f);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.rejected.find("320x240"), std::string::npos) << r.rejected;
  EXPECT_NE(r.rejected.find("640x480"), std::string::npos) << r.rejected;
  EXPECT_TRUE(r.depth.empty());
  f = constant_frame(*c.depth_camera, 2.0f);
  f.depth_m.pop_back();  // header says 640x480, buffer is one short
  r = reg.register_frame(f);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.rejected.find("307199"), std::string::npos) << r.rejected;
}

TEST(DepthRegistration, LanesAgreeWithThePlainDoublePrecisionLoop) {
  // register_frame() (eight pixels per step in single precision) against register_frame_plain()
  // (one pixel at a time in double precision with Eigen, a branch per check) on random scenes that
  // exercise every path: invalid values (0, NaN, beyond range), depth pixels without a lens inverse
  // (strong barrel distortion of the depth camera folds its corners), points behind the event
  // camera (it sits 0.3 m in front and turned), outside its image, beyond the trusted radius of its
  // lens, occlusions, and a width that leaves a tail of 5 pixels (not a multiple of 8).
  // The tolerance: single precision moves a projected point by ~1e-4 px, so a depth pixel may land
  // in the neighbouring cell (or in or out of the image, or of the lens radius) only when it falls
  // that close to a boundary: at most 1 in 10^4 of them; a cell's depth differs by < 2e-6
  // relative (float rounding of z·ray + t) unless its winning surface changed.
  Calibration c;
  c.event_camera = {331, 251, 210.0, 212.0, 160.0, 130.0, {-0.28, 0.09, 0.002, -0.001, -0.01}};
  c.depth_camera = PinholeCamera{203, 151, 120.0, 121.0, 100.0, 76.0, {-0.6, 0.0, 0.0, 0.0, 0.0}};
  c.T_B_D = Eigen::Isometry3d::Identity();
  c.T_B_E = Eigen::Isometry3d::Identity();
  c.T_B_E.linear() = (Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX()))
                         .toRotationMatrix();
  c.T_B_E.translation() = Eigen::Vector3d(0.08, -0.03, 0.3);
  const DepthRegistrar reg(c);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> z(0.2f, 6.0f), u(0.0f, 1.0f);
  std::uint64_t behind = 0, outside = 0, no_inverse = 0, occluded = 0, cells = 0, cells_moved = 0, registered = 0;
  auto near = [](std::uint64_t a, std::uint64_t b, std::uint64_t of) {
    return (a > b ? a - b : b - a) <= of / 10000;
  };
  for (int frame = 0; frame < 20; ++frame) {
    DepthFrame f = constant_frame(*c.depth_camera, 0.0f, frame);
    for (float& d : f.depth_m) {
      const float r = u(rng);
      d = r < 0.05f ? 0.0f : r < 0.08f ? std::nanf("") : r < 0.1f ? 40.0f : z(rng);
    }
    // A region beyond the range, as a far background gives: whole 8-pixel steps without depth.
    std::fill_n(f.depth_m.begin() + 203 * (frame % 7), 203 * 9 + frame, 0.0f);
    const DepthRegistrationResult fast = reg.register_frame(f), plain = reg.register_frame_plain(f);
    ASSERT_TRUE(fast.ok() && plain.ok());
    const RegisteredDepth &a = fast.depth, &b = plain.depth;
    ASSERT_EQ(a.depth_m.size(), b.depth_m.size());
    const std::uint64_t n = f.depth_m.size();
    // The checks that do not depend on geometry are exact.
    EXPECT_EQ(a.invalid_input, b.invalid_input);
    EXPECT_EQ(a.no_inverse, b.no_inverse);
    EXPECT_TRUE(near(a.registered, b.registered, n)) << a.registered << " vs " << b.registered;
    EXPECT_TRUE(near(a.occluded, b.occluded, n)) << a.occluded << " vs " << b.occluded;
    EXPECT_TRUE(near(a.behind_camera, b.behind_camera, n)) << a.behind_camera << " vs " << b.behind_camera;
    EXPECT_TRUE(near(a.outside_image, b.outside_image, n)) << a.outside_image << " vs " << b.outside_image;
    EXPECT_EQ(a.registered + a.invalid_input + a.no_inverse + a.behind_camera + a.outside_image, n);
    for (std::size_t i = 0; i < a.depth_m.size(); ++i) {
      const float za = a.depth_m[i], zb = b.depth_m[i];
      if (za == 0 && zb == 0) continue;
      ++cells;
      if (!(std::abs(za - zb) <= 2e-6f * zb)) ++cells_moved;
    }
    behind += a.behind_camera, outside += a.outside_image, no_inverse += a.no_inverse, occluded += a.occluded;
    registered += a.registered;
  }
  // Cells whose winning surface changed: each needs a depth pixel within ~1e-4 px of a cell border.
  EXPECT_LE(cells_moved, registered / 10000) << cells_moved << " of " << cells << " cells";
  // Every path was taken.
  EXPECT_GT(behind, 0u);
  EXPECT_GT(outside, 0u);
  EXPECT_GT(no_inverse, 0u);
  EXPECT_GT(occluded, 0u);
}

TEST(DepthRegistration, NeedsADepthCamera) {
  Calibration c;
  c.event_camera = {160, 120, 100.0, 100.0, 79.5, 59.5, {}};
  EXPECT_THROW(DepthRegistrar{c}, ConfigError);
  c.depth_camera = c.event_camera;
  DepthRegistrationOptions o;
  o.max_depth_m = 0.05;
  EXPECT_THROW((DepthRegistrar{c, o}), ConfigError);
}

}  // namespace
}  // namespace fdv
