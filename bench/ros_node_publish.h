#pragma once
// The ROS side of fdv_ros_node's work per result, without a ROS master: each row turned into its
// message and serialized, as roscpp does before handing the bytes to its sockets. ROS-free
// header; the implementation is C++17 (ROS 1's generated headers).
#include <cstdint>

#include "node_core.h"

namespace fdv::bench {

/// Outputs that build and serialize every message the node publishes; `bytes` counts them.
ros_core::NodeOutputs serializing_outputs(std::uint64_t& bytes);

}  // namespace fdv::bench
