#include "fdv/io/rpg/rpg_text_reader.h"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/table_stream.h"
#include "fdv/io/text_fields.h"

namespace fdv {
namespace fs = std::filesystem;
namespace {

/// True when `s` is a number that is NaN or infinite ("nan", "inf", "-Infinity", ...).
bool is_non_finite(std::string_view s) {
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && ptr == s.data() + s.size() && !std::isfinite(v);
}

const char* number_problem(std::string_view s) {
  return is_non_finite(s) ? "non-finite value" : "malformed number";
}
const char* time_problem(std::string_view s) {
  return is_non_finite(s) ? "non-finite value" : "malformed timestamp";
}

/// "t v1 .. v(n-1)": t in decimal seconds, the rest finite numbers.
std::string parse_row(const std::vector<std::string_view>& f, std::size_t n, TimeNs& t,
                      double* values) {
  if (f.size() != n) return "expected " + std::to_string(n) + " columns";
  if (!parse_seconds_to_ns(f[0], t)) return time_problem(f[0]);
  for (std::size_t i = 1; i < n; ++i)
    if (!parse_double(f[i], values[i - 1])) return number_problem(f[i]);
  return {};
}

/// imu.txt: t ax ay az gx gy gz (accelerometer first; dataset web page / paper Table 1).
std::string parse_rpg_imu(const std::vector<std::string_view>& f, ImuSample& s) {
  double v[6];
  if (auto why = parse_row(f, 7, s.t, v); !why.empty()) return why;
  s.accel_m_s2 = {v[0], v[1], v[2]};
  s.gyro_rad_s = {v[3], v[4], v[5]};
  return {};
}

/// groundtruth.txt: t px py pz qx qy qz qw, the camera's pose in the motion-capture frame.
std::string parse_groundtruth(const std::vector<std::string_view>& f, OdometrySample& s) {
  double v[7];
  if (auto why = parse_row(f, 8, s.t, v); !why.empty()) return why;
  s.p_W_B = {v[0], v[1], v[2]};
  s.q_W_B = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);
  if (std::abs(s.q_W_B.norm() - 1.0) > kUnitQuaternionTolerance) return "quaternion is not unit length";
  s.q_W_B.normalize();
  s.v_W.setZero();
  s.omega_B.setZero();
  return {};
}

/// events.txt: t x y p. Returns nullptr when valid, else the reason.
const char* parse_event(const std::vector<std::string_view>& f, Event& e) {
  if (f.size() != 4) return "expected 4 columns (t x y p)";
  if (!parse_seconds_to_ns(f[0], e.t)) return time_problem(f[0]);
  std::int64_t x = 0, y = 0, p = 0;
  if (!parse_int64(f[1], x) || !parse_int64(f[2], y) || x < 0 || y < 0 || x > 0xFFFF || y > 0xFFFF)
    return is_non_finite(f[1]) || is_non_finite(f[2]) ? "non-finite value"
                                                      : "malformed pixel coordinate";
  if (!parse_int64(f[3], p) || (p != 0 && p != 1)) return "bad polarity (expected 0 or 1)";
  e.x = static_cast<std::uint16_t>(x);
  e.y = static_cast<std::uint16_t>(y);
  e.polarity = p == 1;
  return nullptr;
}

/// calib.txt: one line "fx fy cx cy [k1 k2 p1 p2 [k3]]".
Calibration read_calib(LineReader& lines) {
  const std::string& path = lines.path();
  std::string_view line;
  if (!lines.next(line)) throw InputError(path, "line 1", "empty calibration file");
  std::vector<std::string_view> f;
  split_fields(line, ' ', f);
  if (f.size() != 4 && f.size() != 8 && f.size() != 9)
    throw InputError(path, lines.where(),
                     "expected fx fy cx cy [k1 k2 p1 p2 [k3]] (4, 8 or 9 numbers), got " +
                         std::to_string(f.size()));
  double v[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < f.size(); ++i)
    if (!parse_double(f[i], v[i]))
      throw InputError(path, lines.where(),
                       std::string(number_problem(f[i])) + " in column " + std::to_string(i + 1));
  const std::string first_where = lines.where();
  if (lines.next(line))
    throw InputError(path, lines.where(), "expected a single line of numbers");
  Calibration c;
  c.event_camera = {kRpgWidth, kRpgHeight, v[0], v[1], v[2], v[3], {v[4], v[5], v[6], v[7], v[8]}};
  if (const std::string why = c.event_camera.validate(); !why.empty())
    throw InputError(path, first_where,
                     "camera does not fit the dataset's 240x180 sensor: " + why);
  return c;
}

/// events.txt, parsed and sanitised a bounded number of lines at a time.
class EventLines {
 public:
  explicit EventLines(LineReader lines) : lines_(std::move(lines)), sanitizer_(kRpgWidth, kRpgHeight) {}

  /// Parses up to max_lines good lines and appends the valid events to `out`; false once the
  /// text is exhausted.
  bool read(std::size_t max_lines, std::vector<Event>& out, ReadReport& report) {
    raw_.clear();
    line_of_.clear();
    std::string_view line;
    bool more = true;
    while (raw_.size() < max_lines) {
      if (!lines_.next(line)) {
        more = false;
        break;
      }
      split_fields(line, ' ', fields_);
      Event e;
      if (const char* why = parse_event(fields_, e)) {
        report.drop(std::string("events: ") + why, lines_.path() + ":" + lines_.where());
      } else {
        raw_.push_back(e);
        line_of_.push_back(lines_.line_number());
      }
    }
    if (!raw_.empty())
      sanitizer_.append(raw_.data(), raw_.data() + raw_.size(), out, report,
                        [&](std::size_t i) { return lines_.path() + ":line " + std::to_string(line_of_[i]); });
    return more;
  }

 private:
  LineReader lines_;
  EventSanitizer sanitizer_;
  std::vector<std::string_view> fields_;
  std::vector<Event> raw_;
  std::vector<std::uint64_t> line_of_;  ///< the line of each event in raw_
};

template <typename T>
std::vector<T> read_table(TableStream<T>&& stream, ReadReport& report) {
  std::vector<T> out;
  stream.take_until(std::numeric_limits<TimeNs>::max(), std::numeric_limits<std::size_t>::max(),
                    out, report);
  return out;
}

class RpgTextReader final : public RecordingReader {
 public:
  RpgTextReader(const std::string& dir, const ReaderOptions& options)
      : chunk_events_(std::max<std::size_t>(1, options.chunk_events)),
        events_(LineReader((fs::path(dir) / kRpgEventsFile).string())),
        imu_(fs::path(dir) / "imu.txt", "imu", parse_rpg_imu, ' '),
        groundtruth_(fs::path(dir) / "groundtruth.txt", "groundtruth", parse_groundtruth, ' ') {
    info_.path = dir;
    info_.format = "rpg_text";
    info_.width = kRpgWidth;
    info_.height = kRpgHeight;
    info_.streams.push_back(StreamKind::kEvents);
    info_.notes.push_back(
        "sensor size 240x180: the DAVIS240C of the dataset (the text layout does not state it)");
    if (imu_.present()) {
      info_.streams.push_back(StreamKind::kImu);
      info_.notes.push_back(
          "imu.txt: accelerometer [m/s^2] then gyroscope [rad/s]; the IMU-to-camera rotation is "
          "not given (R_B_I = identity)");
    }
    if (groundtruth_.present()) {
      info_.streams.push_back(StreamKind::kOdometry);
      info_.notes.push_back(
          "odometry = groundtruth.txt, the motion-capture pose of the event camera (T_W_B with "
          "B = E); velocity and angular velocity are not given (zero)");
    }
    std::error_code ec;
    if (const auto calib = fs::path(dir) / "calib.txt"; fs::exists(calib, ec) || ec) {
      LineReader lines(calib.string());
      info_.calibration = read_calib(lines);
      info_.notes.push_back(
          "calibration from calib.txt (fx fy cx cy k1 k2 p1 p2 k3); extrinsics identity");
    }
  }

  const RecordingInfo& info() const override { return info_; }
  const ReadReport& report() const override { return report_; }

  bool read(SensorChunk& chunk) override {
    chunk.clear();
    while (chunk.events.empty() && !events_done_)
      events_done_ = !events_.read(chunk_events_, chunk.events, report_);
    // The other streams follow the events: everything up to the last event handed out, or,
    // once the events are exhausted, the rest in bounded pieces.
    const TimeNs horizon =
        events_done_ ? std::numeric_limits<TimeNs>::max() : chunk.events.back().t;
    const std::size_t cap = events_done_ ? 4096 : kMaxTableRowsPerChunk;
    imu_.take_until(horizon, cap, chunk.imu, report_);
    groundtruth_.take_until(horizon, cap, chunk.odometry, report_);
    return !chunk.empty() ||
           !(events_done_ && imu_.exhausted(report_) && groundtruth_.exhausted(report_));
  }

 private:
  std::size_t chunk_events_;
  RecordingInfo info_;
  ReadReport report_;
  EventLines events_;
  TableStream<ImuSample> imu_;
  TableStream<OdometrySample> groundtruth_;
  bool events_done_ = false;
};

}  // namespace

std::unique_ptr<RecordingReader> open_rpg_text(const std::string& dir,
                                               const ReaderOptions& options) {
  return std::make_unique<RpgTextReader>(dir, options);
}

std::vector<Event> read_rpg_events(std::unique_ptr<std::istream> in, const std::string& name,
                                   ReadReport& report) {
  EventLines lines(LineReader(std::move(in), name));
  std::vector<Event> out;
  while (lines.read(4096, out, report)) {
  }
  return out;
}

std::vector<ImuSample> read_rpg_imu(std::unique_ptr<std::istream> in, const std::string& name,
                                    ReadReport& report) {
  return read_table(TableStream<ImuSample>(LineReader(std::move(in), name), "imu", parse_rpg_imu, ' '),
                  report);
}

std::vector<OdometrySample> read_rpg_groundtruth(std::unique_ptr<std::istream> in,
                                                 const std::string& name, ReadReport& report) {
  return read_table(TableStream<OdometrySample>(LineReader(std::move(in), name), "groundtruth",
                                              parse_groundtruth, ' '),
                  report);
}

Calibration read_rpg_calib(std::unique_ptr<std::istream> in, const std::string& name) {
  LineReader lines(std::move(in), name);
  return read_calib(lines);
}

}  // namespace fdv
