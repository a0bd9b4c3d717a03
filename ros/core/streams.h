#pragma once
/// The node's streams as the pieces of NodeCore's implementation share them (C++20, not for the
/// ROS node). Pure helpers: safe to call from any thread.
#include <array>
#include <cstddef>
#include <functional>
#include <string>

#include "fdv/io/recording.h"
#include "node_core.h"

namespace fdv::ros_core {

/// In StreamKind's order, which is also the order of ties in the time order.
inline constexpr std::array<Stream, 4> kStreams = {Stream::kEvents, Stream::kImu, Stream::kDepth,
                                                   Stream::kOdometry};

inline std::size_t index(Stream s) { return static_cast<std::size_t>(s); }

inline StreamKind kind(Stream s) {
  switch (s) {
    case Stream::kEvents:
      return StreamKind::kEvents;
    case Stream::kImu:
      return StreamKind::kImu;
    case Stream::kDepth:
      return StreamKind::kDepth;
    case Stream::kOdometry:
      return StreamKind::kOdometry;
  }
  return StreamKind::kEvents;
}

/// Whether the node subscribes to `s` (the sensors declared to the sensor policy).
inline bool subscribed(const NodeConfig& config, Stream s) {
  switch (s) {
    case Stream::kEvents:
      return true;
    case Stream::kImu:
      return config.imu;
    case Stream::kDepth:
      return config.depth;
    case Stream::kOdometry:
      return config.odometry;
  }
  return false;
}

/// NodeOutputs::on_warning's signature: `key` names the cause, for throttling.
using Warn = std::function<void(const std::string& key, const std::string& message)>;

}  // namespace fdv::ros_core
