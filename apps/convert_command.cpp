// `fdv convert INPUT --to aedat4|evt3|hdf5|ros1-bag OUT [--start S] [--end S]` (alias `fdv export`):
// any recording open_recording reads (a simulated dataset folder, aedat4, RAW, HDF5, a bag, ...)
// written in a format other tools read. ROS 1 bag: events, IMU, depth and odometry on the node's
// default topics, for `rosbag play`; AEDAT 4.0: events and IMU; EVT 3.0 RAW and HDF5 (Metavision
// layout): events only.
// What the format cannot hold is left out and counted. Prints a JSON summary of what it wrote.
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>

#include "apps/commands.h"
#include "apps/reader_flags.h"
#include "fdv/core/error.h"
#include "fdv/core/time.h"
#include "fdv/io/aedat4/aedat4_writer.h"
#include "fdv/io/hdf5/hdf5_writer.h"
#include "fdv/io/prophesee/evt3_writer.h"
#include "fdv/io/recording.h"
#include "ros/bridge/ros1_bag_export.h"

namespace fdv::cli {
namespace {

struct ExportArgs {
  std::string input, to, out;
  ReaderOptions reader;
  std::optional<double> start_s, end_s;  ///< after the recording's first time
  int gzip_level = 0;
  std::string compression = "lz4";
  ros1::BagExportOptions bag;
  double event_message_ms = 1.0;
  std::optional<std::int64_t> time_offset_ns;
};

#if FDV_HAS_ROS1
/// ROS bag times must be >= 1 ns and a header stamp of 0 reads as "no stamp" (fdv's reader puts
/// the bag time in its place, the node drops it), so recordings whose clock starts at 0 (fdv's
/// simulated datasets) are moved by 1 s; recordings on an epoch clock are written as they are.
std::int64_t auto_time_offset(const SensorChunk& first) {
  TimeNs t = std::numeric_limits<TimeNs>::max();
  if (!first.events.empty()) t = std::min(t, first.events.front().t);
  if (!first.imu.empty()) t = std::min(t, first.imu.front().t);
  if (!first.depth.empty()) t = std::min(t, first.depth.front().t);
  if (!first.odometry.empty()) t = std::min(t, first.odometry.front().t);
  return t <= 0 ? kNsPerS : 0;
}

void write_chunk(const SensorChunk& c, std::int64_t offset, ros1::BagExporter& bag,
                 std::vector<ros1::EventRecord>& events, std::map<std::string, int>& depth_encodings) {
  events.resize(c.events.size());
  for (std::size_t i = 0; i < c.events.size(); ++i)
    events[i] = {c.events[i].t + offset, c.events[i].x, c.events[i].y, c.events[i].polarity};
  bag.add_events(events.data(), events.size());
  for (const auto& s : c.imu) {
    ros1::ImuRecord r;
    r.t_ns = s.t + offset;
    for (int k = 0; k < 3; ++k) {
      r.gyro_rad_s[k] = s.gyro_rad_s[k];
      r.accel_m_s2[k] = s.accel_m_s2[k];
    }
    bag.add_imu(r);
  }
  for (const auto& f : c.depth)
    ++depth_encodings[bag.add_depth({f.t + offset, f.width, f.height, f.depth_m.data()})];
  for (const auto& s : c.odometry) {
    // nav_msgs/Odometry's twist is in the child (body) frame: v_B = q_W_B^-1 v_W.
    const Eigen::Vector3d v_B = s.q_W_B.conjugate() * s.v_W;
    ros1::OdometryRecord r;
    r.t_ns = s.t + offset;
    for (int k = 0; k < 3; ++k) {
      r.p_W_B[k] = s.p_W_B[k];
      r.v_B[k] = v_B[k];
      r.omega_B[k] = s.omega_B[k];
    }
    const Eigen::Vector4d q = s.q_W_B.coeffs();  // x, y, z, w
    for (int k = 0; k < 4; ++k) r.q_W_B_xyzw[k] = q[k];
    bag.add_odometry(r);
  }
}
#endif

/// The earliest time of a chunk (max when empty).
TimeNs first_time(const SensorChunk& c) {
  TimeNs t = std::numeric_limits<TimeNs>::max();
  if (!c.events.empty()) t = std::min(t, c.events.front().t);
  if (!c.imu.empty()) t = std::min(t, c.imu.front().t);
  if (!c.depth.empty()) t = std::min(t, c.depth.front().t);
  if (!c.odometry.empty()) t = std::min(t, c.odometry.front().t);
  if (!c.ground_truth.empty()) t = std::min(t, c.ground_truth.front().t);
  return t;
}

/// Keeps the items of `c` in [begin, end) and counts the others.
class TimeWindow {
 public:
  TimeWindow(const ExportArgs& a, TimeNs t0)
      : begin_(a.start_s ? after(t0, *a.start_s) : std::numeric_limits<TimeNs>::min()),
        end_(a.end_s ? after(t0, *a.end_s) : std::numeric_limits<TimeNs>::max()) {}
  void apply(SensorChunk& c) {
    cut(c.events);
    cut(c.imu);
    cut(c.depth);
    cut(c.odometry);
    cut(c.ground_truth);
  }
  std::uint64_t outside() const { return outside_; }

 private:
  static TimeNs after(TimeNs t0, double s) {
    return checked_add(t0, from_seconds(s)).value_or(std::numeric_limits<TimeNs>::max());
  }
  template <typename T>
  void cut(std::vector<T>& v) {
    const auto n = v.size();
    std::erase_if(v, [&](const T& x) { return x.t < begin_ || x.t >= end_; });
    outside_ += n - v.size();
  }
  TimeNs begin_, end_;
  std::uint64_t outside_ = 0;
};

void check_window(const ExportArgs& a) {
  constexpr double kMaxS = 1e9;  // ~31 years: from_seconds stays in int64 ns
  if ((a.start_s && !(*a.start_s >= 0 && *a.start_s < kMaxS)) || (a.end_s && !(*a.end_s > 0 && *a.end_s < kMaxS)) ||
      (a.start_s && a.end_s && !(*a.end_s > *a.start_s)))
    throw ConfigError("--start/--end: expected 0 <= start < end seconds after the recording's first time");
}

/// Formats of events, and of IMU samples when the writer takes them (AEDAT 4.0): everything else
/// is counted as not written.
template <typename Writer>
void convert_events(ExportArgs& a, RecordingReader& reader, Writer& writer, nlohmann::json& out) {
  SensorChunk chunk;
  bool more = reader.read(chunk);
  TimeWindow window(a, first_time(chunk));
  std::map<std::string, std::uint64_t> left_out;
  while (more) {
    window.apply(chunk);
    writer.add(chunk.events);
    if constexpr (requires { writer.add(std::span<const ImuSample>(chunk.imu)); })
      writer.add(std::span<const ImuSample>(chunk.imu));
    else
      left_out["imu"] += chunk.imu.size();
    left_out["depth"] += chunk.depth.size();
    left_out["odometry"] += chunk.odometry.size();
    left_out["ground_truth"] += chunk.ground_truth.size();
    more = reader.read(chunk);
  }
  writer.close();
  out["events"] = writer.events();
  if constexpr (requires { writer.imu_samples(); }) {
    out["imu"] = writer.imu_samples();
    out["times_floored_to_us"] = writer.floored_times();
  } else {
    out["times_floored_to_us"] = writer.floored_events();
  }
  out["not_written"] = left_out;
  out["outside_start_end"] = window.outside();
}

std::pair<int, int> sensor_size(const ExportArgs& a, const RecordingReader& reader) {
  const int w = reader.info().width, h = reader.info().height;
  if (w <= 0 || h <= 0)
    throw InputError(a.input, "", "the recording does not give the sensor size, which " + a.to +
                                      " must hold: pass --resolution WxH");
  return {w, h};
}

void run_ros1_bag(ExportArgs& a);

void run_convert(ExportArgs& a) {
  check_window(a);
  if (a.to == "ros1-bag") return run_ros1_bag(a);
  auto reader = open_recording(a.input, a.reader);
  const auto [w, h] = sensor_size(a, *reader);
  nlohmann::json out = {{"input", a.input}, {"output", a.out}, {"format", a.to}};
  if (a.to == "aedat4") {
    const Aedat4Compression c = a.compression == "none"   ? Aedat4Compression::kNone
                                : a.compression == "zstd" ? Aedat4Compression::kZstd
                                                          : Aedat4Compression::kLz4;
    Aedat4Writer writer(a.out, w, h, c);
    convert_events(a, *reader, writer, out);
  } else if (a.to == "evt3") {
    Evt3Writer writer(a.out, w, h);
    convert_events(a, *reader, writer, out);
  } else {
    Hdf5EventWriter writer(a.out, w, h, {.gzip_level = a.gzip_level, .chunk_rows = 16384});
    convert_events(a, *reader, writer, out);
  }
  out["read_report"] = reader->report().to_json();
  std::cout << out.dump(2) << std::endl;
}

void run_ros1_bag(ExportArgs& a) {
#if FDV_HAS_ROS1
  if (a.event_message_ms <= 0 || a.event_message_ms > 4294)
    throw ConfigError("--event-message-ms " + std::to_string(a.event_message_ms) +
                      ": expected > 0 and at most 4294 (EventPacket mono's 32-bit ns offsets)");
  a.bag.event_message_ns = static_cast<std::int64_t>(a.event_message_ms * 1e6);
  auto reader = open_recording(a.input, a.reader);
  a.bag.width = reader->info().width;
  a.bag.height = reader->info().height;
  SensorChunk chunk;
  bool more = reader->read(chunk);
  TimeWindow window(a, first_time(chunk));
  const std::int64_t offset = a.time_offset_ns ? *a.time_offset_ns : auto_time_offset(chunk);
  std::map<std::string, int> depth_encodings;
  std::uint64_t events = 0, ground_truth = 0;
  std::vector<ros1::TopicCount> topics;
  try {
    ros1::BagExporter bag(a.out, a.bag);
    std::vector<ros1::EventRecord> buffer;
    while (more) {
      window.apply(chunk);
      events += chunk.events.size();
      ground_truth += chunk.ground_truth.size();
      write_chunk(chunk, offset, bag, buffer, depth_encodings);
      more = reader->read(chunk);
    }
    bag.close();
    topics = bag.topics();
  } catch (const std::out_of_range& e) {
    throw ConfigError(std::string(e.what()) + "; move the times with --time-offset-ns");
  } catch (const std::invalid_argument& e) {
    throw ConfigError(e.what());
  }
  nlohmann::json out = {{"input", a.input},
                        {"output", a.out},
                        {"format", a.to},
                        {"bag", a.out},
                        {"time_offset_ns", offset},
                        {"events", events},
                        {"depth_encodings", depth_encodings},
                        {"not_exported", {{"ground_truth", ground_truth}}},
                        {"not_written", {{"ground_truth", ground_truth}}},
                        {"outside_start_end", window.outside()},
                        {"read_report", reader->report().to_json()}};
  out["topics"] = nlohmann::json::array();
  for (const auto& t : topics)
    out["topics"].push_back({{"topic", t.topic}, {"type", t.type}, {"messages", t.messages}});
  std::cout << out.dump(2) << std::endl;
#else
  (void)a;
  throw ConfigError(
      "this fdv was built without ROS 1 (FDV_ROS1 off: cmake/fdv_ros1.cmake says why when "
      "configuring; scripts/setup.sh installs the ROS packages), so it cannot write ROS 1 bags");
#endif
}

}  // namespace

void add_convert_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "convert", "write a recording (dataset folder, aedat4, RAW, HDF5, bag, ...) as AEDAT 4.0, EVT 3.0 RAW, HDF5 or "
      "a ROS 1 bag");
  cmd->alias("export");
  static ExportArgs a;
  cmd->add_option("input", a.input, "recording file or dataset folder")->required();
  cmd->add_option("--to", a.to, "output format: aedat4 (events, IMU), evt3 (events), hdf5 (events, Metavision "
                                "layout), ros1-bag (events, IMU, depth, odometry)")
      ->required()
      ->check(CLI::IsMember({"aedat4", "evt3", "hdf5", "ros1-bag"}));
  cmd->add_option("output", a.out, "file to write")->required();
  cmd->add_option("--start", a.start_s, "seconds after the recording's first time: write from here");
  cmd->add_option("--end", a.end_s, "seconds after the recording's first time: write up to here");
  cmd->add_option("--gzip", a.gzip_level, "hdf5: gzip level 1..9 (0: uncompressed)")
      ->check(CLI::Range(0, 9))
      ->capture_default_str();
  cmd->add_option("--compression", a.compression, "aedat4: packet compression (DV records LZ4)")
      ->check(CLI::IsMember({"lz4", "zstd", "none"}))
      ->capture_default_str();
  cmd->add_option("--events-as", a.bag.events_as,
                  "event message: event_array (dvs_msgs/EventArray) or event_packet "
                  "(event_camera_msgs/EventPacket)")
      ->check(CLI::IsMember({"event_array", "event_packet"}))
      ->capture_default_str();
  cmd->add_option("--encoding", a.bag.packet_encoding,
                  "EventPacket encoding: mono (exact ns) or libcaer (times floored to the us)")
      ->check(CLI::IsMember({"mono", "libcaer"}))
      ->capture_default_str();
  cmd->add_option("--event-message-ms", a.event_message_ms,
                  "event time per event message, from its first event")
      ->capture_default_str();
  cmd->add_option("--depth-encoding", a.bag.depth_encoding,
                  "auto: 16UC1 (mm) when every pixel is a whole mm, else 32FC1 (m)")
      ->check(CLI::IsMember({"auto", "16UC1", "32FC1"}))
      ->capture_default_str();
  cmd->add_option("--time-offset-ns", a.time_offset_ns,
                  "added to every time (default: 1 s when the recording's clock starts at 0, "
                  "else 0; ROS times must be >= 1 ns)");
  cmd->add_option("--events-out-topic", a.bag.events_topic)->capture_default_str();
  cmd->add_option("--imu-out-topic", a.bag.imu_topic)->capture_default_str();
  cmd->add_option("--depth-out-topic", a.bag.depth_topic)->capture_default_str();
  cmd->add_option("--odometry-out-topic", a.bag.odometry_topic)->capture_default_str();
  add_reader_flags(cmd, a.reader);
  cmd->callback([] { run_convert(a); });
}

}  // namespace fdv::cli
