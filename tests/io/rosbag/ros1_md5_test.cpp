// The MD5 sums the ROS 1 reader checks connection headers against, recomputed here from the
// message definitions by the ROS 1 md5 rule, and compared with two outside sources: the values
// in Debian's generated message headers, and the published dvs_msgs value.
//
// The rule (genmsg): the MD5 text of a message is its constants ("type name=value") then its
// fields, one per line, comments and extra whitespace removed; a field of a built-in type is
// "type name" (array brackets kept, e.g. "float64[9] covariance"); a field of a message type is
// "<MD5 of that type> name" (array brackets dropped). `Header` is std_msgs/Header.
#include <gtest/gtest.h>

#include <boost/uuid/detail/md5.hpp>
#include <cstdio>
#include <map>
#include <string>

#include "fdv/io/rosbag/ros_messages.h"
#include "ros1_bag_writer.h"

namespace fdv {
namespace {

std::string md5_hex(const std::string& text) {
  boost::uuids::detail::md5 hash;
  hash.process_bytes(text.data(), text.size());
  boost::uuids::detail::md5::digest_type digest;
  hash.get_digest(digest);
  std::string hex;
  char word[9];
  for (unsigned int w : digest) {
    std::snprintf(word, sizeof word, "%08x", w);
    hex += word;
  }
  return hex;
}

/// MD5 sums by the rule. Field lists are the .msg definitions with comments stripped; a type
/// in angle brackets is a nested message replaced by its MD5.
class Md5Rule {
 public:
  Md5Rule() {
    def("std_msgs/Header", "uint32 seq\ntime stamp\nstring frame_id");
    def("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z");
    def("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z");
    def("geometry_msgs/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w");
    def("geometry_msgs/Pose",
        "<geometry_msgs/Point> position\n<geometry_msgs/Quaternion> orientation");
    def("geometry_msgs/PoseWithCovariance", "<geometry_msgs/Pose> pose\nfloat64[36] covariance");
    def("geometry_msgs/Twist", "<geometry_msgs/Vector3> linear\n<geometry_msgs/Vector3> angular");
    def("geometry_msgs/TwistWithCovariance", "<geometry_msgs/Twist> twist\nfloat64[36] covariance");
    def("geometry_msgs/Transform",
        "<geometry_msgs/Vector3> translation\n<geometry_msgs/Quaternion> rotation");
    def("nav_msgs/Odometry",
        "<std_msgs/Header> header\nstring child_frame_id\n<geometry_msgs/PoseWithCovariance> "
        "pose\n<geometry_msgs/TwistWithCovariance> twist");
    def("sensor_msgs/Imu",
        "<std_msgs/Header> header\n<geometry_msgs/Quaternion> orientation\nfloat64[9] "
        "orientation_covariance\n<geometry_msgs/Vector3> angular_velocity\nfloat64[9] "
        "angular_velocity_covariance\n<geometry_msgs/Vector3> linear_acceleration\nfloat64[9] "
        "linear_acceleration_covariance");
    def("sensor_msgs/Image",
        "<std_msgs/Header> header\nuint32 height\nuint32 width\nstring encoding\nuint8 "
        "is_bigendian\nuint32 step\nuint8[] data");
    def("geometry_msgs/PoseStamped", "<std_msgs/Header> header\n<geometry_msgs/Pose> pose");
    def("geometry_msgs/TransformStamped",
        "<std_msgs/Header> header\nstring child_frame_id\n<geometry_msgs/Transform> transform");
    def("dvs_msgs/Event", "uint16 x\nuint16 y\ntime ts\nbool polarity");
    def("dvs_msgs/EventArray",
        "<std_msgs/Header> header\nuint32 height\nuint32 width\n<dvs_msgs/Event> events");
    // prophesee_event_msgs: Event.msg and EventArray.msg have the same fields as dvs_msgs.
    def("prophesee_event_msgs/Event", "uint16 x\nuint16 y\ntime ts\nbool polarity");
    def("prophesee_event_msgs/EventArray",
        "<std_msgs/Header> header\nuint32 height\nuint32 width\n<prophesee_event_msgs/Event> "
        "events");
    // event_camera_msgs/EventPacket, ros-event-camera/event_camera_msgs msg_ros1/EventPacket.msg.
    def("event_camera_msgs/EventPacket",
        "<std_msgs/Header> header\nuint32 height\nuint32 width\nuint64 seq\nuint64 time_base\n"
        "string encoding\nbool is_bigendian\nuint8[] events");
  }
  const std::string& operator[](const std::string& type) const { return md5_.at(type); }

 private:
  void def(const std::string& type, std::string text) {
    for (auto open = text.find('<'); open != std::string::npos; open = text.find('<')) {
      const auto close = text.find('>', open);
      text.replace(open, close - open + 1, md5_.at(text.substr(open + 1, close - open - 1)));
    }
    md5_[type] = md5_hex(text);
  }
  std::map<std::string, std::string> md5_;
};

TEST(Ros1Md5, TableMatchesTheRuleAndDebiansGeneratedHeaders) {
  const Md5Rule rule;
  int checked = 0;
  for (const auto& t : bag::known_message_types()) {
    if (t.ros1_md5[0] == '\0') continue;  // not decoded from ROS 1 bags
    SCOPED_TRACE(t.ros1_name);
    EXPECT_EQ(t.ros1_md5, rule[t.ros1_name]);
    const std::string name = t.ros1_name;
    if (name.rfind("sensor_msgs/", 0) == 0 || name.rfind("nav_msgs/", 0) == 0 ||
        name.rfind("geometry_msgs/", 0) == 0) {
      EXPECT_EQ(t.ros1_md5, test::ros1::generated_md5(name));
    }
    ++checked;
  }
  EXPECT_EQ(checked, 8);
  // The rule itself, on a type whose generated header Debian ships.
  EXPECT_EQ(rule["std_msgs/Header"], test::ros1::generated_md5("std_msgs/Header"));
  // dvs_msgs/EventArray as published by its generated Python module (_md5sum).
  EXPECT_EQ(rule["dvs_msgs/EventArray"], "5e8beee5a6c107e504c2e78903c224b8");
}

}  // namespace
}  // namespace fdv
