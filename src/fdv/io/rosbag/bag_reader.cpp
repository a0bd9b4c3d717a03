#include "fdv/io/rosbag/bag_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "fdv/core/error.h"
#include "fdv/io/text_fields.h"

namespace fdv::bag {
namespace {

constexpr std::array<StreamKind, 5> kStreams = {StreamKind::kEvents, StreamKind::kImu,
                                                StreamKind::kDepth, StreamKind::kOdometry,
                                                StreamKind::kGroundTruth};

std::string lower(std::string_view s) {
  std::string out(s);
  for (auto& ch : out) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return out;
}

/// Name filters for automatic choices where the type alone says too little: an Image topic is
/// taken as depth only if its name says so (a bag often has camera or APS images too), and a
/// pose topic as ground truth only if it comes from a motion-capture system (a vehicle's own
/// pose topic is not ground truth of a thrown object).
bool name_fits(StreamKind stream, const std::string& topic) {
  const std::string t = lower(topic);
  switch (stream) {
    case StreamKind::kDepth:
      return t.find("depth") != std::string::npos;
    case StreamKind::kGroundTruth:
      for (const char* key : {"vicon", "mocap", "optitrack", "ground_truth", "groundtruth"})
        if (t.find(key) != std::string::npos) return true;
      return false;
    default:
      return true;
  }
}

const char* option_name(StreamKind stream) {
  switch (stream) {
    case StreamKind::kEvents:
      return "events_topic";
    case StreamKind::kImu:
      return "imu_topic";
    case StreamKind::kDepth:
      return "depth_topic";
    case StreamKind::kOdometry:
      return "odometry_topic";
    case StreamKind::kGroundTruth:
      return "ground_truth_topic";
  }
  return "?";
}

const std::string& requested(const ReaderOptions& o, StreamKind stream) {
  switch (stream) {
    case StreamKind::kEvents:
      return o.events_topic;
    case StreamKind::kImu:
      return o.imu_topic;
    case StreamKind::kDepth:
      return o.depth_topic;
    case StreamKind::kOdometry:
      return o.odometry_topic;
    case StreamKind::kGroundTruth:
      return o.ground_truth_topic;
  }
  return o.events_topic;
}

std::string fitting_types(StreamKind stream, Dialect dialect) {
  std::string s;
  for (const auto& t : known_message_types())
    if (supported(t.type, dialect) && can_feed(stream, t.type, true))
      s += (s.empty() ? "" : ", ") +
           std::string(dialect == Dialect::kRos1 ? t.ros1_name : t.ros2_name);
  return s;
}

std::string topic_list(const std::vector<TopicInfo>& topics) {
  if (topics.empty()) return "(none)";
  std::string s;
  for (const auto& t : topics) s += (s.empty() ? "" : ", ") + t.topic + " (" + t.type + ")";
  return s;
}

}  // namespace

bool supported(MessageType type, Dialect dialect) {
  if (type == MessageType::kUnsupported) return false;
  return dialect == Dialect::kCdr || type_info(type).ros1_md5[0] != '\0';
}

const char* preferred_topic(StreamKind stream) {
  switch (stream) {
    case StreamKind::kEvents:
      return "/dvs/events";
    case StreamKind::kImu:
      return "/mavros/imu/data";
    case StreamKind::kDepth:
      return "/camera/depth/image_rect_raw";
    case StreamKind::kOdometry:
      return "/mavros/local_position/odom";
    case StreamKind::kGroundTruth:
      return "";
  }
  return "";
}

std::vector<SelectedTopic> select_topics(const std::string& file,
                                         const std::vector<TopicInfo>& topics,
                                         const ReaderOptions& options, Dialect dialect,
                                         std::vector<std::string>& notes) {
  std::vector<SelectedTopic> out;
  auto taken = [&](const std::string& topic) {
    return std::any_of(out.begin(), out.end(), [&](const auto& s) { return s.topic == topic; });
  };
  auto take = [&](StreamKind stream, const TopicInfo& t) {
    out.push_back({stream, t.topic, t.type, message_type(t.type)});
  };
  // Explicit choices first, so that automatic ones never take a topic the user assigned.
  for (const StreamKind stream : kStreams) {
    const std::string& want = requested(options, stream);
    if (want.empty()) continue;
    const TopicInfo* chosen = nullptr;
    for (const auto& t : topics)
      if (t.topic == want) chosen = &t;
    if (!chosen)
      throw InputError(file, "topic " + want,
                       std::string("no such topic (") + option_name(stream) +
                           "); the bag has: " + topic_list(topics));
    const MessageType type = message_type(chosen->type);
    if (!supported(type, dialect) || !can_feed(stream, type, true))
      throw InputError(file, "topic " + want,
                       "has type " + chosen->type + ", but the " + to_string(stream) +
                           " stream needs one of: " + fitting_types(stream, dialect));
    for (const auto& s : out)
      if (s.topic == want)
        throw InputError(file, "topic " + want,
                         std::string("requested for both the ") + to_string(s.stream) +
                             " and the " + to_string(stream) + " stream");
    if (chosen->count == 0)
      notes.push_back(std::string(to_string(stream)) + " topic " + want + " has no messages");
    take(stream, *chosen);
  }
  for (const StreamKind stream : kStreams) {
    if (!requested(options, stream).empty()) continue;
    std::vector<const TopicInfo*> candidates;
    for (const auto& t : topics) {
      const MessageType type = message_type(t.type);
      if (t.count > 0 && supported(type, dialect) && can_feed(stream, type, false) &&
          name_fits(stream, t.topic) && !taken(t.topic))
        candidates.push_back(&t);
    }
    if (candidates.empty()) continue;
    const TopicInfo* chosen = nullptr;
    for (const auto* c : candidates)
      if (c->topic == preferred_topic(stream)) chosen = c;
    if (!chosen)
      chosen = *std::max_element(
          candidates.begin(), candidates.end(), [](const TopicInfo* a, const TopicInfo* b) {
            return a->count < b->count || (a->count == b->count && a->topic > b->topic);
          });
    if (candidates.size() > 1) {
      std::string names;
      for (const auto* c : candidates) names += (names.empty() ? "" : ", ") + c->topic;
      notes.push_back(std::string(to_string(stream)) + ": chose " + chosen->topic + " among " +
                      names + " (set ReaderOptions::" + option_name(stream) + " for another)");
    }
    take(stream, *chosen);
  }
  std::sort(out.begin(), out.end(),
            [](const auto& a, const auto& b) { return stream_index(a.stream) < stream_index(b.stream); });
  for (const auto& s : out)
    notes.push_back(std::string(to_string(s.stream)) + ": " + s.topic + " (" + s.type_name + ")");
  return out;
}

BagReader::BagReader(const std::string& path, const ReaderOptions& options, Dialect dialect,
                     std::string format)
    : options_(options), dialect_(dialect), decoder_(dialect) {
  info_.path = path;
  info_.format = std::move(format);
}

void BagReader::setup(std::vector<TopicInfo> topics) {
  info_.topics = std::move(topics);
  selected_ = select_topics(info_.path, info_.topics, options_, dialect_, info_.notes);
  for (const auto& s : selected_) info_.streams.push_back(s.stream);
  check_selected();
  read_geometry();
}

void BagReader::read_geometry() {
  const auto events = std::find_if(selected_.begin(), selected_.end(),
                                   [](const auto& s) { return s.stream == StreamKind::kEvents; });
  std::vector<std::uint8_t> bytes;
  if (events != selected_.end() && peek_event_message(bytes)) {
    auto parse = [&](auto cursor) {
      if (events->type == MessageType::kEventPacket) {
        EventPacketView p;
        if (!decode_event_packet(cursor, p)) {
          info_.width = static_cast<int>(p.width);
          info_.height = static_cast<int>(p.height);
          info_.notes.push_back("event encoding: " + escape_non_utf8(p.encoding));
          if (p.encoding == "evt3" || p.encoding == "mono")
            info_.notes.push_back(
                "event times: sensor clock moved onto the header-stamp clock by one constant "
                "offset fixed at the first packet with events");
        }
      } else {
        EventArrayHeader h;
        std::vector<Event> ignored;
        if (!decode_event_array(cursor, h, ignored)) {
          info_.width = static_cast<int>(h.width);
          info_.height = static_cast<int>(h.height);
        }
      }
    };
    if (dialect_ == Dialect::kRos1)
      parse(Ros1Cursor(bytes.data(), bytes.size()));
    else
      parse(CdrCursor(bytes.data(), bytes.size()));
  }
  if (info_.width <= 0 || info_.height <= 0 || info_.width > 65535 || info_.height > 65535) {
    if (events != selected_.end())
      info_.notes.push_back("the event messages give no sensor size: pixels are not range-checked");
    info_.width = info_.height = 0;
  }
  decoder_.set_sensor_size(info_.width, info_.height);
}

bool BagReader::read(SensorChunk& chunk) {
  chunk.clear();
  RawMessage m;
  while (chunk.events.size() < options_.chunk_events &&
         chunk.imu.size() + chunk.odometry.size() + chunk.ground_truth.size() < kMaxItemsPerChunk &&
         chunk.depth.size() < kMaxDepthFramesPerChunk) {
    if (!next_message(m)) break;
    const SelectedTopic& topic = selected_[m.selected];
    decoder_.decode(topic.stream, topic.type, m.data, m.size, m.bag_time, chunk, report_,
                    topic.topic + " " + position_label() + std::to_string(m.position));
  }
  return !chunk.empty();
}

}  // namespace fdv::bag
