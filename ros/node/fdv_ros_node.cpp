// fdv_ros_node: the perception pipeline on live ROS 1 topics (README "ROS 1 node").
//
//   rosrun fdv_ros fdv_ros_node _calibration:=rig.yaml _config:=options.yaml
//
// Subscribes to events (dvs_msgs/EventArray or event_camera_msgs/EventPacket), sensor_msgs/Imu,
// depth sensor_msgs/Image and nav_msgs/Odometry as raw bytes (topic_tools::ShapeShifter), which
// NodeCore decodes with the bag readers' decoders, and publishes its results under ~. This file
// is C++17 (ROS 1's generated headers are not C++20) and holds only the ROS plumbing: parameters,
// subscriptions, JSON rows to messages, markers, diagnostics.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "node_core.h"
#include "result_messages.h"

namespace {

using fdv::ros_core::NodeConfig;
using fdv::ros_core::NodeCore;
using fdv::ros_core::NodeOutputs;
using fdv::ros_core::Stream;
using nlohmann::json;
using fdv::ros_node::dodge_message;
using fdv::ros_node::estimate_message;
using fdv::ros_node::markers_message;
using fdv::ros_node::path_message;
using fdv::ros_node::prediction_message;
using fdv::ros_node::tracks_message;
using fdv::ros_node::window_message;

/// A parameter value as the YAML scalar (or flow sequence) the options loader reads.
std::string yaml_text(XmlRpc::XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(v) ? "true" : "false";
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble: {
      char buffer[32];
      std::snprintf(buffer, sizeof buffer, "%.17g", static_cast<double>(v));
      return buffer;
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return "\"" + static_cast<std::string>(v) + "\"";
    case XmlRpc::XmlRpcValue::TypeArray: {
      std::string s = "[";
      for (int i = 0; i < v.size(); ++i) s += (i ? ", " : "") + yaml_text(v[i]);
      return s + "]";
    }
    default:
      throw std::runtime_error("parameter of a type the options cannot take");
  }
}

/// ~options/<section>/<key> and ~options/<key> as ("section.key", value) overrides.
std::vector<std::pair<std::string, std::string>> option_overrides(const ros::NodeHandle& private_nh) {
  std::vector<std::pair<std::string, std::string>> out;
  XmlRpc::XmlRpcValue options;
  if (!private_nh.getParam("options", options)) return out;
  if (options.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    throw std::runtime_error("~options must be a dictionary of option keys");
  for (auto& [key, value] : options) {
    if (value.getType() == XmlRpc::XmlRpcValue::TypeStruct) {
      for (auto& [inner, inner_value] : value) out.emplace_back(key + "." + inner, yaml_text(inner_value));
    } else {
      out.emplace_back(key, yaml_text(value));
    }
  }
  return out;
}

class FdvRosNode {
 public:
  FdvRosNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
    NodeConfig config;
    config.options_file = pnh_.param<std::string>("config", "");
    config.option_overrides = option_overrides(pnh_);
    config.calibration_file = pnh_.param<std::string>("calibration", "");
    config.width = pnh_.param("width", 0);
    config.height = pnh_.param("height", 0);
    config.wait_for_depth = pnh_.param("wait_for_depth", false);
    config.max_hold_s = pnh_.param("max_hold_s", config.max_hold_s);
    config.missing_after_s = pnh_.param("missing_after_s", config.missing_after_s);
    config.path_horizon_s = pnh_.param("path_horizon_s", config.path_horizon_s);
    const std::map<Stream, std::string> topics = {
        {Stream::kEvents, pnh_.param<std::string>("events_topic", "/dvs/events")},
        {Stream::kImu, pnh_.param<std::string>("imu_topic", "/mavros/imu/data")},
        {Stream::kDepth, pnh_.param<std::string>("depth_topic", "/camera/depth/image_rect_raw")},
        {Stream::kOdometry, pnh_.param<std::string>("odometry_topic", "/mavros/local_position/odom")}};
    config.imu = !topics.at(Stream::kImu).empty();
    config.depth = !topics.at(Stream::kDepth).empty();
    config.odometry = !topics.at(Stream::kOdometry).empty();
    camera_frame_ = pnh_.param<std::string>("camera_frame", "event_camera");
    world_frame_ = pnh_.param<std::string>("world_frame", "world");
    idle_finish_s_ = pnh_.param("idle_finish_s", 2.0);
    queue_ = pnh_.param("queue_size", 10000);
    topics_ = topics;

    NodeOutputs outputs;
    outputs.on_window = [this](const fdv::ros_core::WindowOutput& w) {
      detections_.publish(window_message(w, camera_frame_));
      tracks_.publish(tracks_message(w, camera_frame_));
    };
    outputs.on_estimate = [this](const json& r) {
      estimates_.publish(estimate_message(r, world_frame_));
      if (r.at("method") != "fusion" || !r.at("usable").get<bool>()) return;
      const nav_msgs::Path path = path_message(r, world_frame_);
      paths_.publish(path);
      markers_.publish(markers_message(path, r.at("track"), 0.5));
    };
    outputs.on_prediction = [this](const json& r) { predictions_.publish(prediction_message(r, world_frame_)); };
    outputs.on_dodge = [this](const json& r) { dodge_.publish(dodge_message(r, world_frame_)); };
    outputs.on_warning = [](const std::string& key, const std::string& message) {
      // One throttle per cause: a flood of one kind of drop does not hide another kind.
      static std::map<std::string, ros::WallTime> last;
      const ros::WallTime now = ros::WallTime::now();
      auto it = last.find(key);
      if (it != last.end() && (now - it->second).toSec() < 5.0) return;
      last[key] = now;
      ROS_WARN_STREAM("fdv: " << message);
    };
    core_ = std::make_unique<NodeCore>(config, std::move(outputs));
    connect();
    for (const auto& [stream, topic] : topics_)
      if (!topic.empty()) ROS_INFO_STREAM("fdv: " << fdv::ros_core::to_string(stream) << " from " << topic);
    // Wall clock only for the plumbing: the master's watch and diagnostics once a second, and the
    // end of input (nothing received for idle_finish_s: the last window is closed, as at a
    // recording's end).
    timer_ = nh_.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { tick(); });
  }

  void finish() {
    if (pending_) core_->finish();
    pending_ = false;
    publish_diagnostics();
  }

 private:
  void receive(Stream stream, const topic_tools::ShapeShifter& msg) {
    buffer_.resize(msg.size());
    ros::serialization::OStream out(buffer_.data(), static_cast<std::uint32_t>(buffer_.size()));
    msg.write(out);
    core_->push(stream, msg.getDataType(), buffer_.data(), buffer_.size());
    last_message_ = ros::WallTime::now();
    pending_ = true;
  }

  /// Advertises the outputs and subscribes to the inputs, registering each with the master; what
  /// was registered before is shut down first (advertising a topic still advertised would only
  /// add a reference, and register nothing with a restarted master).
  void connect() {
    subscribers_.clear();
    for (ros::Publisher* p : {&detections_, &tracks_, &estimates_, &paths_, &predictions_, &dodge_, &markers_, &diagnostics_})
      p->shutdown();
    detections_ = pnh_.advertise<fdv_msgs::WindowDetections>("detections", 100);
    tracks_ = pnh_.advertise<fdv_msgs::TrackStates>("tracks", 100);
    estimates_ = pnh_.advertise<fdv_msgs::TrajectoryEstimate>("estimates", 100);
    paths_ = pnh_.advertise<nav_msgs::Path>("predicted_path", 100);
    predictions_ = pnh_.advertise<fdv_msgs::CollisionPrediction>("collision", 100);
    dodge_ = pnh_.advertise<fdv_msgs::DodgeDecision>("dodge", 100);
    markers_ = pnh_.advertise<visualization_msgs::MarkerArray>("markers", 100);
    diagnostics_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
    for (const auto& [stream, topic] : topics_) {
      if (topic.empty()) continue;
      const Stream s = stream;
      subscribers_.push_back(nh_.subscribe<topic_tools::ShapeShifter>(
          topic, static_cast<std::uint32_t>(queue_),
          [this, s](const topic_tools::ShapeShifter::ConstPtr& msg) { receive(s, *msg); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
    }
  }

  /// roscpp registers with the master only when a node advertises or subscribes: after a
  /// master's restart the node would be unknown to it, alive and silent. So the master is checked
  /// every tick: gone, an ERROR in the log (repeated every 10 s) and in /diagnostics (to the
  /// subscribers still connected); back, every publisher and subscriber is registered anew.
  void watch_master() {
    const bool up = ros::master::check();
    if (!up) {
      if (master_up_)
        ROS_ERROR_STREAM("fdv: lost the ROS master at " << ros::master::getURI()
                         << ": cut off from new publishers and subscribers until it is back (checked every second)");
      else
        ROS_ERROR_STREAM_THROTTLE(10.0, "fdv: still cut off: no ROS master at " << ros::master::getURI());
    } else if (!master_up_) {
      connect();
      ++master_returns_;
      ROS_WARN_STREAM("fdv: the ROS master at " << ros::master::getURI()
                      << " is back: publishers and subscribers registered again");
    }
    master_up_ = up;
  }

  void tick() {
    watch_master();
    if (pending_ && (ros::WallTime::now() - last_message_).toSec() > idle_finish_s_) {
      ROS_INFO("fdv: no input for %.1f s: end of input, last window closed", idle_finish_s_);
      finish();
      return;
    }
    publish_diagnostics();
  }

  void publish_diagnostics() {
    const json d = core_->diagnostics();
    diagnostic_msgs::DiagnosticArray array;
    array.header.stamp = ros::Time::now();
    diagnostic_msgs::DiagnosticStatus status;
    status.name = "fdv: perception";
    status.hardware_id = "event camera";
    status.level = diagnostic_msgs::DiagnosticStatus::OK;
    status.message = "running";
    auto add = [&](const std::string& key, const json& value) {
      diagnostic_msgs::KeyValue kv;
      kv.key = key;
      kv.value = value.is_string() ? value.get<std::string>() : value.dump();
      status.values.push_back(kv);
    };
    for (const auto& [stream, h] : d.at("streams").items()) {
      for (const auto& [key, value] : h.items()) add(stream + "." + key, value);
      if (h.at("missing").get<bool>() || h.at("dropped").get<std::uint64_t>() > 0) {
        status.level = diagnostic_msgs::DiagnosticStatus::WARN;
        status.message = "streams missing or messages dropped (see the values)";
      }
    }
    if (!master_up_) {
      status.level = diagnostic_msgs::DiagnosticStatus::ERROR;
      status.message = "cut off: no ROS master at " + ros::master::getURI();
    }
    add("master_returns", json(master_returns_));
    add("windows", d.at("windows"));
    add("runs", d.at("runs"));
    if (d.contains("latency_ms"))
      for (const auto& [key, value] : d.at("latency_ms").items()) add("latency_ms." + key, value);
    if (d.contains("pipeline"))
      for (const auto& [key, value] : d.at("pipeline").items()) add("pipeline." + key, value);
    add("dropped_by_reason", d.at("dropped_by_reason"));
    array.status.push_back(status);
    diagnostics_.publish(array);
  }

  ros::NodeHandle nh_, pnh_;
  std::unique_ptr<NodeCore> core_;
  std::map<Stream, std::string> topics_;
  int queue_ = 10000;
  bool master_up_ = true;
  std::uint64_t master_returns_ = 0;  ///< times the master came back after being lost
  std::vector<ros::Subscriber> subscribers_;
  ros::Publisher detections_, tracks_, estimates_, paths_, predictions_, dodge_, markers_, diagnostics_;
  ros::WallTimer timer_;
  std::string camera_frame_, world_frame_;
  double idle_finish_s_ = 2.0;
  std::vector<std::uint8_t> buffer_;
  ros::WallTime last_message_;
  bool pending_ = false;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "fdv_ros_node");
  // Held for the whole of main: ROS shuts down (and stops logging) when the last handle goes.
  ros::NodeHandle nh, private_nh("~");
  try {
    FdvRosNode node(nh, private_nh);
    ros::spin();
    node.finish();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("fdv: " << e.what());
    return 1;
  }
  return 0;
}
