#pragma once
/// Decodes the `events` byte buffer of event_camera_msgs/msg/EventPacket messages (ROS 2 event
/// camera drivers) in the encodings named by the packet's `encoding` field:
///
///   libcaer  8-byte records {uint32 data, int32 ts}: x = data >> 17 (15 bits), y = (data >> 2)
///            & 0x7FFF, polarity = (data >> 1) & 1, bit 0 = valid mark; ts in microseconds.
///            t = time_base + ts * 1000 ns, which is already ROS (epoch) time: the driver adds
///            the elapsed sensor time's high part to time_base. ts is a 31-bit counter: when it
///            goes down inside a packet it has rolled over, and 2^31 us is added from there on.
///   mono     8-byte words: bit 63 polarity, bits 62..48 y, bits 47..32 x, bits 31..0 dt in ns;
///            sensor time = time_base + dt.
///   evt3     Prophesee EVT 3.0 16-bit words (the project's Evt3Decoder, whose state runs on
///            from packet to packet like the camera's stream); time_base is undefined.
///
/// mono and evt3 times are on the sensor clock, not ROS time. So that they share a clock with the
/// other topics of the bag (IMU, depth, odometry header stamps), they are moved by one constant
/// offset, fixed at the first packet that yields an event: offset = that packet's header stamp
/// minus its first event's sensor time (drivers stamp a packet with the ROS time of its first
/// event). Intervals between events are therefore exactly the sensor's.
///
/// Words are read with the byte order the packet's `is_bigendian` states. Unknown encodings and
/// malformed buffers are dropped per packet and counted; the decoder never throws. Time
/// arithmetic is checked: an event whose time (time_base + ts, the offset) would leave the int64
/// nanosecond range is dropped and counted, never wrapped.
///
/// It works on bytes alone (no bag needed): CdrCursor c(data, size); EventPacketView v;
/// if (!decode_event_packet(c, v)) decoder.decode(v, events, report, "message 1").
/// Not thread-safe; one decoder per topic (the evt3 state spans packets).
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "fdv/io/prophesee/evt_decoder.h"
#include "fdv/io/read_report.h"
#include "fdv/io/rosbag/ros_messages.h"

namespace fdv::bag {

class EventPacketDecoder {
 public:
  /// Appends the events of `packet` to `out` (t in ns as described above); drops and repairs
  /// go to `report` at `where`.
  void decode(const EventPacketView& packet, std::vector<Event>& out, ReadReport& report,
              const std::string& where);
  /// Whether the sensor-clock offset has been fixed yet, and its value (ns).
  bool anchored() const { return anchored_; }
  TimeNs offset_ns() const { return offset_ns_; }

 private:
  void decode_libcaer(const EventPacketView& p, std::vector<Event>& out, ReadReport& report,
                      const std::string& where);
  void decode_mono(const EventPacketView& p, std::vector<Event>& out, ReadReport& report,
                   const std::string& where);
  void decode_evt3(const EventPacketView& p, std::vector<Event>& out, ReadReport& report,
                   const std::string& where);
  /// Moves out[first, end) from sensor time to the bag clock, anchoring on the first call that
  /// has events. Events whose time would leave the int64 range are dropped and counted.
  void shift(const EventPacketView& p, std::vector<Event>& out, std::size_t first,
             ReadReport& report, const std::string& where);

  bool anchored_ = false;
  TimeNs offset_ns_ = 0;
  Evt3Decoder evt3_;
  std::vector<std::uint16_t> words_;  ///< aligned copy of an evt3 buffer
  std::vector<Event> evt3_out_;
};

}  // namespace fdv::bag
