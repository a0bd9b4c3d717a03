// The message headers generated from ros/msg carry the md5sums of the public definitions, so that
// our node and exported bags interoperate with the drivers that publish these types.
#include <dvs_msgs/EventArray.h>
#include <event_camera_msgs/EventPacket.h>
#include <gtest/gtest.h>
#include <ros/message_traits.h>

#include <string>

namespace {

template <class Message>
std::string md5() {
  return ros::message_traits::MD5Sum<Message>::value();
}

TEST(RosMsgs, DvsEventArrayHasThePublishedMd5) {
  // rpg_dvs_ros's dvs_msgs, as `rosbag info` prints it for a bag recorded by its driver
  // (github.com/uzh-rpg/rpg_emvs issue 12).
  EXPECT_EQ(md5<dvs_msgs::EventArray>(), "5e8beee5a6c107e504c2e78903c224b8");
  EXPECT_EQ(std::string(ros::message_traits::DataType<dvs_msgs::EventArray>::value()),
            "dvs_msgs/EventArray");
}

TEST(RosMsgs, EventPacketHasTheMd5OfThePublicRos1Definition) {
  // No published md5 of event_camera_msgs/EventPacket was found, so this is the ROS 1 rule
  // (genmsg) applied by hand to the public definition, ros-event-camera/event_camera_msgs
  // msg_ros1/EventPacket.msg (commit 7b98fc5e): md5 of
  //   "2176decaecbce78abc3b96ef049fabed header\nuint32 height\nuint32 width\nuint64 seq\n"
  //   "uint64 time_base\nstring encoding\nbool is_bigendian\nuint8[] events"
  // where 2176deca... is std_msgs/Header's md5 (Debian's std_msgs/Header.h carries the same).
  EXPECT_EQ(md5<event_camera_msgs::EventPacket>(), "8a6101b351a64529ac77bd8b71074e52");
  EXPECT_EQ(md5<std_msgs::Header>(), "2176decaecbce78abc3b96ef049fabed");
  EXPECT_EQ(std::string(ros::message_traits::DataType<event_camera_msgs::EventPacket>::value()),
            "event_camera_msgs/EventPacket");
}

}  // namespace
