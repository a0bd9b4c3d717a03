#pragma once
/// Between fdv::io and the HDF5 plugin (libfdv_hdf5.so; format_plugin.h): the table of entry
/// points the plugin exports as `fdv_hdf5_plugin_api`. Internal to src/fdv/io/hdf5.
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "fdv/core/sensor_data.h"
#include "fdv/io/hdf5/hdf5_writer.h"
#include "fdv/io/recording.h"

namespace fdv::hdf5 {

/// What Hdf5EventWriter forwards to; its contract is Hdf5EventWriter's.
class EventWriterBackend {
 public:
  virtual ~EventWriterBackend() = default;
  virtual void add(std::span<const Event> events) = 0;
  virtual void close() = 0;
  virtual std::uint64_t events() const = 0;
  virtual std::uint64_t floored_events() const = 0;
};

struct PluginApi {
  std::unique_ptr<RecordingReader> (*open)(const std::string& path, const ReaderOptions& options);
  std::unique_ptr<RecordingReader> (*open_image)(std::string image, const std::string& name,
                                                 const ReaderOptions& options);
  /// Options and sizes are checked by the caller.
  std::unique_ptr<EventWriterBackend> (*create_writer)(const std::string& path, int width, int height,
                                                       const Hdf5WriterOptions& options);
};
inline constexpr const char* kPluginName = "hdf5";
inline constexpr const char* kPluginEntry = "fdv_hdf5_plugin_api";

/// The implementations, in the plugin (and linked directly by the fuzz target and the tests).
std::unique_ptr<RecordingReader> open_reader(const std::string& path, const ReaderOptions& options);
std::unique_ptr<RecordingReader> open_reader_image(std::string image, const std::string& name,
                                                   const ReaderOptions& options);
std::unique_ptr<EventWriterBackend> create_writer(const std::string& path, int width, int height,
                                                  const Hdf5WriterOptions& options);

}  // namespace fdv::hdf5
