#include "fdv/core/calibration.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <opencv2/core.hpp>
#include <sstream>

#include "fdv/core/error.h"

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
    if (std::abs(quat.norm() - 1.0) > 1e-3)
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

Calibration load_project_yaml(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::ParserException& e) {
    throw InputError(path, "line " + std::to_string(e.mark.line + 1), e.msg);
  }
  Calibration c;
  c.event_camera = read_camera(root["event_camera"], path, "event_camera");
  if (root["depth_camera"]) c.depth_camera = read_camera(root["depth_camera"], path, "depth_camera");
  c.T_B_E = read_transform(root["T_B_E"], path, "T_B_E");
  c.T_B_D = read_transform(root["T_B_D"], path, "T_B_D");
  if (root["R_B_I"]) c.R_B_I = read_rotation(root["R_B_I"], path, "R_B_I");
  return c;
}

// OpenCV FileStorage layout (XML or "%YAML:1.0"), optionally nested one level under a camera name.
Calibration load_opencv_storage(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw InputError(path, "", "not a readable OpenCV calibration file: " + e.msg);
  }
  if (!fs.isOpened()) throw InputError(path, "", "cannot open as an OpenCV calibration file");
  cv::FileNode node = fs.root();
  if (node["camera_matrix"].empty()) {
    const cv::FileNode root = fs.root();
    for (auto it = root.begin(); it != root.end(); ++it)
      if ((*it).isMap() && !(*it)["camera_matrix"].empty()) {
        node = *it;
        break;
      }
  }
  if (node["camera_matrix"].empty()) throw InputError(path, "key camera_matrix", "not found");
  cv::Mat K, D;
  node["camera_matrix"] >> K;
  node["distortion_coefficients"] >> D;
  if (K.rows != 3 || K.cols != 3) throw InputError(path, "key camera_matrix", "must be 3x3");
  K.convertTo(K, CV_64F);
  Calibration c;
  auto& cam = c.event_camera;
  cam.fx = K.at<double>(0, 0), cam.fy = K.at<double>(1, 1);
  cam.cx = K.at<double>(0, 2), cam.cy = K.at<double>(1, 2);
  if (!D.empty()) {
    D.convertTo(D, CV_64F);
    if (D.total() != 4 && D.total() != 5)
      throw InputError(path, "key distortion_coefficients",
                       "expected 4 or 5 coefficients (k1 k2 p1 p2 [k3]), got " +
                           std::to_string(D.total()));
    const double* d = D.ptr<double>();
    cam.distortion = {d[0], d[1], d[2], d[3], D.total() == 5 ? d[4] : 0.0};
  }
  cam.width = static_cast<int>(node["image_width"].empty() ? 0 : static_cast<int>(node["image_width"]));
  cam.height = static_cast<int>(node["image_height"].empty() ? 0 : static_cast<int>(node["image_height"]));
  if (cam.width == 0 || cam.height == 0)
    throw InputError(path, "key image_width/image_height", "missing image size");
  if (const auto why = cam.validate(); !why.empty()) throw InputError(path, "key camera_matrix", why);
  return c;
}

bool looks_like_opencv_storage(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open calibration file");
  std::string first;
  std::getline(in, first);
  return first.rfind("<?xml", 0) == 0 || first.rfind("%YAML:1.", 0) == 0;
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

Calibration load_calibration(const std::string& path) {
  Calibration c = looks_like_opencv_storage(path) ? load_opencv_storage(path) : load_project_yaml(path);
  if (auto why = c.validate(); !why.empty()) throw InputError(path, "", why);
  return c;
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
