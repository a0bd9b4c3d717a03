#include "fdv/core/calibration.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fdv/core/config_text.h"
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
      // yaml-cpp keeps both and finds the first: the second focal length was lost without a word.
      {"event_camera: {width: 640, height: 480, intrinsics: [500, 500, 320, 240]}\n"
       "event_camera: {width: 640, height: 480, intrinsics: [600, 600, 320, 240]}\n",
       "line 2, column 1", "duplicate key 'event_camera' (first at line 1, column 1)"},
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

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// "where | reason" of the InputError that load_calibration_text raises on `text` (named
/// "calib"), or "no error".
std::string text_error(const std::string& text) {
  return test::input_error_of("calib", [&] { load_calibration_text(text, "calib"); });
}

// The DV calibration's numbers in OpenCV's YAML encoding (as cv::FileStorage writes it).
const char* const kOpenCvYaml = R"(%YAML:1.0
---
DAVIS346_00000133:
   camera_matrix: !!opencv-matrix
      rows: 3
      cols: 3
      dt: d
      data: [ 2.5990781754302105e+02, 0., 1.5498993359418415e+02, 0.,
          2.5794624069819366e+02, 1.1498744146164572e+02, 0., 0., 1. ]
   distortion_coefficients: !!opencv-matrix
      rows: 5
      cols: 1
      dt: d
      data: [ -5.1219672628909629e-01, 4.7198744460368797e-01,
          -1.5977553548421185e-03, -2.9053305869271209e-03,
          -3.1165396541206108e-01 ]
   image_width: 346
   image_height: 260
calibration_time: "03/02/21 17:44:07"
)";

TEST(Calibration, ReadsOpenCvYamlAndTextLikeFiles) {
  const Calibration c = load_calibration_text(kOpenCvYaml, "calib.yaml");
  EXPECT_EQ(c.event_camera.width, 346);
  EXPECT_EQ(c.event_camera.height, 260);
  EXPECT_DOUBLE_EQ(c.event_camera.fx, 2.5990781754302105e+02);
  EXPECT_DOUBLE_EQ(c.event_camera.fy, 2.5794624069819366e+02);
  EXPECT_DOUBLE_EQ(c.event_camera.cx, 1.5498993359418415e+02);
  EXPECT_DOUBLE_EQ(c.event_camera.cy, 1.1498744146164572e+02);
  EXPECT_DOUBLE_EQ(c.event_camera.distortion.p2, -2.9053305869271209e-03);
  EXPECT_DOUBLE_EQ(c.event_camera.distortion.k3, -3.1165396541206108e-01);

  const auto xml = test::real_data("davis346_00000133_calibration.xml");
  FDV_REQUIRE_REAL_FILE(xml);
  const Calibration x = load_calibration_text(read_text(xml), "calib.xml");
  EXPECT_EQ(x.event_camera.width, c.event_camera.width);
  EXPECT_EQ(x.event_camera.fx, c.event_camera.fx);
  EXPECT_EQ(x.event_camera.cy, c.event_camera.cy);
  EXPECT_EQ(x.event_camera.distortion.k1, c.event_camera.distortion.k1);
  EXPECT_EQ(x.event_camera.distortion.k3, c.event_camera.distortion.k3);
}

TEST(Calibration, OpenCvMatrixSizeIsBoundedBeforeReading) {
  // f9: OpenCV allocated rows x cols (80 GB) before looking at the data.
  EXPECT_EQ(text_error("%YAML:1.0\n---\ncamera_matrix: !!opencv-matrix\n   rows: 100000\n"
                       "   cols: 100000\n   dt: d\n   data: [ 1. ]\nimage_width: 346\n"
                       "image_height: 260\n"),
            "key camera_matrix | declares 100000x100000: a calibration matrix has at most 14 "
            "elements");
  EXPECT_EQ(text_error("<?xml version=\"1.0\"?>\n<opencv_storage><cam><camera_matrix type_id=\"opencv-matrix\">"
                       "<rows>3</rows><cols>-7</cols><dt>d</dt><data>1</data></camera_matrix>"
                       "</cam></opencv_storage>\n"),
            "key cam.camera_matrix | declares 3x-7: a calibration matrix has at most 14 elements");
  EXPECT_EQ(text_error("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: z\n"
                       "   dt: d\n   data: [ 1 ]\n"),
            "key camera_matrix | rows and cols must be integers");
  EXPECT_EQ(text_error("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
                       "   dt: 3d\n   data: [ 1 ]\n"),
            "key camera_matrix.dt | '3d' is not a single-channel element type (u c w s i f d)");
  EXPECT_EQ(text_error("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
                       "   dt: d\n   data: [ 1, 2 ]\n"),
            "key camera_matrix.data | expected a list of 9 numbers (rows x cols)");
  EXPECT_EQ(text_error("<?xml version=\"1.0\"?>\n<opencv_storage><camera_matrix>"
                       "<rows>1</rows><cols>1</cols><dt>d</dt><data>1 2</data></camera_matrix>"
                       "</opencv_storage>\n"),
            "key camera_matrix.data | more than 1 numbers (rows x cols)");
  EXPECT_EQ(text_error("%YAML:1.0\ncamera_matrix: 5\n"),
            "key camera_matrix | expected an opencv-matrix {rows, cols, dt, data}");
}

TEST(Calibration, MalformedStructureNamesFileAndKey) {
  // f9: a scalar root made yaml-cpp throw BadSubscript, naming no file.
  EXPECT_EQ(text_error("just text\n"),
            " | expected a map of keys (event_camera, T_B_E, ...) at the top level");
  EXPECT_EQ(text_error("- 1\n- 2\n"),
            " | expected a map of keys (event_camera, T_B_E, ...) at the top level");
  EXPECT_EQ(text_error("%YAML:1.0\n--- 7\n"), " | expected a map of keys at the top level");
  EXPECT_EQ(text_error("event_camera: [1, 2]\n"), "key event_camera | missing camera section");
  // yaml-cpp quotes the offending byte; it is shown escaped.
  EXPECT_EQ(text_error(std::string("a: \"\\\x01\"\n")),
            "line 1, column 7 | unknown escape character: \\x01");
  EXPECT_EQ(text_error("<?xml version=\"1.0\"?>\n<other/>\n"),
            " | not an OpenCV storage file (no <opencv_storage> root element)");
  EXPECT_EQ(text_error("<?xml version=\"1.0\"?>\n<opencv_storage>\n<a>\n</opencv_storage>\n")
                .substr(0, 7),
            "line 3 ");  // where <a> opens
}

TEST(Calibration, DeepNestingAndHugeTextAreErrors) {
  // f3: 60 KB of '[' overflowed OpenCV's parser's stack.
  EXPECT_EQ(text_error("%YAML:1.0\na: " + std::string(60000, '[')).find(" | nested deeper"),
            std::string("line 2, column 1").size());
  EXPECT_NE(text_error("event_camera: " + std::string(60000, '{')).find("nested deeper"),
            std::string::npos);
  std::string xml = "<?xml version=\"1.0\"?>\n<opencv_storage>";
  for (int i = 0; i < 5000; ++i) xml += "<a>";
  EXPECT_NE(text_error(xml).find("not valid XML: XML_ELEMENT_DEPTH_EXCEEDED"), std::string::npos);
  EXPECT_EQ(text_error(std::string(kMaxConfigFileBytes + 1, '#')),
            " | larger than 1048576 bytes: not a configuration file");
}

TEST(Calibration, FuzzFindingsGiveInputErrorNamingTheFile) {
  // Each once hung (f2), crashed (f3), tried an 80 GB allocation or let a yaml-cpp / OpenCV /
  // std::length_error message out (f9). `where` is the key, or the line for a syntax error.
  const std::vector<std::pair<std::string, std::string>> cases{
      {"f2-opencv-yaml-hang.yaml", " | expected a map of keys at the top level"},
      {"f3-opencv-yaml-nesting.yaml", "line 3, column 1 | nested deeper than the YAML parser's limit"},
      {"f9-opencv-huge-matrix.yaml", "key camera_matrix | declares 100000x100000"},
      {"f9-opencv-matrix-size.yaml", "line 9, column 8 | illegal map value"},
      {"f9-foreign-exception-1.yaml", "key camera_matrix | rows and cols must be integers"},
      {"f9-foreign-exception-2.yaml", "line 2, column 4 | unknown escape character"},
      {"f9-foreign-exception-3.yaml", "line 9, column 8 | illegal map value"},
      {"f9-foreign-exception-4.yaml", "line 9, column 8 | illegal map value"},
      {"f9-foreign-exception-5.yaml", "line 9, column 8 | illegal map value"},
      // Its mapping repeats height (lines 2 and 6): refused before any key is read.
      {"f9-foreign-exception-6.yaml", "line 6, column 3 | duplicate key 'height' (first at line 2, column 3)"},
      {"f9-foreign-exception-7.yaml", " | expected a map of keys (event_camera, T_B_E, ...)"},
      {"f9-foreign-exception-8.yaml", "line 5, column 3 | unknown escape character"},
  };
  for (const auto& [name, expected] : cases) {
    const auto path = test::fuzz_finding("calibration/" + name);
    FDV_REQUIRE_REAL_FILE(path);
    try {
      load_calibration(path);
      ADD_FAILURE() << name << " was accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ((e.where() + " | " + e.reason()).rfind(expected, 0), 0u) << name << ": " << e.what();
    }
  }
}

TEST(Calibration, FileIsReadOnlyUpToTheSizeLimit) {
  const auto dir = test::scratch_dir("calib_size");
  const auto big = write_file(dir, "big.yaml", std::string(kMaxConfigFileBytes + 10, '#'));
  try {
    load_calibration(big);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), big);
    EXPECT_NE(e.reason().find("larger than"), std::string::npos);
  }
  try {
    load_calibration(dir);
    ADD_FAILURE() << "accepted a folder";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir);
  }
}

}  // namespace
}  // namespace fdv
