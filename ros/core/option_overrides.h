#pragma once
/// The PerceptionOptions a node asks for: its options file with the node's single-key overrides
/// set over it (C++20, not for the ROS node). A pure function: safe to call from any thread.
#include "fdv/pipeline/perception.h"
#include "node_core.h"

namespace fdv::ros_core {

/// NodeConfig::options_file with each of NodeConfig::option_overrides set on its key
/// ("section.key" or a top-level "key"). Throws InputError / ConfigError naming the key at fault.
PerceptionOptions load_options(const NodeConfig& config);

}  // namespace fdv::ros_core
