#pragma once
/// The node's results as ROS messages: each results row (JSON with the keys of
/// src/fdv/results/schema.h, as NodeCore hands them out) to the fdv_msgs message mirroring it,
/// plus the predicted path and its RViz markers. C++17: it includes ROS 1's generated headers.
///
///   core_outputs.on_window = [&](const WindowOutput& w) { pub.publish(window_message(w, "event_camera")); };
#include <fdv_msgs/CollisionPrediction.h>
#include <fdv_msgs/DodgeDecision.h>
#include <fdv_msgs/TrackStates.h>
#include <fdv_msgs/TrajectoryEstimate.h>
#include <fdv_msgs/WindowDetections.h>
#include <nav_msgs/Path.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>

#include "node_core.h"

namespace fdv::ros_node {

fdv_msgs::WindowDetections window_message(const ros_core::WindowOutput& w, const std::string& frame);
fdv_msgs::TrackStates tracks_message(const ros_core::WindowOutput& w, const std::string& frame);
fdv_msgs::TrajectoryEstimate estimate_message(const nlohmann::json& row, const std::string& frame);
/// The row's "path" as poses (orientation identity: a ball has none).
nav_msgs::Path path_message(const nlohmann::json& row, const std::string& frame);
/// The ball where it is now (a sphere) and its predicted path (a line strip), one pair per track.
visualization_msgs::MarkerArray markers_message(const nav_msgs::Path& path, int track, double lifetime_s);
fdv_msgs::CollisionPrediction prediction_message(const nlohmann::json& row, const std::string& frame);
fdv_msgs::DodgeDecision dodge_message(const nlohmann::json& row, const std::string& frame);

}  // namespace fdv::ros_node
