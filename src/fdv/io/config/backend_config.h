#pragma once
/// YAML loading of the back end's options (tracking, depth segmentation, estimation, prediction)
/// and of the whole pipeline's PerceptionOptions from one file (what `fdv run --config` reads).
///
///   PerceptionOptions o = load_perception_options_file(path);       // every section
///   YAML::Node root = YAML::LoadFile(path);
///   TrackerOptions t = load_tracker_options(root["tracking"], path);  // or one section
///
/// Same rules as frontend_config.h: a missing (undefined or null) section or key keeps its
/// default; keys are the option fields' names, except durations, given in milliseconds
/// (`max_gap_ms: 80` fills `max_gap_ns`); an unknown key, a value of the wrong type, or options
/// that fail validate() throw InputError(file, "key <section>.<key>", reason). The key lists are
/// in docs/ESTIMATION.md ("Configuration") and docs/DETECTION.md ("Parameters").
///
/// Estimation: `mode` is not configurable (the pipeline runs fusion, and the monocular baseline
/// beside it when `monocular_baseline` is true); `gravity` is a list [x, y, z] in W [m/s²];
/// `event_focal_px` 0 (the default) means "from the calibration", which Perception fills in.
#include <string>
#include <string_view>

#include "fdv/depth/depth_segmentation.h"
#include "fdv/estimation/collision.h"
#include "fdv/estimation/trajectory_estimator.h"
#include "fdv/pipeline/perception.h"
#include "fdv/tracking/tracker.h"

namespace YAML {
class Node;
}

namespace fdv {

TrackerOptions load_tracker_options(const YAML::Node& node, const std::string& file,
                                    const std::string& section = "tracking");
DepthSegmentationOptions load_depth_segmentation_options(
    const YAML::Node& node, const std::string& file,
    const std::string& section = "depth_segmentation");
EstimatorOptions load_estimator_options(const YAML::Node& node, const std::string& file,
                                        const std::string& section = "estimation");
PredictionOptions load_prediction_options(const YAML::Node& node, const std::string& file,
                                          const std::string& section = "prediction");

/// Every section of the pipeline: compensation, detector, depth_registration, tracking,
/// depth_segmentation, estimation, prediction; and the top-level scalars window_ms,
/// monocular_baseline, max_lateness_ms, odometry_max_extrapolation_ms. An unknown top-level key
/// is an InputError listing the valid ones. An empty file (null root) gives PerceptionOptions{}.
PerceptionOptions load_perception_options(const YAML::Node& root, const std::string& file);

/// load_perception_options on YAML text in memory (what `fdv run --config` reads); `file` names
/// it in errors. At most kMaxConfigFileBytes (fdv/core/config_text.h). Throws InputError naming
/// the file and the key (or the line, for a syntax error); no yaml-cpp exception escapes.
PerceptionOptions load_perception_options_text(std::string_view text, const std::string& file);
/// Reads `path` (size-checked) and calls load_perception_options_text.
PerceptionOptions load_perception_options_file(const std::string& path);

}  // namespace fdv
