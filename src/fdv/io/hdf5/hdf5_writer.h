#pragma once
/// Writes events as an HDF5 file in Metavision's layout (hdf5_reader.h), which h5py, Metavision's
/// tools and fdv's reader read:
///
///   fdv::Hdf5EventWriter out("run.h5", 640, 480, {.gzip_level = 4});
///   out.add(chunk.events);   // in time order, t in ns
///   out.close();             // flushes; the destructor closes too, without throwing
///
/// `CD/events` {x u16, y u16, p i16, t i64 µs} and `CD/indexes` {id u64, ts i64}: one entry per
/// 2 ms from the first event, naming the first event at or after it and that event's time
/// relative to the first (the attribute `offset` holds minus the first time); the root attribute
/// `geometry` holds "WxH". Times are floored to the microsecond (`floored_events()` counts the
/// events that had a fraction). Not thread-safe.
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "fdv/core/sensor_data.h"

namespace fdv {
namespace hdf5 {
class EventWriterBackend;
}

struct Hdf5WriterOptions {
  int gzip_level = 0;                 ///< 0: uncompressed; 1..9: gzip (built into HDF5)
  std::size_t chunk_rows = 16384;     ///< rows per HDF5 chunk (Metavision's size)
  /// Empty when valid, else a readable reason.
  std::string validate() const;
};

class Hdf5EventWriter {
 public:
  /// Throws InputError when `path` cannot be created, ConfigError for bad options or sizes.
  Hdf5EventWriter(const std::string& path, int width, int height, const Hdf5WriterOptions& options = {});
  ~Hdf5EventWriter();
  Hdf5EventWriter(const Hdf5EventWriter&) = delete;
  Hdf5EventWriter& operator=(const Hdf5EventWriter&) = delete;

  /// Appends events; times must not go backwards across calls (InputError otherwise).
  void add(std::span<const Event> events);
  void close();
  std::uint64_t events() const;
  std::uint64_t floored_events() const;

 private:
  std::unique_ptr<hdf5::EventWriterBackend> backend_;  // in the HDF5 plugin
};

}  // namespace fdv
