#pragma once
/// Between BagExporter and the plugin that writes the bag (libfdv_ros1_export.so;
/// fdv/io/format_plugin.h). Includes nothing of ROS: the plugin's implementation is C++17, the
/// rest C++20.
#include <memory>
#include <string>
#include <vector>

#include "ros/bridge/ros1_bag_export.h"

namespace fdv::ros1 {

/// What BagExporter forwards to; its contract is BagExporter's.
class BagExportBackend {
 public:
  virtual ~BagExportBackend() = default;
  virtual void add_events(const EventRecord* events, std::size_t n) = 0;
  virtual void add_imu(const ImuRecord& imu) = 0;
  virtual std::string add_depth(const DepthRecord& depth) = 0;
  virtual void add_odometry(const OdometryRecord& odometry) = 0;
  virtual void close() = 0;
  virtual std::vector<TopicCount> topics() const = 0;
};

struct ExportPluginApi {
  std::unique_ptr<BagExportBackend> (*create)(const std::string& path, const BagExportOptions& options);
};
inline constexpr const char* kExportPluginName = "ros1_export";
inline constexpr const char* kExportPluginEntry = "fdv_ros1_export_plugin_api";

/// The implementation, in the plugin.
std::unique_ptr<BagExportBackend> create_rosbag_export(const std::string& path, const BagExportOptions& options);

}  // namespace fdv::ros1
