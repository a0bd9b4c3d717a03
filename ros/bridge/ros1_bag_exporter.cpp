// BagExporter forwards to the plugin that writes the bag (ros1_export_plugin_api.h).
#include "fdv/io/format_plugin.h"
#include "ros/bridge/ros1_bag_export.h"
#include "ros/bridge/ros1_export_plugin_api.h"

namespace fdv::ros1 {

BagExporter::BagExporter(const std::string& path, const BagExportOptions& options) {
  const auto& api = *static_cast<const ExportPluginApi*>(load_plugin_api(kExportPluginName, kExportPluginEntry, path));
  backend_ = api.create(path, options);
}

BagExporter::~BagExporter() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; close() explicitly to see errors
  }
}

void BagExporter::add_events(const EventRecord* events, std::size_t n) { backend_->add_events(events, n); }
void BagExporter::add_imu(const ImuRecord& imu) { backend_->add_imu(imu); }
std::string BagExporter::add_depth(const DepthRecord& depth) { return backend_->add_depth(depth); }
void BagExporter::add_odometry(const OdometryRecord& odometry) { backend_->add_odometry(odometry); }
void BagExporter::close() { backend_->close(); }
std::vector<TopicCount> BagExporter::topics() const { return backend_->topics(); }

}  // namespace fdv::ros1
