#include "fdv/io/dataset/dataset_reader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/io/dataset/depth_image.h"
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
  if (std::abs(s.q_W_B.norm() - 1.0) > kUnitQuaternionTolerance) return "quaternion is not unit length";
  s.q_W_B.normalize();
  s.v_W = {v[7], v[8], v[9]};
  s.omega_B = {v[10], v[11], v[12]};
  return {};
}

std::string parse_object(const std::vector<std::string_view>& f, ObjectState& s) {
  double v[7];
  if (auto why = parse_numbers(f, 8, s.t, v); !why.empty()) return why;
  if (v[0] != std::floor(v[0]) || std::abs(v[0]) > std::numeric_limits<int>::max())
    return "object id is not an integer";
  s.id = static_cast<int>(v[0]);
  s.p_W = {v[1], v[2], v[3]};
  s.v_W = {v[4], v[5], v[6]};
  return {};
}

std::string parse_imu(const std::vector<std::string_view>& f, ImuSample& s) {
  double v[6];
  if (auto why = parse_numbers(f, 7, s.t, v); !why.empty()) return why;
  s.gyro_rad_s = {v[0], v[1], v[2]};
  s.accel_m_s2 = {v[3], v[4], v[5]};
  return {};
}

std::string parse_depth_row(const std::vector<std::string_view>& f, DepthIndexRow& d) {
  if (f.size() != 2) return "expected 2 columns";
  if (!parse_int64(f[0], d.t)) return "bad timestamp";
  // The frame must be a file inside the folder: an absolute path or ".." could name a device.
  const fs::path file(f[1]);
  if (f[1].empty() || file.is_absolute()) return "file path leaves the dataset folder";
  for (const auto& part : file)
    if (part == "..") return "file path leaves the dataset folder";
  d.file = std::string(f[1]);
  return {};
}

/// The size of a seekable stream, leaving it at the start; nullopt if it cannot be seeked.
std::optional<std::uint64_t> stream_size(std::istream& in) {
  in.seekg(0, std::ios::end);
  const std::streamoff end = in.tellg();
  in.seekg(0, std::ios::beg);
  if (!in || end < 0) return std::nullopt;
  return static_cast<std::uint64_t>(end);
}

/// events.bin: the header, then the records a bounded number at a time.
class EventRecords {
 public:
  EventRecords(std::unique_ptr<std::istream> in, std::string name, int width, int height,
               ReadReport& report)
      : name_(std::move(name)), in_(std::move(in)), sanitizer_(width, height) {
    const auto size = in_ ? stream_size(*in_) : std::nullopt;
    if (!size) throw InputError(name_, "", "cannot read (events.bin is required)");
    char header[kEventsHeaderBytes];
    in_->read(header, sizeof header);
    if (in_->gcount() != static_cast<std::streamsize>(sizeof header))
      throw InputError(name_, "byte 0", "truncated header");
    if (std::memcmp(header, kEventsMagic, 8) != 0)
      throw InputError(name_, "byte 0", "wrong magic (expected FDVEVT01)");
    std::uint32_t w, h;
    std::memcpy(&w, header + 8, 4);
    std::memcpy(&h, header + 12, 4);
    std::memcpy(&left_, header + 16, 8);
    if (w != static_cast<std::uint32_t>(width) || h != static_cast<std::uint32_t>(height))
      throw InputError(name_, "byte 8", "resolution differs from dataset.yaml");
    // The count is bounded by the bytes present, never allocated as declared.
    const std::uint64_t present =
        *size > kEventsHeaderBytes ? (*size - kEventsHeaderBytes) / 16 : 0;
    if (present < left_) {
      report.drop("events.bin truncated: events missing at the end",
                  "byte " + std::to_string(kEventsHeaderBytes + present * 16), left_ - present);
      left_ = present;
    }
  }

  bool done() const { return left_ == 0; }
  TimeNs last_time() const { return last_t_; }

  /// Reads up to max_events records and appends the valid events to `out`.
  void read(std::size_t max_events, std::vector<Event>& out, ReadReport& report) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left_, max_events));
    if (n == 0) return;
    const std::uint64_t offset = kEventsHeaderBytes + read_ * 16;
    bytes_.resize(n * 16);
    in_->read(bytes_.data(), static_cast<std::streamsize>(bytes_.size()));
    // Fewer bytes than the size promised: the file shrank while being read.
    const std::size_t got = static_cast<std::size_t>(std::max<std::streamsize>(0, in_->gcount())) / 16;
    if (got < n) {
      report.drop("events.bin truncated: events missing at the end",
                  "byte " + std::to_string(offset + got * 16), left_ - got);
      left_ = got;
    }
    left_ -= got;
    read_ += got;
    raw_.resize(got);
    record_.resize(got);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < got; ++i) {  // field by field: the polarity byte may be corrupt
      const char* r = bytes_.data() + i * 16;
      // A polarity other than 0 or 1, or padding that is not zero, is damage: the record's other
      // fields are not to be trusted either.
      if (static_cast<unsigned char>(r[12]) > 1 || r[13] != 0 || r[14] != 0 || r[15] != 0) {
        report.drop("events.bin: polarity not 0 or 1, or padding not zero", "byte " + std::to_string(offset + i * 16));
        continue;
      }
      record_[kept] = i;
      Event& e = raw_[kept++];
      std::memcpy(&e.t, r, 8);
      std::memcpy(&e.x, r + 8, 2);
      std::memcpy(&e.y, r + 10, 2);
      e.polarity = r[12] != 0;
    }
    raw_.resize(kept);
    sanitizer_.append(raw_.data(), raw_.data() + kept, out, report,
                      [&](std::size_t k) { return "byte " + std::to_string(offset + record_[k] * 16); });
    if (!raw_.empty()) last_t_ = std::max(last_t_, raw_.back().t);
  }

 private:
  std::string name_;
  std::unique_ptr<std::istream> in_;
  EventSanitizer sanitizer_;
  std::uint64_t left_ = 0, read_ = 0;
  std::vector<char> bytes_;
  std::vector<Event> raw_;
  std::vector<std::size_t> record_;  ///< raw_[k] is record record_[k] of the batch
  TimeNs last_t_ = std::numeric_limits<TimeNs>::min();
};

std::unique_ptr<std::istream> open_binary(const std::string& path) {
  return std::make_unique<std::ifstream>(path, std::ios::binary);
}

template <typename T>
std::vector<T> read_all(CsvStream<T>&& stream, ReadReport& report) {
  std::vector<T> out;
  stream.take_until(std::numeric_limits<TimeNs>::max(), std::numeric_limits<std::size_t>::max(),
                    out, report);
  return out;
}

/// `dir`, once each file of the dataset that is there is known to be a regular file: opening a
/// FIFO blocks until a writer comes, a device never ends, and a folder is no table.
const std::string& with_regular_files(const std::string& dir) {
  for (const char* name : {kDatasetManifest, "calibration.yaml", "events.bin", "imu.csv", "odometry.csv",
                           "depth.csv", "truth/objects.csv"})
    check_regular_file((fs::path(dir) / name).string());
  return dir;
}

class DatasetReader final : public RecordingReader {
 public:
  DatasetReader(const std::string& dir, const ReaderOptions& options)
      : dir_(with_regular_files(dir)),
        options_(options),
        imu_(fs::path(dir) / "imu.csv", "imu", parse_imu),
        odometry_(fs::path(dir) / "odometry.csv", "odometry", parse_pose),
        depth_(fs::path(dir) / "depth.csv", "depth", parse_depth_row),
        objects_(fs::path(dir) / "truth" / "objects.csv", "ground truth", parse_object) {
    const std::string manifest_path = (fs::path(dir) / kDatasetManifest).string();
    const DatasetManifest manifest = parse_dataset_manifest(read_config_file(manifest_path), manifest_path);
    info_.width = manifest.width;
    info_.height = manifest.height;
    info_.path = dir;
    info_.format = "fdv_dataset";
    std::error_code ec;
    if (const auto calib = fs::path(dir) / "calibration.yaml"; fs::exists(calib, ec) || ec)
      info_.calibration = load_calibration(calib.string());
    const std::string events_path = (fs::path(dir) / "events.bin").string();
    events_.emplace(open_binary(events_path), events_path, info_.width, info_.height, report_);
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
    events_->read(std::max<std::size_t>(1, options_.chunk_events), chunk.events, report_);
    // Other streams follow the events: everything up to the last event handed out, or, once
    // the events are exhausted, the rest in bounded pieces.
    const bool events_done = events_->done();
    const TimeNs horizon = events_done ? std::numeric_limits<TimeNs>::max()
                                       : (chunk.events.empty() ? events_->last_time() : chunk.events.back().t);
    const std::size_t cap = events_done ? 4096 : kMaxTableRowsPerChunk;
    imu_.take_until(horizon, cap, chunk.imu, report_);
    odometry_.take_until(horizon, cap, chunk.odometry, report_);
    objects_.take_until(horizon, cap, chunk.ground_truth, report_);
    std::vector<DepthIndexRow> refs;
    depth_.take_until(horizon, kMaxDepthFramesPerChunk, refs, report_);
    for (const auto& r : refs)
      if (auto frame = load_depth(r)) chunk.depth.push_back(std::move(*frame));
    return !chunk.empty() || !(events_done && imu_.exhausted(report_) &&
                               odometry_.exhausted(report_) && depth_.exhausted(report_) &&
                               objects_.exhausted(report_));
  }

 private:
  std::optional<DepthFrame> load_depth(const DepthIndexRow& ref) {
    const std::string path = (fs::path(dir_) / ref.file).string();
    // The name comes from depth.csv: the report (and fdv info's JSON) needs it as UTF-8.
    const std::string shown = escape_non_utf8(path);
    // Only a regular file of bounded size is read (not a FIFO or a device).
    std::error_code ec;
    const auto status = fs::status(path, ec);
    if (ec || !fs::is_regular_file(status)) {
      report_.drop("depth: image missing or unreadable", shown);
      return std::nullopt;
    }
    const std::uint64_t size = fs::file_size(path, ec);
    if (ec || size > kMaxDepthFileBytes) {
      report_.drop("depth: image file larger than " + std::to_string(kMaxDepthFileBytes) + " bytes",
                   shown);
      return std::nullopt;
    }
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
    std::ifstream in(path, std::ios::binary);
    in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    bytes.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
    const auto& cam = info_.calibration ? info_.calibration->depth_camera
                                        : std::optional<PinholeCamera>{};
    return decode_dataset_depth(bytes, ref.t, cam, shown, report_);
  }

  std::string dir_;
  ReaderOptions options_;
  RecordingInfo info_;
  ReadReport report_;
  std::optional<EventRecords> events_;
  CsvStream<ImuSample> imu_;
  CsvStream<OdometrySample> odometry_;
  CsvStream<DepthIndexRow> depth_;
  CsvStream<ObjectState> objects_;
};

}  // namespace

std::unique_ptr<RecordingReader> open_dataset(const std::string& dir, const ReaderOptions& options) {
  return std::make_unique<DatasetReader>(dir, options);
}

std::vector<OdometrySample> read_body_truth(const std::string& dir) {
  ReadReport ignored;
  return read_all(
      CsvStream<OdometrySample>(fs::path(dir) / "truth" / "body.csv", "body", parse_pose), ignored);
}

std::vector<ObjectState> read_object_truth(const std::string& dir) {
  ReadReport ignored;
  return read_all(CsvStream<ObjectState>(fs::path(dir) / "truth" / "objects.csv", "ground truth",
                                         parse_object),
                  ignored);
}

DatasetManifest parse_dataset_manifest(std::string_view yaml_text, const std::string& name) {
  const YAML::Node root = parse_config_yaml(yaml_text, name);
  if (!root.IsMap()) throw InputError(name, "", "not a YAML mapping (needs width and height)");
  DatasetManifest m;
  for (auto [key, side] : {std::pair{"width", &m.width}, std::pair{"height", &m.height}}) {
    const std::string where = std::string("key ") + key;
    try {
      const YAML::Node node = root[key];
      if (!node) throw InputError(name, where, "missing (the event sensor size is required)");
      *side = node.as<int>();
    } catch (const YAML::Exception& e) {
      throw InputError(name, where, "not an integer: " + e.msg);
    }
    if (*side < 1 || *side > kMaxDatasetSensorSide)
      throw InputError(name, where,
                       "must be 1 to " + std::to_string(kMaxDatasetSensorSide) + " pixels");
  }
  return m;
}

std::vector<Event> read_dataset_events(std::unique_ptr<std::istream> in, const std::string& name,
                                       int width, int height, ReadReport& report) {
  EventRecords records(std::move(in), name, width, height, report);
  std::vector<Event> out;
  while (!records.done()) records.read(4096, out, report);
  return out;
}

std::vector<ImuSample> read_dataset_imu(std::unique_ptr<std::istream> in, const std::string& name,
                                        ReadReport& report) {
  return read_all(CsvStream<ImuSample>(LineReader(std::move(in), name), "imu", parse_imu), report);
}

std::vector<OdometrySample> read_dataset_poses(std::unique_ptr<std::istream> in,
                                               const std::string& name, ReadReport& report) {
  return read_all(
      CsvStream<OdometrySample>(LineReader(std::move(in), name), "odometry", parse_pose), report);
}

std::vector<ObjectState> read_dataset_objects(std::unique_ptr<std::istream> in,
                                              const std::string& name, ReadReport& report) {
  return read_all(
      CsvStream<ObjectState>(LineReader(std::move(in), name), "ground truth", parse_object),
      report);
}

std::vector<DepthIndexRow> read_dataset_depth_index(std::unique_ptr<std::istream> in,
                                                    const std::string& name, ReadReport& report) {
  return read_all(
      CsvStream<DepthIndexRow>(LineReader(std::move(in), name), "depth", parse_depth_row), report);
}

std::optional<DepthFrame> decode_dataset_depth(std::span<const std::uint8_t> bytes, TimeNs t,
                                               const std::optional<PinholeCamera>& camera,
                                               const std::string& name, ReadReport& report) {
  DepthEncoding encoding{};
  if (!sniff_depth_encoding(bytes, encoding)) {
    report.drop("depth: file is neither a PNG nor a Zstandard frame", name);
    return std::nullopt;
  }
  std::int64_t width = 0, height = 0;
  if (encoding == DepthEncoding::kPng) {
    // The IHDR chunk (PNG spec, section 11.2.2) gives the size and pixel type before anything is
    // allocated: width and height big-endian at bytes 16 and 20, bit depth at 24, colour type at
    // 25 (0 = greyscale).
    static constexpr std::uint8_t kIhdr[8] = {0, 0, 0, 13, 'I', 'H', 'D', 'R'};
    if (bytes.size() < 26 || std::memcmp(bytes.data() + 8, kIhdr, sizeof kIhdr) != 0) {
      report.drop("depth: image missing or unreadable", name);
      return std::nullopt;
    }
    const auto be32 = [&](std::size_t at) {
      return std::uint32_t{bytes[at]} << 24 | std::uint32_t{bytes[at + 1]} << 16 |
             std::uint32_t{bytes[at + 2]} << 8 | std::uint32_t{bytes[at + 3]};
    };
    width = be32(16);
    height = be32(20);
    if (bytes[24] != 16 || bytes[25] != 0) {
      report.drop("depth: image is not 16-bit single channel", name);
      return std::nullopt;
    }
  } else if (camera) {  // a Zstandard frame is as large as the depth camera's image
    width = camera->width;
    height = camera->height;
  } else {
    report.drop("depth: a Zstandard frame needs the depth camera's size (calibration.yaml)", name);
    return std::nullopt;
  }
  if (width <= 0 || height <= 0 || width * height > kMaxDepthPixels) {
    report.drop("depth: image larger than " + std::to_string(kMaxDepthPixels) + " pixels", name);
    return std::nullopt;
  }
  if (camera && (width != camera->width || height != camera->height)) {
    report.drop("depth: image size differs from the depth camera calibration", name);
    return std::nullopt;
  }
  // One buffer a thread, reused: a frame is decoded at the depth camera's rate.
  thread_local std::vector<std::uint16_t> millimetres;
  millimetres.resize(static_cast<std::size_t>(width * height));
  const std::string error =
      encoding == DepthEncoding::kPng
          ? decode_depth_png(bytes, static_cast<int>(width), static_cast<int>(height), millimetres)
          : decode_depth_zstd(bytes, millimetres);
  if (!error.empty()) {
    report.drop("depth: image missing or unreadable", name + ": " + error);
    return std::nullopt;
  }
  DepthFrame f;
  f.t = t;
  f.width = static_cast<int>(width);
  f.height = static_cast<int>(height);
  f.depth_m.resize(millimetres.size());
  millimetres_to_metres(millimetres, f.depth_m);
  return f;
}

}  // namespace fdv
