#include "fdv/io/dataset/dataset_reader.h"

#include <yaml-cpp/yaml.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <optional>

#include "fdv/core/error.h"
#include "fdv/io/table_stream.h"
#include "fdv/io/text_fields.h"

namespace fdv {
namespace fs = std::filesystem;
namespace {

/// The CSV streams of the folder (shared helper, fdv/io/table_stream.h).
template <typename T>
using CsvStream = TableStream<T>;

std::string parse_numbers(const std::vector<std::string_view>& f, std::size_t n, TimeNs& t,
                          double* values) {
  if (f.size() != n) return "expected " + std::to_string(n) + " columns";
  if (!parse_int64(f[0], t)) return "bad timestamp";
  for (std::size_t i = 1; i < n; ++i)
    if (!parse_double(f[i], values[i - 1])) return "malformed or non-finite value";
  return {};
}

std::string parse_pose(const std::vector<std::string_view>& f, OdometrySample& s) {
  double v[13];
  if (auto why = parse_numbers(f, 14, s.t, v); !why.empty()) return why;
  s.p_W_B = {v[0], v[1], v[2]};
  s.q_W_B = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);
  if (std::abs(s.q_W_B.norm() - 1.0) > 1e-3) return "quaternion is not unit length";
  s.q_W_B.normalize();
  s.v_W = {v[7], v[8], v[9]};
  s.omega_B = {v[10], v[11], v[12]};
  return {};
}

std::string parse_object(const std::vector<std::string_view>& f, ObjectState& s) {
  double v[7];
  if (auto why = parse_numbers(f, 8, s.t, v); !why.empty()) return why;
  if (v[0] != std::floor(v[0])) return "object id is not an integer";
  s.id = static_cast<int>(v[0]);
  s.p_W = {v[1], v[2], v[3]};
  s.v_W = {v[4], v[5], v[6]};
  return {};
}

/// A depth index row; the PNG is loaded only when the row is handed out.
struct DepthRef {
  TimeNs t = 0;
  std::string file;
};

class DatasetReader final : public RecordingReader {
 public:
  DatasetReader(const std::string& dir, const ReaderOptions& options)
      : dir_(dir),
        options_(options),
        imu_(fs::path(dir) / "imu.csv", "imu",
             [](const auto& f, ImuSample& s) {
               double v[6];
               auto why = parse_numbers(f, 7, s.t, v);
               s.gyro_rad_s = {v[0], v[1], v[2]};
               s.accel_m_s2 = {v[3], v[4], v[5]};
               return why;
             }),
        odometry_(fs::path(dir) / "odometry.csv", "odometry", parse_pose),
        depth_(fs::path(dir) / "depth.csv", "depth",
               [](const auto& f, DepthRef& d) -> std::string {
                 if (f.size() != 2) return "expected 2 columns";
                 if (!parse_int64(f[0], d.t)) return "bad timestamp";
                 d.file = std::string(f[1]);
                 return {};
               }),
        objects_(fs::path(dir) / "truth" / "objects.csv", "ground truth",
                 parse_object) {
    const std::string manifest_path = (fs::path(dir) / kDatasetManifest).string();
    YAML::Node manifest;
    try {
      manifest = YAML::LoadFile(manifest_path);
      info_.width = manifest["width"].as<int>();
      info_.height = manifest["height"].as<int>();
    } catch (const YAML::Exception& e) {
      throw InputError(manifest_path, "line " + std::to_string(e.mark.line + 1),
                       "bad manifest (needs integer width and height): " + e.msg);
    }
    info_.path = dir;
    info_.format = "fdv_dataset";
    if (const auto calib = fs::path(dir) / "calibration.yaml"; fs::exists(calib))
      info_.calibration = load_calibration(calib.string());
    open_events();
    info_.streams.push_back(StreamKind::kEvents);
    if (imu_.present()) info_.streams.push_back(StreamKind::kImu);
    if (depth_.present()) info_.streams.push_back(StreamKind::kDepth);
    if (odometry_.present()) info_.streams.push_back(StreamKind::kOdometry);
    if (objects_.present()) info_.streams.push_back(StreamKind::kGroundTruth);
  }

  const RecordingInfo& info() const override { return info_; }
  const ReadReport& report() const override { return report_; }

  bool read(SensorChunk& chunk) override {
    chunk.clear();
    read_events(chunk.events);
    // Other streams follow the events: everything up to the last event handed out, or, once
    // the events are exhausted, the rest in bounded pieces.
    const bool events_done = events_left_ == 0;
    const TimeNs horizon = events_done ? std::numeric_limits<TimeNs>::max()
                                       : (chunk.events.empty() ? last_event_t_ : chunk.events.back().t);
    const std::size_t cap = events_done ? 4096 : std::numeric_limits<std::size_t>::max();
    imu_.take_until(horizon, cap, chunk.imu, report_);
    odometry_.take_until(horizon, cap, chunk.odometry, report_);
    objects_.take_until(horizon, cap, chunk.ground_truth, report_);
    std::vector<DepthRef> refs;
    depth_.take_until(horizon, events_done ? 8 : cap, refs, report_);
    for (const auto& r : refs) load_depth(r, chunk.depth);
    return !chunk.empty() || !(events_done && imu_.exhausted(report_) &&
                               odometry_.exhausted(report_) && depth_.exhausted(report_) &&
                               objects_.exhausted(report_));
  }

 private:
  void open_events() {
    const std::string path = (fs::path(dir_) / "events.bin").string();
    events_path_ = path;
    events_.open(path, std::ios::binary);
    if (!events_) throw InputError(path, "", "cannot open (events.bin is required)");
    char header[kEventsHeaderBytes];
    events_.read(header, sizeof header);
    if (events_.gcount() != static_cast<std::streamsize>(sizeof header))
      throw InputError(path, "byte 0", "truncated header");
    if (std::memcmp(header, kEventsMagic, 8) != 0)
      throw InputError(path, "byte 0", "wrong magic (expected FDVEVT01)");
    std::uint32_t w, h;
    std::memcpy(&w, header + 8, 4);
    std::memcpy(&h, header + 12, 4);
    std::memcpy(&events_left_, header + 16, 8);
    if (static_cast<int>(w) != info_.width || static_cast<int>(h) != info_.height)
      throw InputError(path, "byte 8", "resolution differs from dataset.yaml");
    const auto bytes = fs::file_size(path) - kEventsHeaderBytes;
    const std::uint64_t present = bytes / 16;
    if (present < events_left_) {
      report_.drop("events.bin truncated: events missing at the end",
                   "byte " + std::to_string(kEventsHeaderBytes + present * 16), events_left_ - present);
      events_left_ = present;
    }
    sanitizer_.emplace(info_.width, info_.height);
  }

  void read_events(std::vector<Event>& out) {
    const std::size_t n = static_cast<std::size_t>(
        std::min<std::uint64_t>(events_left_, options_.chunk_events));
    if (n == 0) return;
    const auto offset = static_cast<std::uint64_t>(events_.tellg());
    bytes_.resize(n * 16);
    events_.read(bytes_.data(), static_cast<std::streamsize>(bytes_.size()));
    events_left_ -= n;
    raw_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {  // field by field: the polarity byte may be corrupt
      const char* r = bytes_.data() + i * 16;
      std::memcpy(&raw_[i].t, r, 8);
      std::memcpy(&raw_[i].x, r + 8, 2);
      std::memcpy(&raw_[i].y, r + 10, 2);
      raw_[i].polarity = r[12] != 0;
    }
    sanitizer_->append(raw_.data(), raw_.data() + n, out, report_, "byte " + std::to_string(offset));
    if (!raw_.empty()) last_event_t_ = std::max(last_event_t_, raw_.back().t);
  }

  void load_depth(const DepthRef& ref, std::vector<DepthFrame>& out) {
    const std::string path = (fs::path(dir_) / ref.file).string();
    const cv::Mat mm = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (mm.empty()) {
      report_.drop("depth: image missing or unreadable", path);
      return;
    }
    if (mm.type() != CV_16UC1) {
      report_.drop("depth: image is not 16-bit single channel", path);
      return;
    }
    const auto& cam = info_.calibration && info_.calibration->depth_camera
                          ? info_.calibration->depth_camera
                          : std::optional<PinholeCamera>{};
    if (cam && (mm.cols != cam->width || mm.rows != cam->height)) {
      report_.drop("depth: image size differs from the depth camera calibration", path);
      return;
    }
    DepthFrame f;
    f.t = ref.t;
    f.width = mm.cols;
    f.height = mm.rows;
    f.depth_m.resize(static_cast<std::size_t>(mm.total()));
    for (int v = 0; v < mm.rows; ++v)
      for (int u = 0; u < mm.cols; ++u)
        f.depth_m[static_cast<std::size_t>(v) * mm.cols + u] =
            static_cast<float>(mm.at<std::uint16_t>(v, u)) * 0.001f;
    out.push_back(std::move(f));
  }

  std::string dir_;
  ReaderOptions options_;
  RecordingInfo info_;
  ReadReport report_;
  std::string events_path_;
  std::ifstream events_;
  std::uint64_t events_left_ = 0;
  std::vector<char> bytes_;
  std::vector<Event> raw_;
  std::optional<EventSanitizer> sanitizer_;
  TimeNs last_event_t_ = std::numeric_limits<TimeNs>::min();
  CsvStream<ImuSample> imu_;
  CsvStream<OdometrySample> odometry_;
  CsvStream<DepthRef> depth_;
  CsvStream<ObjectState> objects_;
};

template <typename T>
std::vector<T> read_all(CsvStream<T>&& stream) {
  std::vector<T> out;
  ReadReport ignored;
  stream.take_until(std::numeric_limits<TimeNs>::max(), std::numeric_limits<std::size_t>::max(),
                    out, ignored);
  return out;
}

}  // namespace

std::unique_ptr<RecordingReader> open_dataset(const std::string& dir, const ReaderOptions& options) {
  return std::make_unique<DatasetReader>(dir, options);
}

std::vector<OdometrySample> read_body_truth(const std::string& dir) {
  return read_all(CsvStream<OdometrySample>(fs::path(dir) / "truth" / "body.csv", "body", parse_pose));
}

std::vector<ObjectState> read_object_truth(const std::string& dir) {
  return read_all(CsvStream<ObjectState>(
      fs::path(dir) / "truth" / "objects.csv", "ground truth", parse_object));
}

}  // namespace fdv
