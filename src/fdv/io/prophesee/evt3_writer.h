#pragma once
/// Writes events as a Prophesee RAW file in EVT 3.0, which Metavision's tools and fdv's RAW reader
/// read (docs/FORMATS.md, "Prophesee RAW"):
///
///   fdv::Evt3Writer out("run.raw", 1280, 720);
///   out.add(chunk.events);   // in time order, t in ns
///   out.close();
///
/// EVT 3.0 holds a 24-bit microsecond time that wraps every 16.8 s, so times are written relative
/// to the first event, and the first event's time [µs] goes into the header line
/// `% time_offset_us N`, which fdv's reader adds back (other readers see times from 0). A
/// TIME_HIGH word is written for every 4096 µs period, as a camera does, so that gaps and wraps
/// decode unambiguously. Times are floored to the microsecond (`floored_events()` counts the
/// events that had a fraction). Not thread-safe.
#include <cstdint>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/sensor_data.h"

namespace fdv {

/// Largest sensor side EVT 3.0 can address (11-bit coordinates).
inline constexpr int kEvt3MaxSide = 2048;

class Evt3Writer {
 public:
  /// Throws ConfigError for a sensor EVT 3.0 cannot address, InputError when `path` cannot be
  /// created.
  Evt3Writer(const std::string& path, int width, int height);
  ~Evt3Writer();
  /// Appends events; times must not go backwards across calls (InputError otherwise).
  void add(std::span<const Event> events);
  void close();
  std::uint64_t events() const { return count_; }
  std::uint64_t floored_events() const { return floored_; }

 private:
  void word(unsigned type, unsigned payload) {
    words_.push_back(static_cast<std::uint16_t>(type << 12 | (payload & 0xFFF)));
  }
  void flush();
  void write_header(std::int64_t offset_us);

  std::string path_;
  int width_, height_;
  std::ofstream out_;
  std::vector<std::uint16_t> words_;
  bool started_ = false, closed_ = false, have_y_ = false;
  std::int64_t first_us_ = 0;
  std::int64_t high_us_ = 0;   ///< start of the current 4096 µs period, relative
  std::int64_t time_us_ = -1;  ///< last TIME_LOW written, relative
  unsigned y_ = 0;
  std::uint64_t count_ = 0, floored_ = 0;
};

}  // namespace fdv
