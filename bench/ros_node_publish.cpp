// Compiled as C++17: see ros_node_publish.h.
#include "ros_node_publish.h"

#include <ros/serialization.h>

#include <vector>

#include "result_messages.h"

namespace fdv::bench {
namespace {

template <class M>
std::uint64_t serialize(const M& message) {
  static std::vector<std::uint8_t> buffer;
  const std::uint32_t size = ros::serialization::serializationLength(message);
  buffer.resize(size);
  ros::serialization::OStream out(buffer.data(), size);
  ros::serialization::serialize(out, message);
  return size;
}

}  // namespace

ros_core::NodeOutputs serializing_outputs(std::uint64_t& bytes) {
  using namespace ros_node;
  ros_core::NodeOutputs o;
  o.on_window = [&bytes](const ros_core::WindowOutput& w) {
    bytes += serialize(window_message(w, "event_camera")) + serialize(tracks_message(w, "event_camera"));
  };
  o.on_estimate = [&bytes](const nlohmann::json& r) {
    bytes += serialize(estimate_message(r, "world"));
    if (r.at("method") != "fusion" || !r.at("usable").get<bool>()) return;
    const nav_msgs::Path path = path_message(r, "world");
    bytes += serialize(path) + serialize(markers_message(path, r.at("track"), 0.5));
  };
  o.on_prediction = [&bytes](const nlohmann::json& r) { bytes += serialize(prediction_message(r, "world")); };
  o.on_dodge = [&bytes](const nlohmann::json& r) { bytes += serialize(dodge_message(r, "world")); };
  o.on_warning = [](const std::string&, const std::string&) {};
  return o;
}

}  // namespace fdv::bench
