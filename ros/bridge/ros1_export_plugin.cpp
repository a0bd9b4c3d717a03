// The ROS 1 bag export plugin's exports (libfdv_ros1_export.so; fdv/io/format_plugin.h).
#include "fdv/io/format_plugin.h"
#include "ros/bridge/ros1_export_plugin_api.h"

extern "C" __attribute__((visibility("default"))) const char* fdv_plugin_abi() { return fdv::plugin_abi(); }

extern "C" __attribute__((visibility("default"))) const void* fdv_ros1_export_plugin_api() {
  static const fdv::ros1::ExportPluginApi api{&fdv::ros1::create_rosbag_export};
  return &api;
}
