// Compiled as C++17: see ros1_bag_export.h.
#include "ros/bridge/ros1_bag_export.h"
#include "ros/bridge/ros1_export_plugin_api.h"

#include <dvs_msgs/EventArray.h>
#include <event_camera_msgs/EventPacket.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <stdexcept>

namespace fdv::ros1 {
namespace {

constexpr std::int64_t kNsPerS = 1'000'000'000;
constexpr std::int64_t kNsPerUs = 1'000;

/// ROS 1 time is uint32 seconds + nanoseconds and a bag refuses 0 (ros::TIME_MIN is 1 ns).
ros::Time ros_time(std::int64_t t_ns, const std::string& topic) {
  if (t_ns < 1 || t_ns / kNsPerS > std::numeric_limits<std::uint32_t>::max())
    throw std::out_of_range("topic " + topic + ": time " + std::to_string(t_ns) +
                            " ns is outside ROS 1 time [1 ns, 2^32 s)");
  return ros::Time(static_cast<std::uint32_t>(t_ns / kNsPerS),
                   static_cast<std::uint32_t>(t_ns % kNsPerS));
}

void append_le(std::vector<std::uint8_t>& out, std::uint64_t word) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(word >> (8 * i)));
}

bool host_is_big_endian() {
  const std::uint16_t one = 1;
  std::uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

template <class T>
void append_bytes(std::vector<std::uint8_t>& out, T value) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.insert(out.end(), bytes, bytes + sizeof(T));  // host order, declared by is_bigendian
}

/// The millimetre value a 16UC1 pixel must hold so that fdv's reader (mm * 0.001f) gives back
/// exactly `d`; -1 when there is none.
long exact_mm(float d) {
  if (d == 0.0f) return 0;
  if (!std::isfinite(d) || d < 0.0f || d > 65.535f) return -1;
  const long mm = std::lround(static_cast<double>(d) * 1000.0);
  return static_cast<float>(mm) * 0.001f == d ? mm : -1;
}

}  // namespace

namespace {

/// BagExporter's work, through rosbag::Bag.
class RosbagExport final : public BagExportBackend {
 public:
  RosbagExport(const std::string& path, const BagExportOptions& options);
  void add_events(const EventRecord* events, std::size_t n) override;
  void add_imu(const ImuRecord& imu) override;
  std::string add_depth(const DepthRecord& depth) override;
  void add_odometry(const OdometryRecord& odometry) override;
  void close() override;
  std::vector<TopicCount> topics() const override { return topic_counts; }

 private:
  BagExportOptions o;
  rosbag::Bag bag;
  std::vector<TopicCount> topic_counts;
  std::map<std::string, std::size_t> topic_index;
  std::vector<EventRecord> pending;  ///< the event message being filled
  std::int64_t last_event_ns = std::numeric_limits<std::int64_t>::min();
  std::uint64_t packets = 0;

  template <class M>
  void write(const std::string& topic, const char* type, const ros::Time& t, const M& m) {
    bag.write(topic, t, m);
    auto [it, added] = topic_index.emplace(topic, topic_counts.size());
    if (added) topic_counts.push_back({topic, type, 0});
    ++topic_counts[it->second].messages;
  }

  std_msgs::Header header(const ros::Time& t, const std::string& frame) const {
    std_msgs::Header h;
    h.stamp = t;
    h.frame_id = frame;
    return h;
  }

  void flush_events();
};

}  // namespace

RosbagExport::RosbagExport(const std::string& path, const BagExportOptions& options) : o(options) {
  if (o.events_as != "event_array" && o.events_as != "event_packet")
    throw std::invalid_argument("events as '" + o.events_as +
                                "': expected event_array or event_packet");
  if (o.packet_encoding != "mono" && o.packet_encoding != "libcaer")
    throw std::invalid_argument("EventPacket encoding '" + o.packet_encoding +
                                "': expected mono or libcaer");
  if (o.depth_encoding != "auto" && o.depth_encoding != "16UC1" && o.depth_encoding != "32FC1")
    throw std::invalid_argument("depth encoding '" + o.depth_encoding +
                                "': expected auto, 16UC1 or 32FC1");
  // mono carries 32-bit nanosecond offsets from time_base: at most 4.29 s per packet.
  if (o.event_message_ns < 1 || o.event_message_ns > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("event message span " + std::to_string(o.event_message_ns) +
                                " ns: expected 1 ns .. 4.29 s");
  try {
    bag.open(path, rosbag::bagmode::Write);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": cannot write the bag: " + e.what());
  }
}

void RosbagExport::close() {
  if (!bag.isOpen()) return;
  flush_events();
  bag.close();
}

void RosbagExport::add_events(const EventRecord* events, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    const EventRecord& e = events[i];
    if (e.t_ns < last_event_ns)
      throw std::invalid_argument("events must come in time order: " + std::to_string(e.t_ns) +
                                  " ns after " + std::to_string(last_event_ns) + " ns");
    last_event_ns = e.t_ns;
    if (!pending.empty() && e.t_ns - pending.front().t_ns >= o.event_message_ns)
      flush_events();
    pending.push_back(e);
  }
}

void RosbagExport::flush_events() {
  if (pending.empty()) return;
  const std::int64_t t0 = pending.front().t_ns;
  const ros::Time stamp = ros_time(t0, o.events_topic);
  ros_time(pending.back().t_ns, o.events_topic);  // the whole message in range
  const auto width = static_cast<std::uint32_t>(o.width);
  const auto height = static_cast<std::uint32_t>(o.height);
  if (o.events_as == "event_array") {
    dvs_msgs::EventArray m;
    m.header = header(stamp, o.events_frame);
    m.width = width;
    m.height = height;
    m.events.resize(pending.size());
    for (std::size_t i = 0; i < pending.size(); ++i) {
      m.events[i].x = pending[i].x;
      m.events[i].y = pending[i].y;
      m.events[i].ts = ros_time(pending[i].t_ns, o.events_topic);
      m.events[i].polarity = pending[i].polarity;
    }
    write(o.events_topic, "dvs_msgs/EventArray", stamp, m);
  } else {
    event_camera_msgs::EventPacket m;
    m.header = header(stamp, o.events_frame);
    m.width = width;
    m.height = height;
    m.seq = packets++;
    m.encoding = o.packet_encoding;
    m.is_bigendian = false;
    m.events.reserve(pending.size() * 8);
    if (o.packet_encoding == "mono") {
      // bit 63 polarity, 62..48 y, 47..32 x, 31..0 dt = t - time_base (ns). The header stamp is
      // the first event's time, so the reader's sensor-clock offset is 0.
      m.time_base = static_cast<std::uint64_t>(t0);
      for (const auto& e : pending) {
        if (e.y >= 1u << 15)
          throw std::invalid_argument("mono encoding: y = " + std::to_string(e.y) +
                                      " does not fit its 15 bits");
        const auto dt = static_cast<std::uint64_t>(e.t_ns - t0);
        append_le(m.events, (std::uint64_t{e.polarity} << 63) | (std::uint64_t{e.y} << 48) |
                                (std::uint64_t{e.x} << 32) | dt);
      }
    } else {
      // {uint32 data = x << 17 | y << 2 | polarity << 1 | valid, int32 ts (us)}, t = time_base +
      // ts us: time_base is the first event's time floored to the microsecond.
      const std::int64_t base = t0 - t0 % kNsPerUs;
      m.time_base = static_cast<std::uint64_t>(base);
      for (const auto& e : pending) {
        if (e.x >= 1u << 15 || e.y >= 1u << 15)
          throw std::invalid_argument("libcaer encoding: pixel (" + std::to_string(e.x) + ", " +
                                      std::to_string(e.y) + ") does not fit its 15-bit fields");
        const std::uint32_t data = (std::uint32_t{e.x} << 17) | (std::uint32_t{e.y} << 2) |
                                   (e.polarity ? 2u : 0u) | 1u;
        const auto ts = static_cast<std::uint32_t>((e.t_ns - base) / kNsPerUs);
        append_le(m.events, (std::uint64_t{ts} << 32) | data);
      }
    }
    write(o.events_topic, "event_camera_msgs/EventPacket", stamp, m);
  }
  pending.clear();
}

void RosbagExport::add_imu(const ImuRecord& r) {
  const ros::Time t = ros_time(r.t_ns, o.imu_topic);
  sensor_msgs::Imu m;
  m.header = header(t, o.imu_frame);
  m.orientation.w = 1;
  m.orientation_covariance[0] = -1;  // REP 145: no orientation estimate
  m.angular_velocity.x = r.gyro_rad_s[0];
  m.angular_velocity.y = r.gyro_rad_s[1];
  m.angular_velocity.z = r.gyro_rad_s[2];
  m.linear_acceleration.x = r.accel_m_s2[0];
  m.linear_acceleration.y = r.accel_m_s2[1];
  m.linear_acceleration.z = r.accel_m_s2[2];
  write(o.imu_topic, "sensor_msgs/Imu", t, m);
}

std::string RosbagExport::add_depth(const DepthRecord& r) {
  const ros::Time t = ros_time(r.t_ns, o.depth_topic);
  if (r.width <= 0 || r.height <= 0 || !r.depth_m)
    throw std::invalid_argument("depth frame at " + std::to_string(r.t_ns) + " ns is empty");
  const std::size_t n = static_cast<std::size_t>(r.width) * static_cast<std::size_t>(r.height);
  bool mm = o.depth_encoding == "16UC1";
  if (o.depth_encoding == "auto") {
    mm = true;
    for (std::size_t i = 0; i < n && mm; ++i) mm = exact_mm(r.depth_m[i]) >= 0;
  }
  sensor_msgs::Image m;
  m.header = header(t, o.depth_frame);
  m.width = static_cast<std::uint32_t>(r.width);
  m.height = static_cast<std::uint32_t>(r.height);
  m.is_bigendian = host_is_big_endian();
  m.encoding = mm ? "16UC1" : "32FC1";
  m.step = m.width * (mm ? 2 : 4);
  m.data.reserve(n * (mm ? 2 : 4));
  for (std::size_t i = 0; i < n; ++i) {
    const float d = r.depth_m[i];
    if (mm) {
      const double v = std::isfinite(d) && d > 0 ? std::round(static_cast<double>(d) * 1000) : 0;
      append_bytes(m.data, static_cast<std::uint16_t>(std::min(v, 65535.0)));
    } else {
      append_bytes(m.data, d);
    }
  }
  write(o.depth_topic, "sensor_msgs/Image", t, m);
  return m.encoding;
}

void RosbagExport::add_odometry(const OdometryRecord& r) {
  const ros::Time t = ros_time(r.t_ns, o.odometry_topic);
  nav_msgs::Odometry m;
  m.header = header(t, o.odometry_frame);
  m.child_frame_id = o.odometry_child_frame;
  m.pose.pose.position.x = r.p_W_B[0];
  m.pose.pose.position.y = r.p_W_B[1];
  m.pose.pose.position.z = r.p_W_B[2];
  m.pose.pose.orientation.x = r.q_W_B_xyzw[0];
  m.pose.pose.orientation.y = r.q_W_B_xyzw[1];
  m.pose.pose.orientation.z = r.q_W_B_xyzw[2];
  m.pose.pose.orientation.w = r.q_W_B_xyzw[3];
  m.twist.twist.linear.x = r.v_B[0];
  m.twist.twist.linear.y = r.v_B[1];
  m.twist.twist.linear.z = r.v_B[2];
  m.twist.twist.angular.x = r.omega_B[0];
  m.twist.twist.angular.y = r.omega_B[1];
  m.twist.twist.angular.z = r.omega_B[2];
  write(o.odometry_topic, "nav_msgs/Odometry", t, m);
}

std::unique_ptr<BagExportBackend> create_rosbag_export(const std::string& path, const BagExportOptions& options) {
  return std::make_unique<RosbagExport>(path, options);
}

}  // namespace fdv::ros1
