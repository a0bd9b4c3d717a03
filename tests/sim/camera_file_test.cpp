// `fdv simulate --camera FILE`: the event camera of a calibration file, applied exactly, and a
// clear error naming the file when it cannot be.
#include <gtest/gtest.h>

#include <fstream>

#include "fdv/core/error.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/simulator.h"
#include "test_support.h"

namespace fdv::sim {
namespace {

std::string write_camera_file(const std::string& name, const std::string& text) {
  const std::string path = fdv::test::scratch_dir("sim_camera_file") + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(CameraFile, AppliesTheDavis346XmlExactly) {
  const std::string xml = fdv::test::real_data("davis346_00000133_calibration.xml");
  FDV_REQUIRE_REAL_FILE(xml);
  const ScenarioConfig preset = make_preset("close_pass", 1);
  ScenarioConfig c = preset;
  load_event_camera(c, xml);
  // The numbers as the file writes them.
  const auto& e = c.event_camera;
  EXPECT_EQ(e.width, 346);
  EXPECT_EQ(e.height, 260);
  EXPECT_EQ(e.fx, 2.5990781754302105e+02);
  EXPECT_EQ(e.fy, 2.5794624069819366e+02);
  EXPECT_EQ(e.cx, 1.5498993359418415e+02);
  EXPECT_EQ(e.cy, 1.1498744146164572e+02);
  const std::array<double, 5> distortion{-5.1219672628909629e-01, 4.7198744460368797e-01,
                                         -1.5977553548421185e-03, -2.9053305869271209e-03,
                                         -3.1165396541206108e-01};
  EXPECT_EQ(e.distortion, distortion);
  EXPECT_EQ(c.validate(), "") << "the DAVIS346 lens folds back only in the corners";
  // The mounting, the pixel model and the depth camera stay the preset's.
  EXPECT_EQ(e.position_B_m, preset.event_camera.position_B_m);
  EXPECT_EQ(e.contrast_threshold_mean, preset.event_camera.contrast_threshold_mean);
  EXPECT_EQ(c.depth_camera.fx, preset.depth_camera.fx);
  EXPECT_EQ(c.depth_camera.width, preset.depth_camera.width);
  EXPECT_EQ(to_yaml(c).substr(to_yaml(c).find("depth_camera:")),
            to_yaml(preset).substr(to_yaml(preset).find("depth_camera:")));

  // --resolution afterwards: the same field of view at 640x480.
  set_event_resolution(c, 640, 480);
  EXPECT_DOUBLE_EQ(c.event_camera.fx, 2.5990781754302105e+02 * 640 / 346);
  EXPECT_DOUBLE_EQ(c.event_camera.fy, 2.5794624069819366e+02 * 480 / 260);
  EXPECT_DOUBLE_EQ(c.event_camera.cx, (1.5498993359418415e+02 + 0.5) * 640 / 346 - 0.5);
  EXPECT_DOUBLE_EQ(c.event_camera.cy, (1.1498744146164572e+02 + 0.5) * 480 / 260 - 0.5);
  EXPECT_EQ(c.event_camera.distortion, distortion);
  EXPECT_EQ(c.validate(), "");
}

TEST(CameraFile, AppliesTheProjectYamlExactly) {
  const std::string path = write_camera_file("rig.yaml", R"(event_camera:
  width: 320
  height: 240
  intrinsics: [301.25, 300.5, 161.75, 119.125]
  distortion: [-0.125, 0.03125, 0.001, -0.002, 0.0]
T_B_E: {translation: [0.2, 0.0, 0.0], quaternion_xyzw: [0.5, -0.5, 0.5, -0.5]}
)");
  ScenarioConfig c = make_preset("two_balls", 1);
  const auto mounting = c.event_camera.position_B_m;
  load_event_camera(c, path);
  const auto& e = c.event_camera;
  EXPECT_EQ(e.width, 320);
  EXPECT_EQ(e.height, 240);
  EXPECT_EQ(e.fx, 301.25);
  EXPECT_EQ(e.fy, 300.5);
  EXPECT_EQ(e.cx, 161.75);
  EXPECT_EQ(e.cy, 119.125);
  EXPECT_EQ(e.distortion, (std::array<double, 5>{-0.125, 0.03125, 0.001, -0.002, 0.0}));
  EXPECT_EQ(e.position_B_m, mounting) << "only the camera's lens and pixels are taken";
  EXPECT_EQ(c.validate(), "");
}

TEST(CameraFile, BadFilesNameTheFile) {
  ScenarioConfig c = make_preset("close_pass", 1);
  const std::string before = to_yaml(c);
  const std::string missing = fdv::test::scratch_dir("sim_camera_missing") + "/none.xml";
  EXPECT_NE(fdv::test::input_error_of(missing, [&] { load_event_camera(c, missing); }),
            "no error");
  const std::string garbage = write_camera_file("garbage.yaml", "event_camera: [1, 2\n");
  EXPECT_NE(fdv::test::input_error_of(garbage, [&] { load_event_camera(c, garbage); }),
            "no error");
  const std::string xml_garbage = write_camera_file("garbage.xml", "<?xml version=\"1.0\"?>\n<oops");
  EXPECT_NE(fdv::test::input_error_of(xml_garbage, [&] { load_event_camera(c, xml_garbage); }),
            "no error");
  // Readable, but a lens that folds back near the image centre cannot be rendered.
  const std::string folding = write_camera_file("folding.yaml", R"(event_camera:
  width: 640
  height: 480
  intrinsics: [536.3, 536.3, 320.9, 234.0]
  distortion: [-0.9, 0, 0, 0, 0]
)");
  const std::string why = fdv::test::input_error_of(folding, [&] { load_event_camera(c, folding); });
  EXPECT_NE(why.find("event_camera.distortion"), std::string::npos) << why;
  EXPECT_EQ(to_yaml(c), before) << "a failed load leaves the configuration as it was";
}

}  // namespace
}  // namespace fdv::sim
