#include "option_overrides.h"

#include <yaml-cpp/yaml.h>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/pipeline/options_yaml.h"

namespace fdv::ros_core {

PerceptionOptions load_options(const NodeConfig& config) {
  const std::string name = config.options_file.empty() ? "(node parameters)" : config.options_file;
  YAML::Node root =
      config.options_file.empty()
          ? YAML::Node(YAML::NodeType::Map)
          : parse_config_yaml(read_config_file(config.options_file), config.options_file);
  if (!root.IsMap() && !root.IsNull()) throw InputError(name, "", "the options must be a mapping");
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  for (const auto& [key, value] : config.option_overrides) {
    const auto dot = key.find('.');
    const YAML::Node scalar = parse_config_yaml(value, "parameter " + key);
    if (dot == std::string::npos)
      root[key] = scalar;
    else
      root[key.substr(0, dot)][key.substr(dot + 1)] = scalar;
  }
  return load_perception_options(root, name);
}

}  // namespace fdv::ros_core
