#include "fdv/io/rosbag/ros_messages.h"

#include <cmath>
#include <cstring>

namespace fdv::bag {
namespace {

// MD5 sums of the ROS 1 definitions, computed by the ROS 1 md5 rule from the .msg texts
// (docs/FORMATS.md, "ROS 1 bags"); tests/io/rosbag/ros1_md5_test.cpp recomputes each one and
// compares with the values Debian's generated message headers carry and the published
// dvs_msgs value (event_camera_msgs/EventPacket: the public msg_ros1 definition; tests/ros checks
// the header gencpp generates from ros/msg carries the same).
const std::vector<MessageTypeInfo> kTypes = {
    {MessageType::kDvsEventArray, "dvs_msgs/EventArray", "dvs_msgs/msg/EventArray",
     "5e8beee5a6c107e504c2e78903c224b8"},
    {MessageType::kPropheseeEventArray, "prophesee_event_msgs/EventArray",
     "prophesee_event_msgs/msg/EventArray", "5e8beee5a6c107e504c2e78903c224b8"},
    {MessageType::kEventPacket, "event_camera_msgs/EventPacket",
     "event_camera_msgs/msg/EventPacket", "8a6101b351a64529ac77bd8b71074e52"},
    {MessageType::kImu, "sensor_msgs/Imu", "sensor_msgs/msg/Imu",
     "6a62c6daae103f4ff57a132d6f95cec2"},
    {MessageType::kImage, "sensor_msgs/Image", "sensor_msgs/msg/Image",
     "060021388200f6f0f447d0fcd9c64743"},
    {MessageType::kOdometry, "nav_msgs/Odometry", "nav_msgs/msg/Odometry",
     "cd5e73d190d741a2f92e81eda573aca7"},
    {MessageType::kPoseStamped, "geometry_msgs/PoseStamped", "geometry_msgs/msg/PoseStamped",
     "d3812c3cbc69362b77dc0b19b345f8f5"},
    {MessageType::kTransformStamped, "geometry_msgs/TransformStamped",
     "geometry_msgs/msg/TransformStamped", "b5764a33bfeb3588febc2682852579b0"},
};
const MessageTypeInfo kUnsupportedInfo{MessageType::kUnsupported, "", "", ""};

template <class Cursor>
Eigen::Vector3d vector3(Cursor& c) {
  const double x = c.template get<double>();
  const double y = c.template get<double>();
  const double z = c.template get<double>();
  return {x, y, z};
}

/// geometry_msgs/Quaternion: x, y, z, w.
template <class Cursor>
Eigen::Quaterniond quaternion(Cursor& c) {
  const double x = c.template get<double>();
  const double y = c.template get<double>();
  const double z = c.template get<double>();
  const double w = c.template get<double>();
  return Eigen::Quaterniond(w, x, y, z);
}

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }
bool finite(const Eigen::Quaterniond& q) { return q.coeffs().allFinite(); }

}  // namespace

const std::vector<MessageTypeInfo>& known_message_types() { return kTypes; }

MessageType message_type(std::string_view name) {
  for (const auto& t : kTypes)
    if (name == t.ros1_name || name == t.ros2_name) return t.type;
  return MessageType::kUnsupported;
}

const MessageTypeInfo& type_info(MessageType type) {
  for (const auto& t : kTypes)
    if (t.type == type) return t;
  return kUnsupportedInfo;
}

bool can_feed(StreamKind stream, MessageType type, bool explicit_choice) {
  switch (stream) {
    case StreamKind::kEvents:
      return type == MessageType::kDvsEventArray || type == MessageType::kPropheseeEventArray ||
             type == MessageType::kEventPacket;
    case StreamKind::kImu:
      return type == MessageType::kImu;
    case StreamKind::kDepth:
      return type == MessageType::kImage;
    case StreamKind::kOdometry:
      return type == MessageType::kOdometry ||
             (explicit_choice &&
              (type == MessageType::kPoseStamped || type == MessageType::kTransformStamped));
    case StreamKind::kGroundTruth:
      return type == MessageType::kPoseStamped || type == MessageType::kTransformStamped ||
             (explicit_choice && type == MessageType::kOdometry);
  }
  return false;
}

template <class Cursor>
const char* decode_event_array(Cursor& c, EventArrayHeader& header, std::vector<Event>& out) {
  header.stamp = c.header();
  header.height = c.template get<std::uint32_t>();
  header.width = c.template get<std::uint32_t>();
  // dvs_msgs/Event: uint16 x, uint16 y, time ts, bool polarity (13 bytes packed in ROS 1).
  const std::uint32_t n = c.sequence(13);
  if (!c.ok()) return "event array: message truncated";
  const std::size_t first = out.size();
  out.resize(first + n);
  for (std::uint32_t i = 0; i < n; ++i) {
    Event& e = out[first + i];
    e.x = c.template get<std::uint16_t>();
    e.y = c.template get<std::uint16_t>();
    e.t = c.time();
    e.polarity = c.template get<std::uint8_t>() != 0;
  }
  if (!c.ok()) {
    out.resize(first);
    return "event array: message truncated";
  }
  return nullptr;
}

template <class Cursor>
const char* decode_event_packet(Cursor& c, EventPacketView& p) {
  p.stamp = c.header();
  p.height = c.template get<std::uint32_t>();
  p.width = c.template get<std::uint32_t>();
  p.seq = c.template get<std::uint64_t>();
  p.time_base = c.template get<std::uint64_t>();
  p.encoding = c.string();
  p.big_endian = c.template get<std::uint8_t>() != 0;
  const std::uint32_t n = c.sequence(1);
  p.events = c.bytes(n);
  p.events_bytes = n;
  return c.ok() ? nullptr : "event packet: message truncated";
}

template <class Cursor>
const char* decode_imu(Cursor& c, ImuSample& s) {
  s.t = c.header();
  c.skip_doubles(4 + 9);  // orientation, orientation_covariance
  s.gyro_rad_s = vector3(c);
  c.skip_doubles(9);
  s.accel_m_s2 = vector3(c);
  c.skip_doubles(9);
  if (!c.ok()) return "imu: message truncated";
  if (!finite(s.gyro_rad_s) || !finite(s.accel_m_s2)) return "imu: non-finite value";
  return nullptr;
}

template <class Cursor>
const char* decode_depth_image(Cursor& c, DepthFrame& f) {
  f.t = c.header();
  const std::uint32_t height = c.template get<std::uint32_t>();
  const std::uint32_t width = c.template get<std::uint32_t>();
  const std::string_view encoding = c.string();
  const bool big_endian = c.template get<std::uint8_t>() != 0;
  const std::uint32_t step = c.template get<std::uint32_t>();
  const std::uint32_t n = c.sequence(1);
  const std::uint8_t* data = c.bytes(n);
  if (!c.ok()) return "depth: message truncated";
  std::size_t bpp = 0;
  if (encoding == "16UC1") bpp = 2;
  if (encoding == "32FC1") bpp = 4;
  if (bpp == 0) return "depth: image encoding is neither 16UC1 nor 32FC1";
  if (width == 0 || height == 0 || width > 1u << 15 || height > 1u << 15)
    return "depth: image size out of range";
  if (step < width * bpp || static_cast<std::uint64_t>(step) * height > n)
    return "depth: image data shorter than step x height";
  f.width = static_cast<int>(width);
  f.height = static_cast<int>(height);
  f.depth_m.assign(static_cast<std::size_t>(width) * height, 0.0f);
  const bool swap = big_endian != (std::endian::native == std::endian::big);
  for (std::uint32_t v = 0; v < height; ++v) {
    const std::uint8_t* row = data + static_cast<std::size_t>(v) * step;
    float* out = f.depth_m.data() + static_cast<std::size_t>(v) * width;
    if (bpp == 2) {
      for (std::uint32_t u = 0; u < width; ++u) {
        std::uint16_t mm;
        std::memcpy(&mm, row + 2 * u, 2);
        if (swap) mm = byte_swap(mm);
        out[u] = static_cast<float>(mm) * 0.001f;
      }
    } else {
      for (std::uint32_t u = 0; u < width; ++u) {
        std::uint32_t bits;
        std::memcpy(&bits, row + 4 * u, 4);
        if (swap) bits = byte_swap(bits);
        float m;
        std::memcpy(&m, &bits, 4);
        out[u] = std::isfinite(m) && m > 0.0f ? m : 0.0f;
      }
    }
  }
  return nullptr;
}

template <class Cursor>
const char* decode_odometry(Cursor& c, OdometrySample& s) {
  s.t = c.header();
  (void)c.string();  // child_frame_id
  s.p_W_B = vector3(c);
  s.q_W_B = quaternion(c);
  c.skip_doubles(36);
  const Eigen::Vector3d v_B = vector3(c);
  s.omega_B = vector3(c);
  c.skip_doubles(36);
  if (!c.ok()) return "odometry: message truncated";
  if (!finite(s.p_W_B) || !finite(s.q_W_B) || !finite(v_B) || !finite(s.omega_B))
    return "odometry: non-finite value";
  s.v_W = s.q_W_B.normalized() * v_B;
  return nullptr;
}

template <class Cursor>
const char* decode_pose_stamped(Cursor& c, OdometrySample& s) {
  s.t = c.header();
  s.p_W_B = vector3(c);
  s.q_W_B = quaternion(c);
  s.v_W.setZero();
  s.omega_B.setZero();
  if (!c.ok()) return "pose: message truncated";
  if (!finite(s.p_W_B) || !finite(s.q_W_B)) return "pose: non-finite value";
  return nullptr;
}

template <class Cursor>
const char* decode_transform_stamped(Cursor& c, OdometrySample& s) {
  s.t = c.header();
  (void)c.string();  // child_frame_id
  s.p_W_B = vector3(c);
  s.q_W_B = quaternion(c);
  s.v_W.setZero();
  s.omega_B.setZero();
  if (!c.ok()) return "transform: message truncated";
  if (!finite(s.p_W_B) || !finite(s.q_W_B)) return "transform: non-finite value";
  return nullptr;
}

#define FDV_ROSBAG_INSTANTIATE(Cursor)                                                      \
  template const char* decode_event_array(Cursor&, EventArrayHeader&, std::vector<Event>&); \
  template const char* decode_event_packet(Cursor&, EventPacketView&);                      \
  template const char* decode_imu(Cursor&, ImuSample&);                                     \
  template const char* decode_depth_image(Cursor&, DepthFrame&);                            \
  template const char* decode_odometry(Cursor&, OdometrySample&);                           \
  template const char* decode_pose_stamped(Cursor&, OdometrySample&);                       \
  template const char* decode_transform_stamped(Cursor&, OdometrySample&);
FDV_ROSBAG_INSTANTIATE(Ros1Cursor)
FDV_ROSBAG_INSTANTIATE(CdrCursor)
#undef FDV_ROSBAG_INSTANTIATE

}  // namespace fdv::bag
