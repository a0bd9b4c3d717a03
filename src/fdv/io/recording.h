#pragma once
/// The one interface every input format implements, so that files, bags, the simulator and
/// live sources all feed the same pipeline.
///
///   auto reader = fdv::open_recording("run.aedat4");
///   fdv::SensorChunk chunk;
///   while (reader->read(chunk)) { /* chunk.events, chunk.imu, ... */ }
///   reader->report();   // what was dropped or repaired, and why
///
/// Contract for implementations:
///  - read() hands out the recording piece by piece (about `ReaderOptions::chunk_events` events
///    at a time) and never needs the whole file in memory;
///  - within each stream, items come in non-decreasing time (a record whose time goes backwards
///    is dropped and counted in the report, never reordered silently);
///  - events outside the sensor resolution are dropped and counted;
///  - unrecoverable corruption (bad magic, truncated header) throws InputError with the file,
///    byte offset or line and the reason; recoverable damage (a corrupt packet, a truncated
///    tail) is dropped and counted so the rest of the file stays usable.
/// Not thread-safe; one reader per thread.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"
#include "fdv/io/read_report.h"

namespace fdv {

enum class StreamKind { kEvents, kImu, kDepth, kOdometry, kGroundTruth };
/// Position of `kind` in the enumeration, for arrays indexed by stream.
constexpr std::size_t stream_index(StreamKind kind) { return static_cast<std::size_t>(kind); }
const char* to_string(StreamKind kind);

/// One topic (channel) of a recording that has them (ROS bags): listed by `fdv info`.
struct TopicInfo {
  std::string topic;
  std::string type;         ///< message type as the recording names it
  std::uint64_t count = 0;  ///< messages
  double rate_hz = 0;       ///< mean rate over the topic's span in recording time; 0 if < 2 messages
};

struct RecordingInfo {
  std::string path;
  std::string format;  ///< "aedat4", "evt2", "evt3", "rpg_text", "fdv_dataset", ...
  int width = 0;       ///< event sensor resolution; 0 when the file does not say
  int height = 0;
  std::vector<StreamKind> streams;         ///< streams this recording can contain
  std::optional<Calibration> calibration;  ///< when the recording carries one
  std::vector<std::string> notes;          ///< format details worth printing (compression, ...)
  std::vector<TopicInfo> topics;           ///< every topic of a bag; empty for other formats
};

struct SensorChunk {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  std::vector<DepthFrame> depth;
  std::vector<OdometrySample> odometry;
  std::vector<ObjectState> ground_truth;
  void clear();
  bool empty() const;
};

struct ReaderOptions {
  std::size_t chunk_events = 1 << 16;  ///< about how many events one read() hands out
  /// Topics to read from a ROS bag (other formats ignore them). Empty: chosen by message type,
  /// preferring the paper's names (/dvs/events, /mavros/imu/data, /camera/depth/image_rect_raw)
  /// when several topics qualify; docs/FORMATS.md "ROS 1 bags" has the rules.
  std::string events_topic;
  std::string imu_topic;
  std::string depth_topic;
  std::string odometry_topic;
  std::string ground_truth_topic;
  /// Event sensor size for files that may not say it (HDF5: DSEC files carry no size); the
  /// file's own size wins when it has one. 0: from the file only.
  int width = 0;
  int height = 0;
};

class RecordingReader {
 public:
  virtual ~RecordingReader() = default;
  virtual const RecordingInfo& info() const = 0;
  /// Clears `chunk` and fills it with the next piece. Returns false once the recording is
  /// exhausted (the chunk is then empty).
  virtual bool read(SensorChunk& chunk) = 0;
  /// Drops and repairs so far (complete once read() has returned false).
  virtual const ReadReport& report() const = 0;
};

/// Detects the format of `path` (by magic bytes or folder layout) and opens it.
/// Throws InputError for a missing file or an unrecognised format.
std::unique_ptr<RecordingReader> open_recording(const std::string& path,
                                                const ReaderOptions& options = {});

/// Where the i-th event of a batch is in the input ("byte 1600024", "line 17"): a drop's first
/// position names the exact record, not the batch.
using EventLocator = std::function<std::string(std::size_t index)>;

/// Drops events that break the stream contract (a corrupt time outside valid_time(), time going
/// backwards, pixel outside the sensor) and counts them in `report`. Readers run every decoded
/// batch through it.
/// An event more than kMaxForwardJumpNs after the last one kept is held until the next event
/// decides (a single corrupt time far ahead would otherwise make every later event "go
/// backwards"): if that event follows the last kept time (not behind it, at most the same span
/// ahead), the held one was a corrupt time and is dropped (`event time far ahead of the stream`);
/// if it follows the held one, the jump was real and both are kept. An event still held when the
/// stream ends is not output.
class EventSanitizer {
 public:
  static constexpr TimeNs kMaxForwardJumpNs = 1'000'000'000;
  EventSanitizer(int width, int height) : width_(width), height_(height) {}
  /// Appends the valid events of [first, last) to `out`; `where` locates each for the report.
  void append(const Event* first, const Event* last, std::vector<Event>& out, ReadReport& report,
              const EventLocator& where);
  TimeNs last_time() const { return last_t_; }

 private:
  int width_, height_;
  TimeNs last_t_ = std::numeric_limits<TimeNs>::min();
  std::optional<Event> held_;
  std::string held_where_;
};

}  // namespace fdv
