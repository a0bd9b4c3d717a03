#pragma once
/// PerceptionOptions in and out of YAML and JSON (what `fdv run --config` reads, `--print-config`
/// prints and summary.json's "options" holds), all from the field lists (fdv/core/field_list.h):
/// describe(v, PerceptionOptions&) in perception.h and one per stage's options beside the struct.
///
///   PerceptionOptions o = load_perception_options_file(path);
///   std::string yaml = to_yaml(o);              // load_perception_options_text(yaml) gives o back
///   nlohmann::json j = to_json(o);              // {"window_ms": 25, ..., "compensation": {...}}
///   std::string table = options_markdown_table("tracking");   // docs' key table of a section
///
/// Rules: a missing (undefined or null) section or key keeps its default; keys are the fields'
/// names except durations, given in ms (`max_gap_ms: 80` fills `max_gap_ns`) and a few renamed
/// ones (estimation `gravity` is gravity_W). An unknown key, a value of the wrong type, a removed
/// key (compensation.threads, compensation.max_events_per_window, estimation.mode: the error says
/// where the option went) or options that fail validate() throw InputError(file,
/// "key <section>.<key>", reason); validate() messages name the YAML keys. No yaml-cpp exception
/// escapes. The key tables are in docs/DETECTION.md and docs/ESTIMATION.md (`fdv options`).
/// Thread safety: pure functions; may be called from any thread.
#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

#include "fdv/pipeline/perception.h"

namespace YAML {
class Node;
}

namespace fdv {

/// Every key of the file (an empty file, a null root: PerceptionOptions{}).
PerceptionOptions load_perception_options(const YAML::Node& root, const std::string& file);
/// load_perception_options on YAML text in memory; `file` names it in errors. At most
/// kMaxConfigFileBytes (fdv/core/config_text.h); a syntax error names the line.
PerceptionOptions load_perception_options_text(std::string_view text, const std::string& file);
/// Reads `path` (size-checked) and calls load_perception_options_text.
PerceptionOptions load_perception_options_file(const std::string& path);

/// Every key, as YAML that load_perception_options_text reads back to the same values.
std::string to_yaml(const PerceptionOptions& options);
/// Every key, as one JSON object: the top-level keys, and one object per section.
nlohmann::json to_json(const PerceptionOptions& options);
/// The "detector" section as the Detector uses it on this event camera: its event-count gates
/// scaled to the focal length (scaled_to_camera, fdv/detection/detector.h). summary.json's
/// "detector_in_use"; "options" keeps the values as given, which a run reads back.
nlohmann::json detector_in_use(const PerceptionOptions& options, const PinholeCamera& event_camera);

/// The sections of the file ("compensation", "detector", ...), in the field list's order; "" is
/// the top level (its scalar keys only).
std::vector<std::string> options_sections();
/// The Markdown key table (| key | default | unit | meaning |) of one section, or of the top
/// level's scalar keys for "". Throws ConfigError for an unknown section.
std::string options_markdown_table(const std::string& section);

}  // namespace fdv
