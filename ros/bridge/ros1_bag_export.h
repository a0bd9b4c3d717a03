#pragma once
/// Writes sensor records as a ROS 1 bag with the node's default topics, through ROS's own
/// rosbag library: what `fdv export --to ros1-bag` calls (apps/convert_command.cpp). The writing
/// happens in the plugin libfdv_ros1_export.so (fdv/io/format_plugin.h), loaded by the first
/// BagExporter: a program that never writes a bag does not load ROS's libraries.
///
///   fdv::ros1::BagExportOptions o;            // /dvs/events as dvs_msgs/EventArray, 1 ms each
///   fdv::ros1::BagExporter bag("out.bag", o);
///   bag.add_events(events.data(), events.size());   // in time order, any batch size
///   bag.add_imu(imu);  bag.add_depth(depth);  bag.add_odometry(odom);
///   bag.close();                              // flushes the last event message
///   for (const auto& t : bag.topics()) ...    // messages written per topic
///
/// Every time is the caller's nanoseconds, written as ROS time (uint32 s + uint32 ns), so it must
/// lie in [1 ns, 2^32 s) (ROS bags reject a time of 0); the header stamp and the bag time of a
/// message are the same. This header includes nothing of ROS or fdv: the implementation is
/// compiled as C++17 (Debian's generated ROS headers do not compile as C++20) and this header is
/// included by the C++20 command line.
/// Thread safety: the functions share no state; one bag is written by one thread.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace fdv::ros1 {

struct EventRecord {
  std::int64_t t_ns = 0;
  std::uint16_t x = 0;
  std::uint16_t y = 0;
  bool polarity = false;
};

struct ImuRecord {
  std::int64_t t_ns = 0;
  double gyro_rad_s[3] = {0, 0, 0};
  double accel_m_s2[3] = {0, 0, 0};
};

/// Row-major z-depth in metres, 0 = invalid (fdv's DepthFrame).
struct DepthRecord {
  std::int64_t t_ns = 0;
  int width = 0;
  int height = 0;
  const float* depth_m = nullptr;
};

/// Pose of the body B in the world W and the twist in B, as nav_msgs/Odometry carries it.
struct OdometryRecord {
  std::int64_t t_ns = 0;
  double p_W_B[3] = {0, 0, 0};
  double q_W_B_xyzw[4] = {0, 0, 0, 1};
  double v_B[3] = {0, 0, 0};
  double omega_B[3] = {0, 0, 0};
};

struct BagExportOptions {
  std::string events_topic = "/dvs/events";
  std::string imu_topic = "/mavros/imu/data";
  std::string depth_topic = "/camera/depth/image_rect_raw";
  std::string odometry_topic = "/mavros/local_position/odom";
  /// "event_array" (dvs_msgs/EventArray) or "event_packet" (event_camera_msgs/EventPacket).
  std::string events_as = "event_array";
  /// EventPacket encoding, as fdv's reader decodes it (fdv/io/rosbag/event_packet_decoder.h):
  /// "mono" (ns offsets from time_base: exact) or "libcaer" (microsecond ticks: times are floored
  /// to the microsecond).
  std::string packet_encoding = "mono";
  /// One event message per this much event time, from its first event's time.
  std::int64_t event_message_ns = 1'000'000;
  /// "auto": 16UC1 (mm) when every pixel is a whole millimetre (fdv's 16-bit PNG datasets), else
  /// 32FC1 (m); or "16UC1" (rounded to the mm) / "32FC1".
  std::string depth_encoding = "auto";
  int width = 0;  ///< event sensor size written into the event messages
  int height = 0;
  std::string events_frame = "event_camera";
  std::string imu_frame = "imu";
  std::string depth_frame = "depth_camera";
  std::string odometry_frame = "world";
  std::string odometry_child_frame = "body";
};

struct TopicCount {
  std::string topic;
  std::string type;
  std::uint64_t messages = 0;
};

class BagExporter {
 public:
  /// Opens `path` for writing; throws std::runtime_error naming the path when it cannot,
  /// std::invalid_argument for options out of range, fdv::InputError when the plugin is missing.
  BagExporter(const std::string& path, const BagExportOptions& options);
  ~BagExporter();
  BagExporter(const BagExporter&) = delete;
  BagExporter& operator=(const BagExporter&) = delete;

  /// Events in non-decreasing time across calls.
  void add_events(const EventRecord* events, std::size_t n);
  void add_imu(const ImuRecord& imu);
  /// Returns the encoding written ("16UC1" or "32FC1").
  std::string add_depth(const DepthRecord& depth);
  void add_odometry(const OdometryRecord& odometry);
  /// Writes the pending event message and closes the bag (also done by the destructor).
  void close();

  /// Messages written so far per topic, in the order the topics were first written.
  std::vector<TopicCount> topics() const;

 private:
  std::unique_ptr<class BagExportBackend> backend_;  // in the plugin libfdv_ros1_export.so
};

}  // namespace fdv::ros1
