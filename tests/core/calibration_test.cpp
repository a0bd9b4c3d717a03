#include "fdv/core/calibration.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fdv/core/error.h"
#include "test_support.h"

namespace fdv {
namespace {

std::string write_file(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(Calibration, ReadsTheRealDavisOpenCvXml) {
  const auto path = test::real_data("davis346_00000133_calibration.xml");
  FDV_REQUIRE_REAL_FILE(path);
  const Calibration c = load_calibration(path);
  // Values read off the XML file by eye.
  EXPECT_EQ(c.event_camera.width, 346);
  EXPECT_EQ(c.event_camera.height, 260);
  EXPECT_DOUBLE_EQ(c.event_camera.fx, 2.5990781754302105e+02);
  EXPECT_DOUBLE_EQ(c.event_camera.cy, 1.1498744146164572e+02);
  EXPECT_DOUBLE_EQ(c.event_camera.distortion.k1, -5.1219672628909629e-01);
  EXPECT_DOUBLE_EQ(c.event_camera.distortion.k3, -3.1165396541206108e-01);
  EXPECT_TRUE(c.T_B_E.isApprox(Eigen::Isometry3d::Identity()));
}

TEST(Calibration, ProjectYamlRoundTrips) {
  const auto dir = test::scratch_dir("calib_roundtrip");
  Calibration c;
  c.event_camera = {640, 480, 536.3, 536.3, 320.9, 234.0, {-0.1, 0.02, 0.001, -0.002, 0.0}};
  c.depth_camera = PinholeCamera{640, 480, 385.7, 385.7, 321.0, 238.0, {}};
  c.T_B_E.translation() = Eigen::Vector3d(0.1, 0.0, -0.02);
  c.T_B_E.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  c.T_B_D.translation() = Eigen::Vector3d(0.1, 0.05, -0.02);
  c.R_B_I = Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  save_calibration(c, dir + "/calib.yaml");
  const Calibration r = load_calibration(dir + "/calib.yaml");
  EXPECT_DOUBLE_EQ(r.event_camera.fx, 536.3);
  EXPECT_DOUBLE_EQ(r.event_camera.distortion.p2, -0.002);
  ASSERT_TRUE(r.depth_camera.has_value());
  EXPECT_DOUBLE_EQ(r.depth_camera->fx, 385.7);
  EXPECT_TRUE(r.T_B_E.isApprox(c.T_B_E, 1e-12));
  EXPECT_TRUE(r.T_B_D.isApprox(c.T_B_D, 1e-12));
  EXPECT_TRUE(r.R_B_I.isApprox(c.R_B_I, 1e-12));
  // R_E_I = R_B_E^T R_B_I by definition.
  EXPECT_TRUE(r.R_E_I().isApprox(c.T_B_E.linear().transpose() * c.R_B_I, 1e-12));
}

TEST(Calibration, ErrorsNameFileKeyAndReason) {
  const auto dir = test::scratch_dir("calib_errors");
  struct Case {
    std::string text, key_fragment, reason_fragment;
  };
  const std::vector<Case> cases{
      {"event_camera: {width: 640, height: 480, intrinsics: [1, 2, 3]}\n", "event_camera.intrinsics",
       "4 numbers"},
      {"event_camera: {width: 640, height: 480, intrinsics: [500, .nan, 320, 240]}\n",
       "event_camera.intrinsics", "non-finite"},
      {"event_camera: {width: 640, height: 480, intrinsics: [-500, 500, 320, 240]}\n", "event_camera",
       "focal"},
      {"event_camera: {width: 640, height: 480, intrinsics: [500, 500, 320, 240]}\n"
       "T_B_E: [1,0,0,0, 0,2,0,0, 0,0,1,0, 0,0,0,1]\n",
       "T_B_E", "not a rigid"},
      {"depth_camera: {width: 640, height: 480, intrinsics: [500, 500, 320, 240]}\n", "event_camera",
       "missing camera"},
      {"event_camera: [unclosed\n", "line", ""},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto path = write_file(dir, "c" + std::to_string(i) + ".yaml", cases[i].text);
    try {
      load_calibration(path);
      ADD_FAILURE() << "case " << i << " was accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_NE(std::string(e.what()).find(cases[i].key_fragment), std::string::npos) << e.what();
      EXPECT_NE(e.reason().find(cases[i].reason_fragment), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(load_calibration(dir + "/does_not_exist.yaml"), InputError);
}

}  // namespace
}  // namespace fdv
