#include "fdv/core/camera.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

namespace fdv {
namespace {

// The paper's DVXplorer intrinsics with a moderate made-up distortion, and the DAVIS346 of the
// real recording (strong barrel distortion, k1 = -0.51).
PinholeCamera dvxplorer() { return {640, 480, 536.3, 536.3, 320.9, 234.0, {-0.2, 0.05, 1e-3, -5e-4, 0.01}}; }
PinholeCamera davis346() {
  return {346, 260, 259.90781754302105, 257.94624069819366, 154.98993359418415, 114.98744146164572,
          {-0.51219672628909629, 0.47198744460368797, -1.5977553548421185e-03,
           -2.9053305869271209e-03, -0.31165396541206108}};
}

TEST(PinholeCamera, ProjectsWithoutDistortionByHand) {
  PinholeCamera cam{640, 480, 500, 400, 320, 240, {}};
  // X = (1, -0.5, 2): x/z = 0.5, y/z = -0.25 -> u = 500*0.5+320 = 570, v = 400*-0.25+240 = 140.
  const Eigen::Vector2d px = cam.project({1.0, -0.5, 2.0});
  EXPECT_DOUBLE_EQ(px.x(), 570.0);
  EXPECT_DOUBLE_EQ(px.y(), 140.0);
}

TEST(PinholeCamera, DistortionMatchesHandComputedValue) {
  PinholeCamera cam{640, 480, 100, 100, 0, 0, {0.1, 0.01, 0.001, 0.002, 0.0001}};
  // xn = (0.3, 0.4): r2 = 0.25, radial = 1 + 0.1*0.25 + 0.01*0.0625 + 0.0001*0.015625
  //      = 1.0256265625; x' = 0.3*radial + 2*0.001*0.12 + 0.002*(0.25+0.18) = 0.30768796875+0.00024+0.00086
  //      = 0.30878796875; y' = 0.4*radial + 0.001*(0.25+0.32) + 2*0.002*0.12 = 0.410250625+0.00057+0.00048
  //      = 0.411300625.
  const Eigen::Vector2d xd = cam.distort({0.3, 0.4});
  EXPECT_NEAR(xd.x(), 0.30878796875, 1e-15);
  EXPECT_NEAR(xd.y(), 0.411300625, 1e-15);
}

TEST(PinholeCamera, AgreesWithOpenCvProjectPoints) {
  for (const PinholeCamera& cam : {dvxplorer(), davis346()}) {
    const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
    const auto& d = cam.distortion;
    const std::vector<double> dist{d.k1, d.k2, d.p1, d.p2, d.k3};
    std::vector<cv::Point3d> pts{{0.3, -0.2, 2.0}, {-0.5, 0.4, 3.0}, {0.0, 0.0, 1.0}, {0.7, 0.5, 2.5}};
    std::vector<cv::Point2d> out;
    cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, out);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector2d px = cam.project({pts[i].x, pts[i].y, pts[i].z});
      EXPECT_NEAR(px.x(), out[i].x, 1e-9);
      EXPECT_NEAR(px.y(), out[i].y, 1e-9);
    }
  }
}

TEST(PinholeCamera, BackProjectionRoundTripsOverTheWholeImage) {
  const PinholeCamera cam = dvxplorer();
  double worst = 0;
  for (int v = 0; v < cam.height; v += 7)
    for (int u = 0; u < cam.width; u += 7) {
      const Eigen::Vector2d px(u, v);
      const Eigen::Vector3d X = cam.back_project(px, 3.5);
      EXPECT_DOUBLE_EQ(X.z(), 3.5);
      worst = std::max(worst, (cam.project(X) - px).norm());
    }
  EXPECT_LT(worst, 1e-7);
}

// The real DAVIS346 calibration (k1 -0.51, k2 0.47, k3 -0.31): its radial map
// r -> r(1 + k1 r^2 + k2 r^4 + k3 r^6) peaks at r^2 ~ 0.85 with a distorted radius ~ 0.66, while
// the image corners sit at a distorted radius ~ 0.92. Such pixels have no undistorted point.
TEST(PinholeCamera, StrongDistortionRoundTripsWhereInvertibleAndIsNanElsewhere) {
  const PinholeCamera cam = davis346();
  const auto& d = cam.distortion;
  double max_distorted_radius = 0;  // by brute force over r, independent of the Newton code
  for (double r = 0; r < 2; r += 1e-5)
    max_distorted_radius = std::max(max_distorted_radius,
                                    r * (1 + d.k1 * r * r + d.k2 * std::pow(r, 4) + d.k3 * std::pow(r, 6)));
  int invertible = 0, not_invertible = 0;
  double worst = 0;
  for (int v = 0; v < cam.height; v += 3)
    for (int u = 0; u < cam.width; u += 3) {
      const Eigen::Vector2d px(u, v);
      const double rd = Eigen::Vector2d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy).norm();
      const Eigen::Vector3d X = cam.back_project(px, 2.0);
      if (X.allFinite()) {
        ++invertible;
        worst = std::max(worst, (cam.project(X) - px).norm());
      } else {
        ++not_invertible;
      }
      // Tangential terms shift the fold by a little; away from it the answer is certain.
      if (rd < 0.98 * max_distorted_radius) {
        EXPECT_TRUE(X.allFinite()) << u << "," << v;
      } else if (rd > 1.02 * max_distorted_radius) {
        EXPECT_FALSE(X.allFinite()) << u << "," << v;
      }
    }
  EXPECT_LT(worst, 1e-7);
  // About 14 % of this grid lies beyond the fold (counted independently: rd > max radius).
  EXPECT_NEAR(static_cast<double>(not_invertible) / (invertible + not_invertible), 0.144, 0.02);
  EXPECT_GT(not_invertible, 0);
}

TEST(PinholeCamera, UndistortPixelIsIdentityWithoutDistortion) {
  PinholeCamera cam{640, 480, 500, 500, 320, 240, {}};
  const Eigen::Vector2d px(12.25, 400.5);
  EXPECT_TRUE(cam.undistort_pixel(px).isApprox(px));
}

TEST(PinholeCamera, ValidateNamesTheProblem) {
  EXPECT_EQ(dvxplorer().validate(), "");
  PinholeCamera bad = dvxplorer();
  bad.fx = -1;
  EXPECT_NE(bad.validate().find("focal"), std::string::npos);
  bad = dvxplorer();
  bad.cy = std::nan("");
  EXPECT_NE(bad.validate().find("non-finite"), std::string::npos);
  bad = dvxplorer();
  bad.width = 0;
  EXPECT_NE(bad.validate().find("resolution"), std::string::npos);
}

// Sizes and focal lengths that once passed and then allocated gigabytes or detected nothing
// without a word (a 60000x60000 depth camera; fx = 1e300, fy = 1e-300).
TEST(PinholeCamera, ValidateCapsTheSizeAndTheFocalLengths) {
  PinholeCamera cam = dvxplorer();
  cam.width = cam.height = kMaxCameraSide;
  cam.cx = cam.cy = kMaxCameraSide / 2.0;
  EXPECT_EQ(cam.validate(), "");
  cam.height = kMaxCameraSide + 1;
  EXPECT_NE(cam.validate().find("resolution must be 1 to 4096 pixels a side, got 4096x4097"), std::string::npos)
      << cam.validate();
  for (const auto& [fx, fy] : {std::pair{1e300, 500.0}, {500.0, 1e-300}, {0.5, 500.0}, {500.0, 2e6}}) {
    PinholeCamera bad = dvxplorer();
    bad.fx = fx;
    bad.fy = fy;
    EXPECT_NE(bad.validate().find("focal lengths must be 1 to 1e+06 px"), std::string::npos) << bad.validate();
  }
}

}  // namespace
}  // namespace fdv
