#pragma once
/// Reader for iniVation's AEDAT 4.0 recordings (DV software, DAVIS / DVXplorer cameras).
///
///   auto reader = fdv::open_aedat4("run.aedat4");          // or fdv::open_recording(...)
///   fdv::SensorChunk chunk;
///   while (reader->read(chunk)) { /* chunk.events (ns, px), chunk.imu (rad/s, m/s^2) */ }
///   reader->info().notes;   // compression, skipped frame / trigger packets (complete at the end)
///   reader->report();       // dropped packets and records, with the first byte offset of each
///
/// Layout (docs/FORMATS.md, "AEDAT 4.0"): the magic "#!AER-DAT4.0\r\n", a size-prefixed IOHeader
/// FlatBuffer (compression, data-table position, XML stream description), then packets of
/// {int32 stream id, int32 payload size, payload}; each payload is one LZ4 / Zstd frame (or raw)
/// holding a size-prefixed FlatBuffer of the stream's type (EVTS events, IMUS inertial samples;
/// FRME frames and TRIG triggers are skipped). The packet index at the end of the file is never
/// used: the reader walks the packets one at a time, so a file cut short or with a damaged index
/// reads up to the damage.
///
/// Units: event and IMU times become int64 nanoseconds (Unix epoch, as recorded, never shifted);
/// accelerometer g -> m/s^2 (x 9.80665), gyroscope deg/s -> rad/s. Pixel (x, y) as recorded.
///
/// Pitfalls: only the first events stream and the first IMU stream of a file are read (a second
/// camera's streams are noted as skipped). RecordingInfo::notes counts skipped packets so far;
/// the counts are final once read() has returned false. Not thread-safe.
#include <cstddef>
#include <istream>
#include <memory>
#include <string>
#include <string_view>

#include "fdv/io/aedat4/aedat4_format.h"
#include "fdv/io/recording.h"

namespace fdv {

/// Largest events or IMU packet the reader decodes [bytes, after decompression]: about 370x the
/// largest packet of the real recordings (172 KiB, 11,020 events), room for 4 M events (25 ms of
/// a DVXplorer at its 165 Mev/s peak). A larger packet (a decompression bomb) is dropped and
/// counted; its stored payload may exceed this by the codecs' worst-case expansion (1/128).
inline constexpr std::size_t kAedat4MaxPacketBytes = std::size_t{64} << 20;

/// Opens an AEDAT 4.0 file. Throws InputError (file, "byte N", reason) when the file cannot be
/// opened, the magic is wrong, the header is truncated or not a valid IOHeader FlatBuffer, the
/// compression is unknown, or the XML stream description is unusable.
std::unique_ptr<RecordingReader> open_aedat4(const std::string& path,
                                             const ReaderOptions& options = {});

/// As above, reading from `in` (which must be seekable: the packets are walked by offset, from
/// the stream's position 0); `name` stands for the file in errors and in info().path.
std::unique_ptr<RecordingReader> open_aedat4(std::unique_ptr<std::istream> in,
                                             const std::string& name,
                                             const ReaderOptions& options = {});

}  // namespace fdv
