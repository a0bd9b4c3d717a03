#pragma once
/// What the ROS 1 and ROS 2 bag readers share: choosing a topic per stream, and turning the
/// bag's messages (in bag time order) into SensorChunks. The storage layer (rosbag::View for
/// ROS 1, SQLite for ROS 2) only hands over raw message bytes one at a time.
/// Internal to src/fdv/io/rosbag; users call open_ros1_bag / open_ros2_bag (rosbag_reader.h).
/// Thread safety: not thread-safe; one reader per thread (the RecordingReader contract).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "fdv/io/recording.h"
#include "fdv/io/rosbag/message_decoder.h"
#include "fdv/io/rosbag/ros_messages.h"

namespace fdv::bag {

/// Whether the reader decodes `type` from bags of this dialect.
bool supported(MessageType type, Dialect dialect);

/// The paper's topic name for a stream, preferred when several topics qualify ("" if none).
const char* preferred_topic(StreamKind stream);

struct SelectedTopic {
  StreamKind stream = StreamKind::kEvents;
  std::string topic;
  std::string type_name;
  MessageType type = MessageType::kUnsupported;
};

/// Chooses the topic of every stream from `topics` (docs/FORMATS.md, "ROS 1 bags"): an explicit
/// option must name an existing topic of a fitting type (else InputError naming the topic and
/// what it has); an empty option picks, among topics with messages of an automatic type, the
/// paper's name if present, else the one with the most messages. Choices are added to `notes`.
std::vector<SelectedTopic> select_topics(const std::string& file,
                                         const std::vector<TopicInfo>& topics,
                                         const ReaderOptions& options, Dialect dialect,
                                         std::vector<std::string>& notes);

/// One message handed over by the storage layer. `data` stays valid until the next call.
struct RawMessage {
  std::size_t selected = 0;  ///< index into the selected topics
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
  TimeNs bag_time = 0;         ///< the time the bag recorded the message at
  std::uint64_t position = 0;  ///< ROS 1: ordinal within its topic (from 1); ROS 2: messages.id
};

class BagReader : public RecordingReader {
 public:
  const RecordingInfo& info() const override { return info_; }
  const ReadReport& report() const override { return report_; }
  bool read(SensorChunk& chunk) override;

  /// At most this many IMU / odometry / ground-truth items, and depth frames, per chunk (bounded
  /// memory when a stretch of the bag has no events).
  static constexpr std::size_t kMaxItemsPerChunk = 4096;
  static constexpr std::size_t kMaxDepthFramesPerChunk = 8;

 protected:
  BagReader(const std::string& path, const ReaderOptions& options, Dialect dialect,
            std::string format);
  /// Called once by the subclass constructor with the bag's topic listing: selects topics,
  /// reads the event geometry (via peek_event_message) and fills info().
  void setup(std::vector<TopicInfo> topics);

  /// Checks the selected topics before any of their messages is decoded (ROS 1: MD5 sums).
  virtual void check_selected() {}
  /// The first message of the selected events topic; false if it has none.
  virtual bool peek_event_message(std::vector<std::uint8_t>& bytes) = 0;
  /// The next message of any selected topic in bag time order; false at the end.
  virtual bool next_message(RawMessage& m) = 0;
  /// Label of RawMessage::position in report positions ("message " or "messages.id ").
  virtual const char* position_label() const = 0;

  const std::vector<SelectedTopic>& selected() const { return selected_; }
  const std::string& path() const { return info_.path; }

  RecordingInfo info_;
  ReadReport report_;

 private:
  void read_geometry();

  ReaderOptions options_;
  Dialect dialect_;
  std::vector<SelectedTopic> selected_;
  MessageDecoder decoder_;
};

}  // namespace fdv::bag
