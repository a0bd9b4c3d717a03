#pragma once
/// Per-event ground-truth labels: what caused each simulated event.
///
/// File `truth/event_labels.bin` of a dataset folder (docs/SIMULATOR.md, docs/FORMATS.md),
/// little-endian:
///   bytes 0-7   magic "FDVLBL01"
///   bytes 8-15  uint64 count (equals the event count of events.bin)
///   bytes 16... count int16 labels, the i-th for the i-th event of events.bin
/// Label values: >= 1 the id of the object (ball) whose image caused the event, 0 the static
/// scene (ego-motion), -1 background activity noise, -2 a hot pixel.
///
///   EventLabelWriter w(dir + "/truth/event_labels.bin");  w.append(labels);  w.finish();
///   std::vector<std::int16_t> labels = read_event_labels(dir);
/// Thread safety: not thread-safe; one writer per file, used by one thread.
#include <cstdint>
#include <fstream>
#include <span>
#include <string>
#include <vector>

namespace fdv::sim {

inline constexpr std::int16_t kLabelScene = 0;
inline constexpr std::int16_t kLabelNoise = -1;
inline constexpr std::int16_t kLabelHotPixel = -2;
inline constexpr char kLabelsMagic[8] = {'F', 'D', 'V', 'L', 'B', 'L', '0', '1'};
inline constexpr const char* kLabelsFile = "truth/event_labels.bin";

class EventLabelWriter {
 public:
  /// Creates the file (the folder must exist). Throws InputError if it cannot.
  explicit EventLabelWriter(const std::string& path);
  ~EventLabelWriter();
  EventLabelWriter(const EventLabelWriter&) = delete;
  EventLabelWriter& operator=(const EventLabelWriter&) = delete;
  void append(std::span<const std::int16_t> labels);
  /// Writes the count and closes. Throws InputError on a write failure.
  void finish();

 private:
  std::string path_;
  std::ofstream out_;
  std::uint64_t count_ = 0;
  bool finished_ = false;
};

/// Reads `DIR/truth/event_labels.bin`. Throws InputError (file, byte offset, reason) for a
/// missing file, a wrong magic or a file shorter than its count.
std::vector<std::int16_t> read_event_labels(const std::string& dataset_dir);

}  // namespace fdv::sim
