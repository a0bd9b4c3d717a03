// The ROS 1 bag plugin's exports (libfdv_ros1.so; fdv/io/format_plugin.h).
#include "fdv/io/format_plugin.h"
#include "fdv/io/rosbag/ros1_plugin_api.h"

extern "C" __attribute__((visibility("default"))) const char* fdv_plugin_abi() { return fdv::plugin_abi(); }

extern "C" __attribute__((visibility("default"))) const void* fdv_ros1_plugin_api() {
  static const fdv::ros1::PluginApi api{&fdv::ros1::open_reader, &fdv::ros1::open_reader_bytes};
  return &api;
}
