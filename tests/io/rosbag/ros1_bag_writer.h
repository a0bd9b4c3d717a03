#pragma once
// Writes ROS 1 bags for the reader tests with ROS's own library (rosbag::Bag in write mode and
// roscpp's serializer): an independent producer. Typed messages come from Debian's generated
// message headers (sensor_msgs, nav_msgs, geometry_msgs); the event arrays, whose packages
// Debian does not ship, are declared in the .cpp with ROS serializers, and arbitrary bytes can
// be written under any type name and MD5 sum. This header includes no ROS header: the writer is
// compiled as C++17 (Debian's generated headers do not compile as C++20) and called from the
// C++20 tests.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace fdv::test::ros1 {

struct Stamp {
  std::uint32_t sec = 0;
  std::uint32_t nsec = 0;
};

struct RawEvent {
  std::uint16_t x = 0;
  std::uint16_t y = 0;
  Stamp ts;
  bool polarity = false;
};

/// Position and attitude (quaternion x, y, z, w).
struct Pose {
  std::array<double, 3> p{};
  std::array<double, 4> q{0, 0, 0, 1};
};

/// The published MD5 sum of dvs_msgs/EventArray (and prophesee_event_msgs/EventArray).
inline constexpr const char* kEventArrayMd5 = "5e8beee5a6c107e504c2e78903c224b8";
/// The MD5 sum of event_camera_msgs/EventPacket's ROS 1 definition (tests/ros checks it).
inline constexpr const char* kEventPacketMd5 = "8a6101b351a64529ac77bd8b71074e52";

class BagWriter {
 public:
  enum class Compression { kNone, kLz4, kBz2 };
  explicit BagWriter(const std::string& path, Compression compression = Compression::kNone);
  ~BagWriter();
  void event_array(const std::string& topic, Stamp bag_time, Stamp header, std::uint32_t width,
                   std::uint32_t height, const std::vector<RawEvent>& events,
                   const std::string& type = "dvs_msgs/EventArray",
                   const std::string& md5 = kEventArrayMd5);
  /// event_camera_msgs/EventPacket with `events` already encoded as `encoding` says.
  void event_packet(const std::string& topic, Stamp bag_time, Stamp header, std::uint32_t width,
                    std::uint32_t height, std::uint64_t time_base, const std::string& encoding,
                    const std::vector<std::uint8_t>& events);
  void imu(const std::string& topic, Stamp bag_time, Stamp header, std::array<double, 3> gyro,
           std::array<double, 3> accel);
  void image(const std::string& topic, Stamp bag_time, Stamp header, std::uint32_t width,
             std::uint32_t height, const std::string& encoding, std::uint32_t step,
             const std::vector<std::uint8_t>& data);
  void odometry(const std::string& topic, Stamp bag_time, Stamp header, const Pose& pose,
                std::array<double, 3> v_child, std::array<double, 3> w_child);
  void pose_stamped(const std::string& topic, Stamp bag_time, Stamp header, const Pose& pose);
  void transform_stamped(const std::string& topic, Stamp bag_time, Stamp header, const Pose& pose);
  /// Arbitrary message bytes under any type name and MD5 sum.
  void raw(const std::string& topic, Stamp bag_time, const std::string& type,
           const std::string& md5, const std::vector<std::uint8_t>& bytes);
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The MD5 sum Debian's generated header for `type` ("sensor_msgs/Imu", ...) carries.
std::string generated_md5(const std::string& type);

}  // namespace fdv::test::ros1
