#pragma once
/// The ROS message types the bag readers understand, and their decoders from serialized bytes
/// (ROS 1 serialization or ROS 2 CDR, see message_cursor.h). No ROS message package is needed:
/// each layout is written here from the type's .msg definition.
///
///   Ros1Cursor c(bytes, size);
///   ImuSample s;
///   if (const char* why = decode_imu(c, s)) report.drop(why, where);
///
/// Every decoder returns nullptr on success or a short fixed reason for the read report.
/// Header stamps are returned as they are (0 included); the reader decides what to do with 0.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <cstdint>
#include <string_view>
#include <vector>

#include "fdv/core/sensor_data.h"
#include "fdv/io/recording.h"
#include "fdv/io/rosbag/message_cursor.h"

namespace fdv::bag {

enum class MessageType {
  kUnsupported,
  kDvsEventArray,        ///< dvs_msgs/EventArray (per-event stamps)
  kPropheseeEventArray,  ///< prophesee_event_msgs/EventArray (same layout as dvs_msgs)
  kEventPacket,          ///< event_camera_msgs/EventPacket (encoded byte buffer)
  kImu,                  ///< sensor_msgs/Imu
  kImage,                ///< sensor_msgs/Image (depth: 16UC1 mm or 32FC1 m)
  kOdometry,             ///< nav_msgs/Odometry
  kPoseStamped,          ///< geometry_msgs/PoseStamped
  kTransformStamped,     ///< geometry_msgs/TransformStamped
};

struct MessageTypeInfo {
  MessageType type;
  const char* ros1_name;  ///< "pkg/Type"
  const char* ros2_name;  ///< "pkg/msg/Type"
  /// MD5 of the ROS 1 definition (the ROS 1 md5 rule: constants and fields, comments and
  /// whitespace stripped, nested types replaced by their own MD5); "" when the reader does not
  /// decode this type from ROS 1 bags. Checked against each ROS 1 connection header.
  const char* ros1_md5;
};

/// Every supported type, in a fixed order.
const std::vector<MessageTypeInfo>& known_message_types();
/// The type named `name` in either spelling; kUnsupported when unknown.
MessageType message_type(std::string_view name);
const MessageTypeInfo& type_info(MessageType type);

/// Whether messages of `type` can feed `stream`. `explicit_choice` admits the extra pairings a
/// user may ask for by topic (poses as odometry, odometry as ground truth) that are never
/// chosen automatically.
bool can_feed(StreamKind stream, MessageType type, bool explicit_choice);

/// A decoded dvs_msgs / prophesee_event_msgs EventArray: geometry from the message, events
/// appended to a caller-owned buffer (reused between messages: no allocation once grown).
struct EventArrayHeader {
  TimeNs stamp = 0;
  std::uint32_t height = 0;
  std::uint32_t width = 0;
};

/// event_camera_msgs/msg/EventPacket, with `events` pointing into the message bytes.
struct EventPacketView {
  TimeNs stamp = 0;
  std::uint32_t height = 0;
  std::uint32_t width = 0;
  std::uint64_t seq = 0;
  std::uint64_t time_base = 0;
  std::string_view encoding;
  bool big_endian = false;
  const std::uint8_t* events = nullptr;
  std::size_t events_bytes = 0;
};

template <class Cursor>
const char* decode_event_array(Cursor& c, EventArrayHeader& header, std::vector<Event>& out);
template <class Cursor>
const char* decode_event_packet(Cursor& c, EventPacketView& packet);
template <class Cursor>
const char* decode_imu(Cursor& c, ImuSample& out);
/// Depth image: 16UC1 (millimetres) or 32FC1 (metres); anything else is a reason to drop.
/// Pixels that are 0, negative, NaN or infinite become 0 (invalid), the DepthFrame convention.
template <class Cursor>
const char* decode_depth_image(Cursor& c, DepthFrame& out);
/// nav_msgs/Odometry: pose of the child frame (body) in the parent frame (world). The twist is
/// in the child frame (REP 105 / the message's own comment), so the linear velocity is rotated
/// into W: v_W = q_W_B * v_B; the angular velocity stays in B.
template <class Cursor>
const char* decode_odometry(Cursor& c, OdometrySample& out);
/// PoseStamped / TransformStamped: position and attitude; velocities left zero.
template <class Cursor>
const char* decode_pose_stamped(Cursor& c, OdometrySample& out);
template <class Cursor>
const char* decode_transform_stamped(Cursor& c, OdometrySample& out);

}  // namespace fdv::bag
