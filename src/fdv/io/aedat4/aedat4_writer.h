#pragma once
/// Writes events and IMU samples as an AEDAT 4.0 file (iniVation DV), which DV, dv-processing and
/// fdv's reader read (docs/FORMATS.md, "AEDAT 4.0"):
///
///   fdv::Aedat4Writer out("run.aedat4", 346, 260);   // LZ4 packets, as DV records
///   out.add(chunk.events);   // in time order, t in ns
///   out.add(chunk.imu);      // in time order
///   out.close();             // the destructor closes too, without throwing
///
/// Layout: the magic, a size-prefixed IOHeader (compression, no packet index: data table
/// position -1, which readers answer by walking the packets), then one packet per add() call of
/// at most kAedat4WriterPacketEvents events or IMU samples. Stream 0 is "events" (EVTS, with
/// sizeX / sizeY), stream 1 "imu" (IMUS). Times are Unix or recording time in microseconds,
/// floored (`floored_times()` counts the events and samples that had a fraction); accelerations
/// in g, angular rates in deg/s; the temperature and magnetometer, which fdv does not have, are
/// NaN. Not thread-safe.
#include <cstdint>
#include <fstream>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/sensor_data.h"
#include "fdv/io/aedat4/aedat4_format.h"

namespace fdv {

/// Most events (or IMU samples) in one packet: about 10 ms of a DAVIS346 in a busy scene, the
/// size DV's recorder writes.
inline constexpr std::size_t kAedat4WriterPacketEvents = 8192;

class Aedat4Writer {
 public:
  /// `compression`: kNone, kLz4 or kZstd. Throws ConfigError for a sensor AEDAT 4.0's int16
  /// coordinates cannot address or another compression, InputError when `path` cannot be created.
  Aedat4Writer(const std::string& path, int width, int height,
               Aedat4Compression compression = Aedat4Compression::kLz4);
  ~Aedat4Writer();
  Aedat4Writer(const Aedat4Writer&) = delete;
  Aedat4Writer& operator=(const Aedat4Writer&) = delete;

  /// Appends events; times must not go backwards across calls (InputError otherwise).
  void add(std::span<const Event> events);
  /// Appends IMU samples; times must not go backwards across calls (InputError otherwise).
  void add(std::span<const ImuSample> imu);
  void close();
  std::uint64_t events() const { return events_; }
  std::uint64_t imu_samples() const { return imu_; }
  /// Events and IMU samples whose time had a fraction of a microsecond.
  std::uint64_t floored_times() const { return floored_; }

 private:
  /// Writes {stream id, payload size, payload} for a size-prefixed FlatBuffer.
  void write_packet(std::int32_t stream, std::span<const std::uint8_t> flatbuffer);
  std::int64_t checked_us(TimeNs t, TimeNs& last, std::uint64_t index, const char* what);

  std::string path_;
  int width_, height_;
  Aedat4Compression compression_;
  std::ofstream out_;
  std::vector<std::uint8_t> packed_;
  bool closed_ = false;
  TimeNs last_event_t_ = std::numeric_limits<TimeNs>::min(), last_imu_t_ = last_event_t_;
  std::uint64_t events_ = 0, imu_ = 0, floored_ = 0;
};

}  // namespace fdv
