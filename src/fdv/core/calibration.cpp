#include "fdv/core/calibration.h"

#include <tinyxml2.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <tuple>
#include <vector>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/core/sensor_data.h"

namespace fdv {
namespace {

bool is_rotation(const Eigen::Matrix3d& R) {
  return R.allFinite() && (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
         std::abs(R.determinant() - 1.0) < 1e-6;
}

std::vector<double> read_numbers(const YAML::Node& node, const std::string& file,
                                 const std::string& key, std::size_t expected) {
  if (!node || !node.IsSequence() || node.size() != expected)
    throw InputError(file, "key " + key,
                     "expected a list of " + std::to_string(expected) + " numbers");
  std::vector<double> v;
  for (const auto& n : node) {
    double x;
    try {
      x = n.as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(file, "key " + key, "'" + n.Scalar() + "' is not a number");
    }
    if (!std::isfinite(x)) throw InputError(file, "key " + key, "non-finite value");
    v.push_back(x);
  }
  return v;
}

PinholeCamera read_camera(const YAML::Node& node, const std::string& file, const std::string& key) {
  if (!node || !node.IsMap()) throw InputError(file, "key " + key, "missing camera section");
  PinholeCamera cam;
  try {
    cam.width = node["width"].as<int>();
    cam.height = node["height"].as<int>();
  } catch (const YAML::Exception&) {
    throw InputError(file, "key " + key, "width and height must be integers");
  }
  const auto k = read_numbers(node["intrinsics"], file, key + ".intrinsics", 4);
  cam.fx = k[0], cam.fy = k[1], cam.cx = k[2], cam.cy = k[3];
  if (node["distortion"]) {
    const auto d = read_numbers(node["distortion"], file, key + ".distortion", 5);
    cam.distortion = {d[0], d[1], d[2], d[3], d[4]};
  }
  if (const auto why = cam.validate(); !why.empty()) throw InputError(file, "key " + key, why);
  return cam;
}

Eigen::Matrix3d read_rotation(const YAML::Node& node, const std::string& file,
                              const std::string& key) {
  Eigen::Matrix3d R;
  if (node.IsSequence() && node.size() == 9) {
    const auto m = read_numbers(node, file, key, 9);
    R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(m.data());
  } else if (node.IsMap() && node["quaternion_xyzw"]) {
    const auto q = read_numbers(node["quaternion_xyzw"], file, key + ".quaternion_xyzw", 4);
    const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
    if (std::abs(quat.norm() - 1.0) > kUnitQuaternionTolerance)
      throw InputError(file, "key " + key, "quaternion is not unit length");
    R = quat.normalized().toRotationMatrix();
  } else {
    throw InputError(file, "key " + key,
                     "expected 9 numbers (row-major) or {quaternion_xyzw: [x, y, z, w]}");
  }
  if (!is_rotation(R)) throw InputError(file, "key " + key, "not a rotation matrix");
  return R;
}

Eigen::Isometry3d read_transform(const YAML::Node& node, const std::string& file,
                                 const std::string& key) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (!node) return T;
  if (node.IsSequence() && node.size() == 16) {
    const auto m = read_numbers(node, file, key, 16);
    const Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> M(m.data());
    if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
      throw InputError(file, "key " + key, "last row of a rigid transform must be 0 0 0 1");
    T.linear() = M.topLeftCorner<3, 3>();
    T.translation() = M.topRightCorner<3, 1>();
    if (!is_rotation(T.linear())) throw InputError(file, "key " + key, "not a rigid transform");
    return T;
  }
  if (!node.IsMap())
    throw InputError(file, "key " + key,
                     "expected 16 numbers (row-major 4x4) or {translation, quaternion_xyzw}");
  const auto t = read_numbers(node["translation"], file, key + ".translation", 3);
  T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  T.linear() = read_rotation(node, file, key);
  return T;
}

Calibration read_project_yaml(const YAML::Node& root, const std::string& file) {
  if (root && !root.IsNull() && !root.IsMap())
    throw InputError(file, "", "expected a map of keys (event_camera, T_B_E, ...) at the top level");
  Calibration c;
  c.event_camera = read_camera(root["event_camera"], file, "event_camera");
  if (root["depth_camera"]) c.depth_camera = read_camera(root["depth_camera"], file, "depth_camera");
  c.T_B_E = read_transform(root["T_B_E"], file, "T_B_E");
  c.T_B_D = read_transform(root["T_B_D"], file, "T_B_D");
  if (root["R_B_I"]) c.R_B_I = read_rotation(root["R_B_I"], file, "R_B_I");
  return c;
}

Calibration load_project_yaml(std::string_view text, const std::string& file) {
  const YAML::Node root = parse_config_yaml(text, file);
  return yaml_errors_as_input_errors(file, [&] { return read_project_yaml(root, file); });
}

// ---- OpenCV FileStorage layout, read without OpenCV (its parser hangs and overflows the stack
// on hostile text): YAML via yaml-cpp, XML via tinyxml2. The calibration sits at the top level or
// inside one named map (the DV software writes <opencv_storage><DAVIS346_...>).

/// Largest matrix a calibration holds [elements]: OpenCV's richest distortion model has 14
/// coefficients, the camera matrix 9. Checked on rows and cols before the data is read.
constexpr long long kMaxCalibrationMatrixElements = 14;

/// A matrix as declared by an `opencv-matrix` node, single channel, row-major.
struct CvMatrix {
  long long rows = 0, cols = 0;
  std::vector<double> data;
};

/// OpenCV element type of `dt` ("d", "f", "i", ...; a leading "1" allowed): 0 when unsupported.
char matrix_type(std::string dt) {
  if (dt.size() == 2 && dt[0] == '1') dt.erase(0, 1);
  if (dt.size() == 1 && std::string_view("ucwsifd").find(dt[0]) != std::string_view::npos) return dt[0];
  return 0;
}

/// What OpenCV stores for `x` in an element of type `t` (integers rounded and saturated).
double as_element(double x, char t) {
  auto sat = [x](double lo, double hi) { return std::clamp(std::nearbyint(x), lo, hi); };
  switch (t) {
    case 'u': return sat(0, 255);
    case 'c': return sat(-128, 127);
    case 'w': return sat(0, 65535);
    case 's': return sat(-32768, 32767);
    case 'i': return sat(-2147483648.0, 2147483647.0);
    case 'f': return static_cast<double>(static_cast<float>(x));
    default: return x;
  }
}

/// Checks a declared shape and type before anything is allocated for the data.
char check_matrix_header(long long rows, long long cols, const std::string& dt,
                         const std::string& file, const std::string& key) {
  if (rows < 0 || cols < 0 || rows > kMaxCalibrationMatrixElements ||
      cols > kMaxCalibrationMatrixElements || rows * cols > kMaxCalibrationMatrixElements)
    throw InputError(file, "key " + key,
                     "declares " + std::to_string(rows) + "x" + std::to_string(cols) +
                         ": a calibration matrix has at most " +
                         std::to_string(kMaxCalibrationMatrixElements) + " elements");
  const char t = matrix_type(dt);
  if (t == 0)
    throw InputError(file, "key " + key + ".dt",
                     "'" + dt.substr(0, 16) + "' is not a single-channel element type (u c w s i f d)");
  return t;
}

std::optional<double> finite_number(const char* s) {
  if (s == nullptr) return std::nullopt;
  while (std::isspace(static_cast<unsigned char>(*s))) ++s;
  if (*s == '\0') return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  while (std::isspace(static_cast<unsigned char>(*end))) ++end;
  if (*end != '\0' || !std::isfinite(v)) return std::nullopt;
  return v;
}

/// An integer in [-2^31, 2^31) given as a number (OpenCV rounds a real one).
std::optional<long long> integer_value(std::optional<double> v) {
  if (!v || *v < -2147483648.0 || *v > 2147483647.0) return std::nullopt;
  return std::llround(*v);
}

std::optional<double> yaml_number(const YAML::Node& n) {
  if (!n || !n.IsScalar()) return std::nullopt;
  return finite_number(n.Scalar().c_str());
}

CvMatrix read_yaml_matrix(const YAML::Node& n, const std::string& file, const std::string& key) {
  if (!n.IsMap()) throw InputError(file, "key " + key, "expected an opencv-matrix {rows, cols, dt, data}");
  const auto rows = integer_value(yaml_number(n["rows"]));
  const auto cols = integer_value(yaml_number(n["cols"]));
  if (!rows || !cols) throw InputError(file, "key " + key, "rows and cols must be integers");
  const YAML::Node dt_node = n["dt"];
  const std::string dt = dt_node && dt_node.IsScalar() ? dt_node.Scalar() : "";
  const char t = check_matrix_header(*rows, *cols, dt, file, key);
  CvMatrix m{*rows, *cols, {}};
  const std::size_t expected = static_cast<std::size_t>(*rows * *cols);
  const YAML::Node data = n["data"];
  if (expected == 0 && (!data || data.IsNull())) return m;
  if (!data || !data.IsSequence() || data.size() != expected)
    throw InputError(file, "key " + key + ".data",
                     "expected a list of " + std::to_string(expected) + " numbers (rows x cols)");
  for (std::size_t i = 0; i < expected; ++i) {
    const auto v = yaml_number(data[i]);
    if (!v) throw InputError(file, "key " + key + ".data", "element " + std::to_string(i) + " is not a finite number");
    m.data.push_back(as_element(*v, t));
  }
  return m;
}

const char* xml_text(const tinyxml2::XMLElement* e, const char* name) {
  const tinyxml2::XMLElement* c = e->FirstChildElement(name);
  return c == nullptr ? nullptr : c->GetText();
}

CvMatrix read_xml_matrix(const tinyxml2::XMLElement* e, const std::string& file, const std::string& key) {
  const auto rows = integer_value(finite_number(xml_text(e, "rows")));
  const auto cols = integer_value(finite_number(xml_text(e, "cols")));
  if (!rows || !cols) throw InputError(file, "key " + key, "rows and cols must be integers");
  const char* dt_text = xml_text(e, "dt");
  std::string dt = dt_text == nullptr ? "" : dt_text;
  dt.erase(0, dt.find_first_not_of(" \t\r\n"));
  dt.erase(dt.find_last_not_of(" \t\r\n") + 1);
  const char t = check_matrix_header(*rows, *cols, dt, file, key);
  CvMatrix m{*rows, *cols, {}};
  const std::size_t expected = static_cast<std::size_t>(*rows * *cols);
  // Whitespace-separated numbers; at most `expected` are kept, one more is an error.
  std::istringstream in(xml_text(e, "data") == nullptr ? "" : xml_text(e, "data"));
  std::string token;
  while (in >> token) {
    const auto v = finite_number(token.c_str());
    if (!v) throw InputError(file, "key " + key + ".data", "'" + token.substr(0, 40) + "' is not a finite number");
    if (m.data.size() == expected)
      throw InputError(file, "key " + key + ".data", "more than " + std::to_string(expected) + " numbers (rows x cols)");
    m.data.push_back(as_element(*v, t));
  }
  if (m.data.size() != expected)
    throw InputError(file, "key " + key + ".data",
                     "expected " + std::to_string(expected) + " numbers (rows x cols), got " +
                         std::to_string(m.data.size()));
  return m;
}

/// The calibration's entries as found in either encoding; `prefix` is "" or "NAME.".
struct OpenCvEntries {
  std::string prefix;
  CvMatrix K;
  std::optional<CvMatrix> D;
  std::optional<long long> width, height;
};

Calibration from_opencv_entries(const OpenCvEntries& in, const std::string& file) {
  const std::string K_key = in.prefix + "camera_matrix";
  if (in.K.rows != 3 || in.K.cols != 3) throw InputError(file, "key " + K_key, "must be 3x3");
  Calibration c;
  auto& cam = c.event_camera;
  const auto& k = in.K.data;
  cam.fx = k[0], cam.fy = k[4], cam.cx = k[2], cam.cy = k[5];
  if (in.D && !in.D->data.empty()) {
    const auto& d = in.D->data;
    if (d.size() != 4 && d.size() != 5)
      throw InputError(file, "key " + in.prefix + "distortion_coefficients",
                       "expected 4 or 5 coefficients (k1 k2 p1 p2 [k3]), got " + std::to_string(d.size()));
    cam.distortion = {d[0], d[1], d[2], d[3], d.size() == 5 ? d[4] : 0.0};
  }
  for (auto [name, value, field] : {std::tuple{"image_width", in.width, &cam.width},
                                    std::tuple{"image_height", in.height, &cam.height}}) {
    if (!value || *value == 0) throw InputError(file, "key " + in.prefix + name, "missing image size");
    *field = static_cast<int>(*value);
  }
  if (const auto why = cam.validate(); !why.empty()) throw InputError(file, "key " + K_key, why);
  return c;
}

bool present(const YAML::Node& n) { return n && !n.IsNull(); }

Calibration load_opencv_yaml(std::string_view text, const std::string& file) {
  const YAML::Node root = parse_config_yaml(text, file);
  try {
    if (!root.IsMap()) throw InputError(file, "", "expected a map of keys at the top level");
    OpenCvEntries e;
    // Built, not assigned: a YAML::Node assignment would write into the tree it refers to.
    const YAML::Node node = [&]() -> YAML::Node {
      if (present(root["camera_matrix"])) return root;
      for (const auto& kv : root)
        if (kv.second.IsMap() && present(kv.second["camera_matrix"])) {
          e.prefix = (kv.first.IsScalar() ? kv.first.Scalar() : "?") + ".";
          return kv.second;
        }
      return root;
    }();
    if (!present(node["camera_matrix"])) throw InputError(file, "key camera_matrix", "not found");
    e.K = read_yaml_matrix(node["camera_matrix"], file, e.prefix + "camera_matrix");
    if (present(node["distortion_coefficients"]))
      e.D = read_yaml_matrix(node["distortion_coefficients"], file, e.prefix + "distortion_coefficients");
    e.width = integer_value(yaml_number(node["image_width"]));
    e.height = integer_value(yaml_number(node["image_height"]));
    return from_opencv_entries(e, file);
  } catch (const YAML::Exception& e) {
    throw InputError(file, yaml_position(e.mark), yaml_reason(e));
  }
}

Calibration load_opencv_xml(std::string_view text, const std::string& file) {
  check_config_text(text, file);
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.data(), text.size()) != tinyxml2::XML_SUCCESS)
    throw InputError(file, "line " + std::to_string(doc.ErrorLineNum()),
                     std::string("not valid XML: ") + doc.ErrorName());
  const tinyxml2::XMLElement* root = doc.RootElement();
  if (root == nullptr || std::string_view(root->Name()) != "opencv_storage")
    throw InputError(file, "", "not an OpenCV storage file (no <opencv_storage> root element)");
  const tinyxml2::XMLElement* node = root;
  OpenCvEntries e;
  if (root->FirstChildElement("camera_matrix") == nullptr)
    for (const auto* child = root->FirstChildElement(); child != nullptr; child = child->NextSiblingElement())
      if (child->FirstChildElement("camera_matrix") != nullptr) {
        node = child;
        e.prefix = std::string(child->Name()) + ".";
        break;
      }
  const auto* K = node->FirstChildElement("camera_matrix");
  if (K == nullptr) throw InputError(file, "key camera_matrix", "not found");
  e.K = read_xml_matrix(K, file, e.prefix + "camera_matrix");
  if (const auto* D = node->FirstChildElement("distortion_coefficients"); D != nullptr && !D->NoChildren())
    e.D = read_xml_matrix(D, file, e.prefix + "distortion_coefficients");
  e.width = integer_value(finite_number(xml_text(node, "image_width")));
  e.height = integer_value(finite_number(xml_text(node, "image_height")));
  return from_opencv_entries(e, file);
}

/// The OpenCV layouts announce themselves on the first line, as OpenCV requires.
enum class CalibrationFormat { kProjectYaml, kOpenCvYaml, kOpenCvXml };
CalibrationFormat detect_format(std::string_view text) {
  if (text.rfind("<?xml", 0) == 0) return CalibrationFormat::kOpenCvXml;
  if (text.rfind("%YAML:1.", 0) == 0) return CalibrationFormat::kOpenCvYaml;
  return CalibrationFormat::kProjectYaml;
}

void write_transform(YAML::Emitter& out, const std::string& key, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  out << YAML::Key << key << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "translation" << YAML::Value << YAML::Flow
      << std::vector<double>{T.translation().x(), T.translation().y(), T.translation().z()};
  out << YAML::Key << "quaternion_xyzw" << YAML::Value << YAML::Flow
      << std::vector<double>{q.x(), q.y(), q.z(), q.w()};
  out << YAML::EndMap;
}

void write_camera(YAML::Emitter& out, const std::string& key, const PinholeCamera& c) {
  out << YAML::Key << key << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "width" << YAML::Value << c.width;
  out << YAML::Key << "height" << YAML::Value << c.height;
  out << YAML::Key << "intrinsics" << YAML::Value << YAML::Flow
      << std::vector<double>{c.fx, c.fy, c.cx, c.cy};
  const auto& d = c.distortion;
  out << YAML::Key << "distortion" << YAML::Value << YAML::Flow
      << std::vector<double>{d.k1, d.k2, d.p1, d.p2, d.k3};
  out << YAML::EndMap;
}

}  // namespace

std::string Calibration::validate() const {
  if (auto why = event_camera.validate(); !why.empty()) return "event_camera: " + why;
  if (depth_camera)
    if (auto why = depth_camera->validate(); !why.empty()) return "depth_camera: " + why;
  if (!is_rotation(T_B_E.linear()) || !T_B_E.translation().allFinite()) return "T_B_E: not rigid";
  if (!is_rotation(T_B_D.linear()) || !T_B_D.translation().allFinite()) return "T_B_D: not rigid";
  if (!is_rotation(R_B_I)) return "R_B_I: not a rotation";
  return {};
}

Calibration load_calibration_text(std::string_view text, const std::string& name) {
  Calibration c;
  switch (detect_format(text)) {
    case CalibrationFormat::kOpenCvXml: c = load_opencv_xml(text, name); break;
    case CalibrationFormat::kOpenCvYaml: c = load_opencv_yaml(text, name); break;
    case CalibrationFormat::kProjectYaml: c = load_project_yaml(text, name); break;
  }
  if (auto why = c.validate(); !why.empty()) throw InputError(name, "", why);
  return c;
}

Calibration load_calibration(const std::string& path) {
  return load_calibration_text(read_config_file(path), path);
}

void save_calibration(const Calibration& calib, const std::string& path) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  write_camera(out, "event_camera", calib.event_camera);
  if (calib.depth_camera) write_camera(out, "depth_camera", *calib.depth_camera);
  write_transform(out, "T_B_E", calib.T_B_E);
  write_transform(out, "T_B_D", calib.T_B_D);
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = calib.R_B_I;
  out << YAML::Key << "R_B_I" << YAML::Value << YAML::Flow
      << std::vector<double>(R.data(), R.data() + 9);
  out << YAML::EndMap;
  std::ofstream f(path);
  if (!f) throw InputError(path, "", "cannot write calibration file");
  f << out.c_str() << "\n";
}

}  // namespace fdv
