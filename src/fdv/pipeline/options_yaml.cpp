#include "fdv/pipeline/options_yaml.h"

#include <yaml-cpp/yaml.h>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/core/options_json.h"
#include "fdv/core/options_yaml.h"
#include "fdv/detection/detector.h"

namespace fdv {
namespace {

/// Visits the top level of a field list: its scalar keys go to `scalars`, each section to `on_section`.
template <class Scalars, class OnSection>
struct TopLevel {
  Scalars& scalars;
  OnSection on_section;
  template <class T>
  void operator()(const char* key, T& value, std::string_view unit = {}, std::string_view meaning = {}) {
    scalars(key, value, unit, meaning);
  }
  void ms(const char* key, TimeNs& ns, std::string_view meaning) { scalars.ms(key, ns, meaning); }
  template <class T, class... Check>
  void section(const char* key, T& sub, std::string_view = {}, const Check&...) {
    on_section(key, sub);
  }
  void removed(const char* key, std::string_view why) { scalars.removed(key, why); }
};
// Spelled out for clang 14, which lacks C++20's deduction for aggregates.
template <class Scalars, class OnSection>
TopLevel(Scalars&, OnSection) -> TopLevel<Scalars, OnSection>;

}  // namespace

PerceptionOptions load_perception_options(const YAML::Node& root, const std::string& file) {
  PerceptionOptions o;
  if (!root || root.IsNull()) return o;
  if (!root.IsMap()) throw InputError(file, "", "an options file must be a mapping of keys");
  YamlLoader loader(root, file, {.validate = true});
  yaml_errors_as_input_errors(file, [&] {
    describe(loader, o);
    loader.check_unknown();
  });
  // Every section was validated above; the top-level keys here.
  if (const std::string why = o.validate(); !why.empty()) loader.fail("", loader.with_yaml_names(why));
  return o;
}

PerceptionOptions load_perception_options_text(std::string_view text, const std::string& file) {
  const YAML::Node root = parse_config_yaml(text, file);
  return load_perception_options(root, file);
}

PerceptionOptions load_perception_options_file(const std::string& path) {
  return load_perception_options_text(read_config_file(path), path);
}

std::string to_yaml(const PerceptionOptions& options) { return options_to_yaml(options) + "\n"; }

nlohmann::json to_json(const PerceptionOptions& options) { return options_to_json(options); }

nlohmann::json detector_in_use(const PerceptionOptions& options, const PinholeCamera& event_camera) {
  PerceptionOptions in_use = options;
  in_use.detection = scaled_to_camera(options.detection, event_camera);
  return options_to_json(in_use).at("detector");
}

std::vector<std::string> options_sections() {
  std::vector<std::string> names{""};
  PerceptionOptions o;
  MarkdownTableWriter ignored;
  TopLevel visit{ignored, [&](const char* key, auto&) { names.emplace_back(key); }};
  describe(visit, o);
  return names;
}

std::string options_markdown_table(const std::string& section) {
  PerceptionOptions o;
  MarkdownTableWriter top;
  std::string table;
  TopLevel visit{top, [&](const char* key, auto& sub) {
                   if (key == section) table = options_markdown(sub);
                 }};
  describe(visit, o);
  if (section.empty()) return top.table();
  if (table.empty()) throw ConfigError("no options section '" + section + "'");
  return table;
}

}  // namespace fdv
