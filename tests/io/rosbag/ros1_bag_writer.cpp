// Compiled as C++17: see ros1_bag_writer.h.
#include "ros1_bag_writer.h"

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <std_msgs/Header.h>

#include <cstring>
#include <stdexcept>

namespace fdv_test_msgs {

// dvs_msgs/Event and dvs_msgs/EventArray as ROS would generate them, with the type name and
// MD5 sum carried per message so that tests can write mislabelled bags.
struct Event {
  std::uint16_t x = 0;
  std::uint16_t y = 0;
  ros::Time ts;
  std::uint8_t polarity = 0;
};

struct EventArray {
  std_msgs::Header header;
  std::uint32_t height = 0;
  std::uint32_t width = 0;
  std::vector<Event> events;
  std::string type, md5;
};

// event_camera_msgs/EventPacket (ROS 1 branch of ros-event-camera/event_camera_msgs).
struct EventPacket {
  std_msgs::Header header;
  std::uint32_t height = 0;
  std::uint32_t width = 0;
  std::uint64_t seq = 0;
  std::uint64_t time_base = 0;
  std::string encoding;
  std::uint8_t is_bigendian = 0;
  std::vector<std::uint8_t> events;
};

/// Already serialized bytes under a given type name.
struct RawBytes {
  std::vector<std::uint8_t> bytes;
  std::string type, md5;
};

const char* kEventArrayDefinition =
    "Header header\nuint32 height\nuint32 width\nEvent[] events\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n"
    "================================================================================\n"
    "MSG: dvs_msgs/Event\nuint16 x\nuint16 y\ntime ts\nbool polarity\n";

const char* kEventPacketDefinition =
    "Header header\nuint32 height\nuint32 width\nuint64 seq\nuint64 time_base\n"
    "string encoding\nbool is_bigendian\nuint8[] events\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n";

}  // namespace fdv_test_msgs

namespace ros {
namespace message_traits {
#define FDV_RUNTIME_TRAITS(M, DEFINITION)                           \
  template <>                                                       \
  struct MD5Sum<M> {                                                \
    static const char* value() { return "*"; }                      \
    static const char* value(const M& m) { return m.md5.c_str(); }  \
  };                                                                \
  template <>                                                       \
  struct DataType<M> {                                              \
    static const char* value() { return "*"; }                      \
    static const char* value(const M& m) { return m.type.c_str(); } \
  };                                                                \
  template <>                                                       \
  struct Definition<M> {                                            \
    static const char* value() { return DEFINITION; }               \
    static const char* value(const M&) { return DEFINITION; }       \
  };
FDV_RUNTIME_TRAITS(fdv_test_msgs::EventArray, fdv_test_msgs::kEventArrayDefinition)
FDV_RUNTIME_TRAITS(fdv_test_msgs::RawBytes, "")
#undef FDV_RUNTIME_TRAITS
template <>
struct MD5Sum<fdv_test_msgs::EventPacket> {
  static const char* value() { return fdv::test::ros1::kEventPacketMd5; }
  static const char* value(const fdv_test_msgs::EventPacket&) { return value(); }
};
template <>
struct DataType<fdv_test_msgs::EventPacket> {
  static const char* value() { return "event_camera_msgs/EventPacket"; }
  static const char* value(const fdv_test_msgs::EventPacket&) { return value(); }
};
template <>
struct Definition<fdv_test_msgs::EventPacket> {
  static const char* value() { return fdv_test_msgs::kEventPacketDefinition; }
  static const char* value(const fdv_test_msgs::EventPacket&) { return value(); }
};
}  // namespace message_traits

namespace serialization {
template <>
struct Serializer<fdv_test_msgs::Event> {
  template <typename Stream, typename T>
  inline static void allInOne(Stream& stream, T m) {
    stream.next(m.x);
    stream.next(m.y);
    stream.next(m.ts);
    stream.next(m.polarity);
  }
  ROS_DECLARE_ALLINONE_SERIALIZER
};

template <>
struct Serializer<fdv_test_msgs::EventArray> {
  template <typename Stream, typename T>
  inline static void allInOne(Stream& stream, T m) {
    stream.next(m.header);
    stream.next(m.height);
    stream.next(m.width);
    stream.next(m.events);
  }
  ROS_DECLARE_ALLINONE_SERIALIZER
};

template <>
struct Serializer<fdv_test_msgs::EventPacket> {
  template <typename Stream, typename T>
  inline static void allInOne(Stream& stream, T m) {
    stream.next(m.header);
    stream.next(m.height);
    stream.next(m.width);
    stream.next(m.seq);
    stream.next(m.time_base);
    stream.next(m.encoding);
    stream.next(m.is_bigendian);
    stream.next(m.events);
  }
  ROS_DECLARE_ALLINONE_SERIALIZER
};

template <>
struct Serializer<fdv_test_msgs::RawBytes> {
  template <typename Stream>
  inline static void write(Stream& stream, const fdv_test_msgs::RawBytes& m) {
    if (!m.bytes.empty())
      std::memcpy(stream.advance(static_cast<std::uint32_t>(m.bytes.size())), m.bytes.data(),
                  m.bytes.size());
  }
  inline static std::uint32_t serializedLength(const fdv_test_msgs::RawBytes& m) {
    return static_cast<std::uint32_t>(m.bytes.size());
  }
};
}  // namespace serialization
}  // namespace ros

namespace fdv::test::ros1 {
namespace {

ros::Time to_ros(Stamp s) { return ros::Time(s.sec, s.nsec); }

std_msgs::Header header(Stamp s) {
  std_msgs::Header h;
  h.stamp = to_ros(s);
  h.frame_id = "test";
  return h;
}

geometry_msgs::Pose pose_msg(const Pose& p) {
  geometry_msgs::Pose m;
  m.position.x = p.p[0];
  m.position.y = p.p[1];
  m.position.z = p.p[2];
  m.orientation.x = p.q[0];
  m.orientation.y = p.q[1];
  m.orientation.z = p.q[2];
  m.orientation.w = p.q[3];
  return m;
}

}  // namespace

struct BagWriter::Impl {
  rosbag::Bag bag;
  std::uint64_t packets = 0;
};

BagWriter::BagWriter(const std::string& path, Compression compression) : impl_(new Impl) {
  impl_->bag.open(path, rosbag::bagmode::Write);
  impl_->bag.setChunkThreshold(2048);  // several chunks even in small test bags
  if (compression == Compression::kLz4) impl_->bag.setCompression(rosbag::compression::LZ4);
  if (compression == Compression::kBz2) impl_->bag.setCompression(rosbag::compression::BZ2);
}

BagWriter::~BagWriter() { close(); }

void BagWriter::close() {
  if (impl_->bag.isOpen()) impl_->bag.close();
}

void BagWriter::event_array(const std::string& topic, Stamp bag_time, Stamp h, std::uint32_t width,
                            std::uint32_t height, const std::vector<RawEvent>& events,
                            const std::string& type, const std::string& md5) {
  fdv_test_msgs::EventArray m;
  m.header = header(h);
  m.width = width;
  m.height = height;
  for (const auto& e : events) {
    fdv_test_msgs::Event out;
    out.x = e.x;
    out.y = e.y;
    out.ts = to_ros(e.ts);
    out.polarity = e.polarity ? 1 : 0;
    m.events.push_back(out);
  }
  m.type = type;
  m.md5 = md5;
  impl_->bag.write(topic, to_ros(bag_time), m);
}

void BagWriter::event_packet(const std::string& topic, Stamp bag_time, Stamp h,
                             std::uint32_t width, std::uint32_t height, std::uint64_t time_base,
                             const std::string& encoding, const std::vector<std::uint8_t>& events) {
  fdv_test_msgs::EventPacket m;
  m.header = header(h);
  m.width = width;
  m.height = height;
  m.seq = ++impl_->packets;
  m.time_base = time_base;
  m.encoding = encoding;
  m.events = events;
  impl_->bag.write(topic, to_ros(bag_time), m);
}

void BagWriter::imu(const std::string& topic, Stamp bag_time, Stamp h, std::array<double, 3> gyro,
                    std::array<double, 3> accel) {
  sensor_msgs::Imu m;
  m.header = header(h);
  m.orientation.w = 1;
  m.orientation_covariance[0] = -1;
  m.angular_velocity.x = gyro[0];
  m.angular_velocity.y = gyro[1];
  m.angular_velocity.z = gyro[2];
  m.linear_acceleration.x = accel[0];
  m.linear_acceleration.y = accel[1];
  m.linear_acceleration.z = accel[2];
  for (auto& c : m.angular_velocity_covariance) c = 0.5;  // must not leak into the values
  impl_->bag.write(topic, to_ros(bag_time), m);
}

void BagWriter::image(const std::string& topic, Stamp bag_time, Stamp h, std::uint32_t width,
                      std::uint32_t height, const std::string& encoding, std::uint32_t step,
                      const std::vector<std::uint8_t>& data) {
  sensor_msgs::Image m;
  m.header = header(h);
  m.width = width;
  m.height = height;
  m.encoding = encoding;
  m.is_bigendian = 0;
  m.step = step;
  m.data = data;
  impl_->bag.write(topic, to_ros(bag_time), m);
}

void BagWriter::odometry(const std::string& topic, Stamp bag_time, Stamp h, const Pose& pose,
                         std::array<double, 3> v, std::array<double, 3> w) {
  nav_msgs::Odometry m;
  m.header = header(h);
  m.child_frame_id = "body";
  m.pose.pose = pose_msg(pose);
  for (std::size_t i = 0; i < 36; ++i) m.pose.covariance[i] = 0.25;
  m.twist.twist.linear.x = v[0];
  m.twist.twist.linear.y = v[1];
  m.twist.twist.linear.z = v[2];
  m.twist.twist.angular.x = w[0];
  m.twist.twist.angular.y = w[1];
  m.twist.twist.angular.z = w[2];
  impl_->bag.write(topic, to_ros(bag_time), m);
}

void BagWriter::pose_stamped(const std::string& topic, Stamp bag_time, Stamp h, const Pose& pose) {
  geometry_msgs::PoseStamped m;
  m.header = header(h);
  m.pose = pose_msg(pose);
  impl_->bag.write(topic, to_ros(bag_time), m);
}

void BagWriter::transform_stamped(const std::string& topic, Stamp bag_time, Stamp h,
                                  const Pose& pose) {
  geometry_msgs::TransformStamped m;
  m.header = header(h);
  m.child_frame_id = "ball";
  m.transform.translation.x = pose.p[0];
  m.transform.translation.y = pose.p[1];
  m.transform.translation.z = pose.p[2];
  m.transform.rotation.x = pose.q[0];
  m.transform.rotation.y = pose.q[1];
  m.transform.rotation.z = pose.q[2];
  m.transform.rotation.w = pose.q[3];
  impl_->bag.write(topic, to_ros(bag_time), m);
}

void BagWriter::raw(const std::string& topic, Stamp bag_time, const std::string& type,
                    const std::string& md5, const std::vector<std::uint8_t>& bytes) {
  fdv_test_msgs::RawBytes m{bytes, type, md5};
  impl_->bag.write(topic, to_ros(bag_time), m);
}

std::string generated_md5(const std::string& type) {
  using ros::message_traits::md5sum;
  if (type == "sensor_msgs/Imu") return md5sum<sensor_msgs::Imu>();
  if (type == "sensor_msgs/Image") return md5sum<sensor_msgs::Image>();
  if (type == "nav_msgs/Odometry") return md5sum<nav_msgs::Odometry>();
  if (type == "geometry_msgs/PoseStamped") return md5sum<geometry_msgs::PoseStamped>();
  if (type == "geometry_msgs/TransformStamped") return md5sum<geometry_msgs::TransformStamped>();
  if (type == "std_msgs/Header") return md5sum<std_msgs::Header>();
  throw std::invalid_argument("no generated header for " + type);
}

}  // namespace fdv::test::ros1
