#pragma once
/// HDF5 event files, in the two layouts users hold (docs/FORMATS.md, "HDF5 events"):
///  - Metavision (`metavision_file_to_hdf5`, and fdv's own writer): the compound table
///    `CD/events` {x u16, y u16, p i16, t i64 [µs]} with its index `CD/indexes` {id, ts}, the
///    sensor size in the root attribute `geometry` ("WxH");
///  - DSEC: the datasets `events/x`, `events/y`, `events/t` [µs], `events/p`, the index
///    `ms_to_idx` (first event of each millisecond) and `t_offset` [µs] added to every `t`.
///
///   auto reader = fdv::open_recording("street.h5");   // or fdv::open_hdf5(...)
///   fdv::SensorChunk chunk;
///   while (reader->read(chunk)) { /* chunk.events, t in ns */ }
///
/// The tables are read `ReaderOptions::chunk_events` rows at a time (never the whole file).
/// Datasets compressed with gzip, or a filter whose plugin HDF5 finds, are decoded by HDF5;
/// when HDF5_PLUGIN_PATH is unset, Debian's plugin folder is searched (hdf5_support.h). The index
/// is checked against the table as the table streams past: an entry that disagrees is an
/// InputError (file, dataset, entry, reason), as is a missing or mistyped dataset, an
/// unavailable filter (Prophesee's ECF: how to get a readable file) and a damaged file.
/// Sensor size: the file's `geometry` (or `width` / `height`) attribute, else
/// ReaderOptions::width/height (`--resolution WxH`), else InputError.
/// Polarity other than 0 / 1, negative pixels and times beyond the int64 ns range are dropped
/// and counted. Not thread-safe (one reader per thread; HDF5 itself is built thread-safe).
#include <memory>
#include <string>
#include <string_view>

#include "fdv/io/recording.h"

namespace fdv {

/// The HDF5 signature, at byte 0 of files written by h5py, Metavision and fdv.
inline constexpr std::string_view kHdf5Magic{"\x89HDF\r\n\x1a\n", 8};

bool looks_like_hdf5(std::string_view head);

std::unique_ptr<RecordingReader> open_hdf5(const std::string& path, const ReaderOptions& options = {});
/// As above, from a whole file held in memory (the fuzz target); `name` stands for the file in
/// errors and in info().path.
std::unique_ptr<RecordingReader> open_hdf5_image(std::string image, const std::string& name,
                                                 const ReaderOptions& options = {});

}  // namespace fdv
