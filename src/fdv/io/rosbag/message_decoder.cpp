#include "fdv/io/rosbag/message_decoder.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fdv/core/camera.h"
#include "fdv/io/rosbag/message_cursor.h"

namespace fdv::bag {

MessageDecoder::MessageDecoder(Dialect dialect) : dialect_(dialect) {
  last_t_.fill(std::numeric_limits<TimeNs>::min());
}

void MessageDecoder::set_sensor_size(int width, int height) {
  if (width > 0 && height > 0)
    sanitizer_ = EventSanitizer(width, height);
  else
    sanitizer_ = EventSanitizer(1 << 16, 1 << 16);
}

bool MessageDecoder::accept_time(StreamKind stream, TimeNs& t, std::optional<TimeNs> fallback_time,
                                 ReadReport& report, const std::string& where) {
  if (t == 0) {
    if (!fallback_time) {
      report.drop(std::string(to_string(stream)) + ": header stamp is zero", where);
      return false;
    }
    t = *fallback_time;
    report.repair(std::string(to_string(stream)) + ": header stamp is zero, bag time used", where);
  }
  if (latest_ && t > latest_->first) {
    report.drop(std::string(to_string(stream)) + ": " + latest_->second, where);
    return false;
  }
  TimeNs& last = last_t_[stream_index(stream)];
  if (t < last) {
    report.drop(std::string(to_string(stream)) + ": timestamp went backwards", where);
    return false;
  }
  last = t;
  return true;
}

bool MessageDecoder::decode(StreamKind stream, MessageType type, const std::uint8_t* data,
                            std::size_t size, std::optional<TimeNs> fallback_time,
                            SensorChunk& out, ReadReport& report, const std::string& where) {
  bool accepted = false;
  const char* why = nullptr;
  auto run = [&](auto cursor) {
    if (!cursor.ok()) {
      report.drop(std::string(to_string(stream)) + ": message too short or not plain CDR", where);
      return;
    }
    why = decode_with(cursor, stream, type, fallback_time, out, report, where, accepted);
  };
  if (dialect_ == Dialect::kRos1)
    run(Ros1Cursor(data, size));
  else
    run(CdrCursor(data, size));
  if (why && !accepted) report.drop(why, where);
  return accepted;
}

template <class Cursor>
const char* MessageDecoder::decode_with(Cursor& c, StreamKind stream, MessageType type,
                                        std::optional<TimeNs> fallback_time, SensorChunk& out,
                                        ReadReport& report, const std::string& where,
                                        bool& accepted) {
  const char* why = nullptr;
  switch (stream) {
    case StreamKind::kEvents: {
      raw_events_.clear();
      // Why the message's declared sensor size is refused, or nullptr. Above the cap of any
      // camera it is not taken as the size of a run (image buffers are allocated from it).
      auto size_refused = [&](std::uint32_t width, std::uint32_t height) -> const char* {
        static_assert(kMaxCameraSide == 4096, "the reason below names the cap");
        if (width > kMaxCameraSide || height > kMaxCameraSide) return "events: sensor size above the cap 4096";
        message_size_ = {static_cast<int>(width), static_cast<int>(height)};
        if (required_size_ && *required_size_ != message_size_)
          return "events: the message's sensor size is not the calibration's";
        return nullptr;
      };
      if (type == MessageType::kEventPacket) {
        EventPacketView p;
        why = decode_event_packet(c, p);
        if (!why) why = size_refused(p.width, p.height);
        if (!why) packet_decoder_.decode(p, raw_events_, report, where);
      } else {
        EventArrayHeader h;
        why = decode_event_array(c, h, raw_events_);
        if (!why) why = size_refused(h.width, h.height);
      }
      if (!why && latest_) {
        const auto late = [&](const Event& e) { return e.t > latest_->first; };
        const auto kept = std::remove_if(raw_events_.begin(), raw_events_.end(), late);
        if (kept == raw_events_.begin() && kept != raw_events_.end()) {  // all of them: the message is dropped
          report.drop("events: " + latest_->second, where, raw_events_.size());
          break;
        }
        if (kept != raw_events_.end())
          report.drop("events: " + latest_->second, where, static_cast<std::uint64_t>(raw_events_.end() - kept));
        raw_events_.erase(kept, raw_events_.end());
      }
      if (!why) {
        sanitizer_.append(raw_events_.data(), raw_events_.data() + raw_events_.size(), out.events, report,
                          [&](std::size_t i) { return where + ", event " + std::to_string(i); });
        accepted = true;
      }
      break;
    }
    case StreamKind::kImu: {
      ImuSample s;
      why = decode_imu(c, s);
      if (!why && accept_time(stream, s.t, fallback_time, report, where)) {
        out.imu.push_back(s);
        accepted = true;
      }
      break;
    }
    case StreamKind::kDepth: {
      DepthFrame f;
      why = decode_depth_image(c, f);
      if (!why && accept_time(stream, f.t, fallback_time, report, where)) {
        out.depth.push_back(std::move(f));
        accepted = true;
      }
      break;
    }
    case StreamKind::kOdometry:
    case StreamKind::kGroundTruth: {
      OdometrySample s;
      if (type == MessageType::kOdometry) why = decode_odometry(c, s);
      if (type == MessageType::kPoseStamped) why = decode_pose_stamped(c, s);
      if (type == MessageType::kTransformStamped) why = decode_transform_stamped(c, s);
      if (why) break;
      if (stream == StreamKind::kOdometry) {
        if (std::abs(s.q_W_B.norm() - 1.0) > kUnitQuaternionTolerance) {
          why = "odometry: quaternion is not unit length";
          break;
        }
        s.q_W_B.normalize();
        if (accept_time(stream, s.t, fallback_time, report, where)) {
          out.odometry.push_back(s);
          accepted = true;
        }
      } else if (accept_time(stream, s.t, fallback_time, report, where)) {
        ObjectState o;
        o.t = s.t;
        o.id = 0;
        o.p_W = s.p_W_B;
        o.v_W = s.v_W;  // zero for poses; the odometry's own velocity when given explicitly
        out.ground_truth.push_back(o);
        accepted = true;
      }
      break;
    }
  }
  return why;
}

}  // namespace fdv::bag
