#pragma once
/// Between fdv::io and the ROS 1 bag plugin (libfdv_ros1.so; format_plugin.h): the table of
/// entry points the plugin exports as `fdv_ros1_plugin_api`. Internal to src/fdv/io/rosbag.
#include <memory>
#include <string>

#include "fdv/io/recording.h"

namespace fdv::ros1 {

struct PluginApi {
  std::unique_ptr<RecordingReader> (*open)(const std::string& path, const ReaderOptions& options);
  std::unique_ptr<RecordingReader> (*open_bytes)(const std::string& bytes, const std::string& name,
                                                 const ReaderOptions& options);
};
inline constexpr const char* kPluginName = "ros1";
inline constexpr const char* kPluginEntry = "fdv_ros1_plugin_api";

/// The implementations, in the plugin (and linked directly by the fuzz target).
std::unique_ptr<RecordingReader> open_reader(const std::string& path, const ReaderOptions& options);
std::unique_ptr<RecordingReader> open_reader_bytes(const std::string& bytes, const std::string& name,
                                                   const ReaderOptions& options);

}  // namespace fdv::ros1
