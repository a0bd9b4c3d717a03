#pragma once
// Reader options every command that opens a recording offers (ROS bag topic choice, sensor size).
#include <CLI/CLI.hpp>
#include <charconv>
#include <string>

#include "fdv/io/recording.h"

namespace fdv::cli {

inline void add_reader_flags(CLI::App* cmd, ReaderOptions& o) {
  cmd->add_option("--events-topic", o.events_topic, "ROS bag: events topic (default: by type, /dvs/events first)");
  cmd->add_option("--imu-topic", o.imu_topic, "ROS bag: IMU topic (default: by type, /mavros/imu/data first)");
  cmd->add_option("--depth-topic", o.depth_topic,
                  "ROS bag: depth image topic (default: by type, /camera/depth/image_rect_raw first)");
  cmd->add_option("--odometry-topic", o.odometry_topic, "ROS bag: odometry topic (default: by type)");
  cmd->add_option("--ground-truth-topic", o.ground_truth_topic, "ROS bag: motion-capture pose topic");
  cmd->add_option_function<std::string>(
      "--resolution",
      [&o](const std::string& s) {
        const auto x = s.find('x');
        const auto side = [&](std::string_view v, int& out) {
          const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
          return ec == std::errc() && p == v.data() + v.size() && out >= 1 && out <= 65535;
        };
        if (x == std::string::npos || !side(std::string_view(s).substr(0, x), o.width) ||
            !side(std::string_view(s).substr(x + 1), o.height))
          throw CLI::ValidationError("--resolution", "expected WIDTHxHEIGHT (e.g. 640x480), got '" + s + "'");
      },
      "sensor size WxH for files that do not give it (HDF5 in the DSEC layout)");
}

}  // namespace fdv::cli
