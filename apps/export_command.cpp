// `fdv export DATASET --to ros1-bag OUT.bag`: any recording open_recording reads (a simulated
// dataset folder, aedat4, a bag, ...) written as a ROS 1 bag with the node's default topics, so
// that a ROS stack can replay it (`rosbag play`). Prints a JSON summary of what it wrote.
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>

#include "apps/commands.h"
#include "apps/reader_flags.h"
#include "fdv/core/error.h"
#include "fdv/io/recording.h"
#include "ros/bridge/ros1_bag_export.h"

namespace fdv::cli {
namespace {

struct ExportArgs {
  std::string input, to, out;
  ReaderOptions reader;
  ros1::BagExportOptions bag;
  double event_message_ms = 1.0;
  std::optional<std::int64_t> time_offset_ns;
};

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

#if FDV_HAS_ROS1
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

void run_export(ExportArgs& a) {
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
  const std::int64_t offset = a.time_offset_ns ? *a.time_offset_ns : auto_time_offset(chunk);
  std::map<std::string, int> depth_encodings;
  std::uint64_t events = 0, ground_truth = 0;
  std::vector<ros1::TopicCount> topics;
  try {
    ros1::BagExporter bag(a.out, a.bag);
    std::vector<ros1::EventRecord> buffer;
    while (more) {
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
                        {"bag", a.out},
                        {"time_offset_ns", offset},
                        {"events", events},
                        {"depth_encodings", depth_encodings},
                        {"not_exported", {{"ground_truth", ground_truth}}},
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

void add_export_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "export", "write a recording (dataset folder, aedat4, bag, ...) as a ROS 1 bag for replay");
  static ExportArgs a;
  cmd->add_option("input", a.input, "recording file or dataset folder")->required();
  cmd->add_option("--to", a.to, "output format")->required()->check(CLI::IsMember({"ros1-bag"}));
  cmd->add_option("output", a.out, "bag file to write")->required();
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
  cmd->callback([] { run_export(a); });
}

}  // namespace fdv::cli
