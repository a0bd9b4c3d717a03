// The ROS node's message handling (ros/core NodeCore): what its subscribers hand it, a run of
// serialized messages on its four streams, then the end of input and its /diagnostics. Byte 0
// picks the configuration (bit 0: CDR instead of ROS 1 bytes; bit 1: a configured 64x48 sensor,
// else the size comes from the first event message, as for a node without calibration); then
// each message is a byte choosing its stream and type, a 2-byte length and its bytes. NodeCore
// promises to drop (count and warn) what it cannot use: push() and finish() must not throw,
// crash or report, and diagnostics() must be JSON that dumps.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "node_core.h"

namespace {

using fdv::ros_core::Stream;

/// Each stream with the message types its subscriber takes (ros/node), wrong pairs included.
constexpr std::array<std::pair<Stream, const char*>, 10> kMessages{{
    {Stream::kEvents, "dvs_msgs/EventArray"},
    {Stream::kEvents, "prophesee_event_msgs/EventArray"},
    {Stream::kEvents, "event_camera_msgs/EventPacket"},
    {Stream::kImu, "sensor_msgs/Imu"},
    {Stream::kDepth, "sensor_msgs/Image"},
    {Stream::kOdometry, "nav_msgs/Odometry"},
    {Stream::kOdometry, "geometry_msgs/PoseStamped"},
    {Stream::kOdometry, "geometry_msgs/TransformStamped"},
    {Stream::kImu, "nav_msgs/Odometry"},
    {Stream::kEvents, "sensor_msgs/Imu"},
}};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  fdv::ros_core::NodeConfig config;
  config.cdr = (data[0] & 1) != 0;
  if (data[0] & 2) config.width = 64, config.height = 48;
  fdv::ros_core::NodeCore core(config, {});
  for (std::size_t pos = 1; pos + 3 <= size;) {
    const auto& [stream, type] = kMessages[data[pos] % kMessages.size()];
    const std::size_t length = std::min<std::size_t>(data[pos + 1] | (data[pos + 2] << 8), size - pos - 3);
    (void)core.push(stream, type, data + pos + 3, length);
    pos += 3 + length;
  }
  core.finish();
  (void)core.diagnostics().dump();
  return 0;
}
