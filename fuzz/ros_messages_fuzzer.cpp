// The ROS message decoders on one serialized message, ROS 1 or CDR (ROS 2), and the EventPacket
// event decoder behind them. Byte 0 picks the message type and the wire format; the rest is the
// message. The decoders never throw: they return a reason, or nullptr with values that must be
// finite where the decoder promises it.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fdv/io/rosbag/event_packet_decoder.h"
#include "fdv/io/rosbag/message_cursor.h"
#include "fdv/io/rosbag/ros_messages.h"
#include "fuzz/fuzz_support.h"

namespace {

using namespace fdv;
using namespace fdv::bag;

template <class Cursor>
void decode(std::uint8_t type, const std::uint8_t* data, std::size_t size) {
  Cursor c(data, size);
  switch (type % 7) {
    case 0: {
      EventArrayHeader header;
      std::vector<Event> events;
      (void)decode_event_array(c, header, events);
      break;
    }
    case 1: {
      // A few packets through one decoder: its evt3 state and clock anchor span packets.
      EventPacketDecoder decoder;
      std::vector<Event> events;
      ReadReport report;
      for (int packet = 0; packet < 3 && c.ok() && c.remaining() > 0; ++packet) {
        EventPacketView view;
        if (decode_event_packet(c, view) == nullptr) decoder.decode(view, events, report, "message 0");
      }
      (void)report.to_json().dump();  // reasons must be valid UTF-8
      break;
    }
    case 2: {
      ImuSample imu;
      if (decode_imu(c, imu) == nullptr && !(imu.gyro_rad_s.allFinite() && imu.accel_m_s2.allFinite()))
        fuzz::contract_broken("IMU sample decoded with a non-finite value", "");
      break;
    }
    case 3: {
      DepthFrame frame;
      (void)decode_depth_image(c, frame);
      break;
    }
    case 4: {
      OdometrySample odometry;
      (void)decode_odometry(c, odometry);
      break;
    }
    case 5: {
      OdometrySample pose;
      (void)decode_pose_stamped(c, pose);
      break;
    }
    default: {
      OdometrySample transform;
      (void)decode_transform_stamped(c, transform);
      break;
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  if (data[0] & 0x80)
    decode<CdrCursor>(data[0], data + 1, size - 1);
  else
    decode<Ros1Cursor>(data[0], data + 1, size - 1);
  return 0;
}
