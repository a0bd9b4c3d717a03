#pragma once
// Reader options every command that opens a recording offers (ROS bag topic choice).
#include <CLI/CLI.hpp>

#include "fdv/io/recording.h"

namespace fdv::cli {

inline void add_reader_flags(CLI::App* cmd, ReaderOptions& o) {
  cmd->add_option("--events-topic", o.events_topic, "ROS bag: events topic (default: by type, /dvs/events first)");
  cmd->add_option("--imu-topic", o.imu_topic, "ROS bag: IMU topic (default: by type, /mavros/imu/data first)");
  cmd->add_option("--depth-topic", o.depth_topic,
                  "ROS bag: depth image topic (default: by type, /camera/depth/image_rect_raw first)");
  cmd->add_option("--odometry-topic", o.odometry_topic, "ROS bag: odometry topic (default: by type)");
  cmd->add_option("--ground-truth-topic", o.ground_truth_topic, "ROS bag: motion-capture pose topic");
}

}  // namespace fdv::cli
