// fdv::io's side of ROS 1 bags: forwards to the ROS 1 plugin (ros1_plugin_api.h), so that only a
// program reading a ROS 1 bag loads Debian's rosbag storage and what it brings (roslib, rospack,
// libpython).
#include "fdv/io/format_plugin.h"
#include "fdv/io/rosbag/ros1_plugin_api.h"
#include "fdv/io/rosbag/rosbag_reader.h"

namespace fdv {
namespace {

const ros1::PluginApi& ros1_plugin(const std::string& needed_for) {
  return *static_cast<const ros1::PluginApi*>(load_plugin_api(ros1::kPluginName, ros1::kPluginEntry, needed_for));
}

}  // namespace

std::unique_ptr<RecordingReader> open_ros1_bag(const std::string& path, const ReaderOptions& options) {
  return ros1_plugin(path).open(path, options);
}

std::unique_ptr<RecordingReader> open_ros1_bag_bytes(const std::string& bytes, const std::string& name,
                                                     const ReaderOptions& options) {
  return ros1_plugin(name).open_bytes(bytes, name, options);
}

}  // namespace fdv
