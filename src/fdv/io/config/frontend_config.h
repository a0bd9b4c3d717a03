#pragma once
/// YAML loading of the detection front end's options (compensation, detector, depth registration).
///
///   YAML::Node root = YAML::LoadFile(path);
///   CompensationOptions c = load_compensation_options(root["compensation"], path);
///   DetectorOptions d = load_detector_options(root["detector"], path);
///
/// A missing (undefined or null) section gives the defaults; a key that is absent keeps its
/// default. Keys are the option fields' names, except durations, which YAML gives in
/// milliseconds (`rotation_refresh_ms: 1.0` fills `rotation_refresh_ns`). An unknown key, a value
/// of the wrong type, or options that fail validate() throw InputError(file, "key <section>.<key>",
/// reason). The full key list is in docs/DETECTION.md.
#include <string>

#include "fdv/compensation/compensator.h"
#include "fdv/depth/depth_registration.h"
#include "fdv/detection/detector_options.h"

namespace YAML {
class Node;
}

namespace fdv {

CompensationOptions load_compensation_options(const YAML::Node& node, const std::string& file,
                                              const std::string& section = "compensation");
DetectorOptions load_detector_options(const YAML::Node& node, const std::string& file,
                                      const std::string& section = "detector");
DepthRegistrationOptions load_depth_registration_options(const YAML::Node& node, const std::string& file,
                                                         const std::string& section = "depth_registration");

}  // namespace fdv
