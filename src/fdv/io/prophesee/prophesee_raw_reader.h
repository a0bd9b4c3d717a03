#pragma once
/// Prophesee RAW files (Metavision `.raw`): a `% key value` text header, then EVT 2.0 or EVT 3.0
/// encoded events (docs/FORMATS.md, "Prophesee RAW (EVT 2.0 / EVT 3.0)").
///
///   auto reader = fdv::open_prophesee_raw("street.raw");   // or fdv::open_recording(...)
///   fdv::SensorChunk chunk;
///   while (reader->read(chunk)) { /* chunk.events, t in ns on the camera clock */ }
///
/// The header names the encoding (`% evt 2.0|3.0`, or `% format EVT2|EVT3;...`) and the sensor
/// size (`% geometry WxH`, `% format ...;height=H;width=W`, or `% width` + `% height`). Older
/// headers carry neither: the encoding and size are then taken from `plugin_name` (Gen3 sensors
/// record EVT 2.0 at 640x480; Gen4 / IMX636 sensors EVT 3.0 at 1280x720), and a header that
/// allows neither is rejected with InputError. The file is read a fixed-size buffer at a time;
/// the decoder keeps its state across buffers. External triggers and vendor words are skipped
/// and counted in info().notes, which is complete once read() has returned false.
/// Not thread-safe.
#include <cstddef>
#include <istream>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "fdv/io/recording.h"

namespace fdv {

struct PropheseeRawOptions {
  /// Bytes read from the file per refill. A multiple of 4 (whole EVT 2.0 / EVT 3.0 words);
  /// 64 KiB keeps the buffer in L2 cache while making system calls negligible.
  std::size_t read_buffer_bytes = 64 * 1024;
  /// Empty when valid, else a readable reason.
  std::string validate() const;
};

/// The parsed text header of a RAW file.
struct RawHeader {
  std::map<std::string, std::string> keys;  ///< keyword (lower case) -> value, as written
  std::size_t data_offset = 0;              ///< byte where the event data starts
  std::string encoding;                     ///< "evt2" or "evt3"
  std::string encoding_source;              ///< which header line decided the encoding
  int width = 0;
  int height = 0;
  std::string geometry_source;  ///< which header line decided the sensor size
};

/// True when `head` (the first bytes of a file) starts like a Prophesee RAW header ("% ").
bool looks_like_prophesee_raw(std::string_view head);

/// Reads and interprets the header of `path`. Throws InputError (file, "byte N" or "key K",
/// reason) for an unterminated header, an unsupported encoding (EVT 2.1, a DAT file), or when
/// neither the encoding nor the sensor size can be determined.
/// Header values are kept as written (any bytes); escape them (escape_non_utf8) before printing.
RawHeader read_prophesee_raw_header(const std::string& path);
/// As above, reading `in` from its current position (the file's first byte); `name` stands for
/// the file in errors.
RawHeader read_prophesee_raw_header(std::istream& in, const std::string& name);

/// Header values that reach info().notes are passed through escape_non_utf8 (valid UTF-8).
std::unique_ptr<RecordingReader> open_prophesee_raw(const std::string& path,
                                                    const ReaderOptions& options = {},
                                                    const PropheseeRawOptions& raw_options = {});
/// As above, reading from `in` (which must be seekable, the file's first byte at position 0);
/// `name` stands for the file in errors and in info().path.
std::unique_ptr<RecordingReader> open_prophesee_raw(std::unique_ptr<std::istream> in,
                                                    const std::string& name,
                                                    const ReaderOptions& options = {},
                                                    const PropheseeRawOptions& raw_options = {});

}  // namespace fdv
