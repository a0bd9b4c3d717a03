#pragma once
/// Decodes ROS sensor messages one at a time, from their serialized bytes into SensorChunk items:
/// what the bag readers do with each stored message, and what a live subscriber (ros/) does in
/// each callback, so that a topic read from a bag and the same topic received live give the same
/// records, the same repairs and the same drops.
///
///   MessageDecoder decoder(Dialect::kRos1);
///   decoder.set_sensor_size(346, 260);     // events outside are dropped (0 x 0: not checked)
///   SensorChunk chunk;
///   decoder.decode(StreamKind::kImu, MessageType::kImu, bytes, size, bag_time, chunk, report, "/imu message 7");
///
/// Per stream it keeps what spans messages: the event sanitizer (fdv/io/recording.h), the
/// EventPacket decoder's clock offset and the last accepted time (a record whose time goes
/// backwards is dropped and counted). A header stamp of 0 is replaced by `fallback_time` and
/// counted as a repair; without a fallback (a live message has no bag time) it is dropped.
/// Not thread-safe; one decoder per source.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fdv/io/read_report.h"
#include "fdv/io/recording.h"
#include "fdv/io/rosbag/event_packet_decoder.h"
#include "fdv/io/rosbag/ros_messages.h"

namespace fdv::bag {

/// The serialization of the bytes: ROS 1 (packed little-endian) or ROS 2's CDR.
enum class Dialect { kRos1, kCdr };

class MessageDecoder {
 public:
  explicit MessageDecoder(Dialect dialect);
  Dialect dialect() const { return dialect_; }
  /// Events with a pixel outside width x height are dropped; 0 x 0 checks only the 16-bit range.
  void set_sensor_size(int width, int height);
  /// When set, an event message that declares another sensor size is dropped whole (a live
  /// source checked against its calibration).
  void require_event_message_size(int width, int height) { required_size_ = {width, height}; }
  /// When set, a record or event stamped after `latest` is dropped as `why` (before the stream's
  /// order checks, so it moves no stream's time): a live node whose outputs must stay within ROS
  /// time's range.
  void set_latest_time(TimeNs latest, std::string why) { latest_ = std::pair(latest, std::move(why)); }
  /// The sensor size the last decoded event message declared (0 x 0 before any).
  std::pair<int, int> event_message_size() const { return message_size_; }

  /// Appends what one message of `type` feeding `stream` holds to `out` (an event message: its
  /// valid events; otherwise one record). Drops and repairs go to `report` at `where`. Returns
  /// false when the whole message was dropped.
  bool decode(StreamKind stream, MessageType type, const std::uint8_t* data, std::size_t size,
              std::optional<TimeNs> fallback_time, SensorChunk& out, ReadReport& report,
              const std::string& where);

 private:
  template <class Cursor>
  const char* decode_with(Cursor& c, StreamKind stream, MessageType type,
                          std::optional<TimeNs> fallback_time, SensorChunk& out, ReadReport& report,
                          const std::string& where, bool& accepted);
  /// The stream's time rules: a zero stamp becomes the fallback (counted); backwards: dropped.
  bool accept_time(StreamKind stream, TimeNs& t, std::optional<TimeNs> fallback_time,
                   ReadReport& report, const std::string& where);

  Dialect dialect_;
  EventSanitizer sanitizer_{1 << 16, 1 << 16};
  EventPacketDecoder packet_decoder_;
  std::vector<Event> raw_events_;
  std::array<TimeNs, 5> last_t_;
  std::optional<std::pair<int, int>> required_size_;
  std::pair<int, int> message_size_{0, 0};
  std::optional<std::pair<TimeNs, std::string>> latest_;
};

}  // namespace fdv::bag
