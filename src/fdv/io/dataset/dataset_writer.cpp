#include "fdv/io/dataset/dataset_writer.h"

#include <yaml-cpp/yaml.h>

#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <memory>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/io/dataset/depth_image.h"

namespace fdv {
namespace fs = std::filesystem;
namespace {

std::ofstream open_out(const fs::path& path, const char* header, bool binary = false) {
  std::ofstream f(path, binary ? std::ios::binary : std::ios::out);
  if (!f) throw InputError(path.string(), "", "cannot create file");
  if (header) f << header << "\n";
  return f;
}

std::string pose_row(const OdometrySample& s) {
  return fmt::format("{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n",
                     s.t, s.p_W_B.x(), s.p_W_B.y(), s.p_W_B.z(), s.q_W_B.x(), s.q_W_B.y(),
                     s.q_W_B.z(), s.q_W_B.w(), s.v_W.x(), s.v_W.y(), s.v_W.z(), s.omega_B.x(),
                     s.omega_B.y(), s.omega_B.z());
}

std::string imu_row(const ImuSample& s) {
  return fmt::format("{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", s.t, s.gyro_rad_s.x(),
                     s.gyro_rad_s.y(), s.gyro_rad_s.z(), s.accel_m_s2.x(), s.accel_m_s2.y(),
                     s.accel_m_s2.z());
}

/// The one sample a reader parses from `row`, or nothing if it drops it.
template <class Sample, class Read>
std::optional<Sample> read_back(std::string row, Read read) {
  ReadReport report;
  std::vector<Sample> samples = read(std::make_unique<std::istringstream>(std::move(row)), "as_stored", report);
  if (samples.size() != 1) return std::nullopt;
  return samples.front();
}

constexpr const char* kPoseHeader = "# t_ns,px,py,pz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz";

}  // namespace

DatasetWriter::DatasetWriter(const std::string& dir, const Calibration& calib,
                             DepthEncoding depth_encoding)
    : dir_(dir),
      width_(calib.event_camera.width),
      height_(calib.event_camera.height),
      depth_encoding_(depth_encoding) {
  fs::create_directories(fs::path(dir) / "depth");
  fs::create_directories(fs::path(dir) / "truth");
  save_calibration(calib, (fs::path(dir) / "calibration.yaml").string());
  events_ = open_out(fs::path(dir) / "events.bin", nullptr, true);
  char header[kEventsHeaderBytes] = {};
  std::memcpy(header, kEventsMagic, 8);
  const auto w = static_cast<std::uint32_t>(width_), h = static_cast<std::uint32_t>(height_);
  std::memcpy(header + 8, &w, 4);
  std::memcpy(header + 12, &h, 4);
  events_.write(header, sizeof header);
  imu_ = open_out(fs::path(dir) / "imu.csv", "# t_ns,gx,gy,gz,ax,ay,az");
  odometry_ = open_out(fs::path(dir) / "odometry.csv", kPoseHeader);
  depth_index_ = open_out(fs::path(dir) / "depth.csv", "# t_ns,file");
  objects_ = open_out(fs::path(dir) / "truth" / "objects.csv", "# t_ns,id,px,py,pz,vx,vy,vz");
  body_ = open_out(fs::path(dir) / "truth" / "body.csv", kPoseHeader);
}

DatasetWriter::~DatasetWriter() {
  if (!finished_) {
    try {
      finish();
    } catch (...) {  // destructors must not throw; an explicit finish() reports errors
    }
  }
}

void DatasetWriter::add_events(std::span<const Event> events) {
  // Event is 16 bytes with 3 zeroed padding bytes; write field by field so padding is defined.
  static_assert(std::endian::native == std::endian::little, "events.bin is little-endian");
  std::vector<char> buf(events.size() * 16, 0);
  for (std::size_t i = 0; i < events.size(); ++i) {
    char* r = buf.data() + i * 16;
    std::memcpy(r, &events[i].t, 8);
    std::memcpy(r + 8, &events[i].x, 2);
    std::memcpy(r + 10, &events[i].y, 2);
    r[12] = events[i].polarity ? 1 : 0;
  }
  events_.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  event_count_ += events.size();
}

void DatasetWriter::add_imu(const ImuSample& s) { imu_ << imu_row(s); }

void DatasetWriter::add_odometry(const OdometrySample& s) { odometry_ << pose_row(s); }
void DatasetWriter::add_body_truth(const OdometrySample& s) { body_ << pose_row(s); }

void DatasetWriter::add_unflown_body_truth(const OdometrySample& s) {
  if (!body_unflown_.is_open())
    body_unflown_ = open_out(fs::path(dir_) / "truth" / "body_unflown.csv", kPoseHeader);
  body_unflown_ << pose_row(s);
}

void DatasetWriter::add_object_truth(const ObjectState& s) {
  objects_ << fmt::format("{},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", s.t, s.id, s.p_W.x(),
                          s.p_W.y(), s.p_W.z(), s.v_W.x(), s.v_W.y(), s.v_W.z());
}

void DatasetWriter::add_depth(const DepthFrame& frame) {
  millimetres_.resize(frame.depth_m.size());
  metres_to_millimetres(frame.depth_m, millimetres_);
  const bool png = depth_encoding_ == DepthEncoding::kPng;
  const std::string name = fmt::format("depth/{:06d}.{}", depth_count_++, png ? "png" : "zst");
  const std::vector<std::uint8_t> bytes =
      png ? encode_depth_png(millimetres_, frame.width, frame.height) : encode_depth_zstd(millimetres_);
  const fs::path path = fs::path(dir_) / name;
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw InputError(path.string(), "", "cannot write depth frame (disk full?)");
  depth_index_ << frame.t << "," << name << "\n";
}

void DatasetWriter::finish(const std::string& manifest_extra) {
  if (finished_) return;
  finished_ = true;
  events_.seekp(16);
  events_.write(reinterpret_cast<const char*>(&event_count_), 8);
  for (auto* f : {&events_, &imu_, &odometry_, &depth_index_, &objects_, &body_, &body_unflown_}) {
    if (f == &body_unflown_ && !f->is_open()) continue;
    f->close();
    if (f->fail()) throw InputError(dir_, "", "write failed (disk full?)");
  }
  YAML::Node manifest = manifest_extra.empty() ? YAML::Node(YAML::NodeType::Map)
                                               : YAML::Load(manifest_extra);
  manifest["format"] = "fdv_dataset";
  manifest["format_version"] = 1;
  manifest["width"] = width_;
  manifest["height"] = height_;
  manifest["events"] = event_count_;
  std::ofstream m(fs::path(dir_) / kDatasetManifest);
  m << manifest << "\n";
  if (!m) throw InputError(dir_, "", "cannot write dataset.yaml");
}

std::optional<ImuSample> as_stored(const ImuSample& s) {
  return read_back<ImuSample>(imu_row(s), read_dataset_imu);
}

std::optional<OdometrySample> as_stored(const OdometrySample& s) {
  return read_back<OdometrySample>(pose_row(s), read_dataset_poses);
}

DepthFrame as_stored(const DepthFrame& frame) {
  std::vector<std::uint16_t> millimetres(frame.depth_m.size());
  metres_to_millimetres(frame.depth_m, millimetres);
  DepthFrame out = frame;
  millimetres_to_metres(millimetres, out.depth_m);
  return out;
}

}  // namespace fdv
