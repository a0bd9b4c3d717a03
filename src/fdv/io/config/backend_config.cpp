#include "fdv/io/config/backend_config.h"

#include <yaml-cpp/yaml.h>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/io/config/frontend_config.h"
#include "fdv/io/config/yaml_section.h"

namespace fdv {
using config_internal::Section;

TrackerOptions load_tracker_options(const YAML::Node& node, const std::string& file,
                                    const std::string& section) {
  TrackerOptions o;
  Section s(node, file, section);
  s.on("filter", [&](const YAML::Node& n, const std::string& k) {
    Section f(n, file, k);
    f.bind("measurement_sigma_px", o.filter.measurement_sigma_px);
    f.bind("jerk_psd_px2_s5", o.filter.jerk_psd_px2_s5);
    f.bind("init_velocity_sigma_px_s", o.filter.init_velocity_sigma_px_s);
    f.bind("init_acceleration_sigma_px_s2", o.filter.init_acceleration_sigma_px_s2);
    f.apply();
    f.check(o.filter.validate());
  });
  s.bind("gate_chi2", o.gate_chi2);
  s.bind("gate_max_distance_px", o.gate_max_distance_px);
  s.bind_ms("max_gap_ms", o.max_gap_ns);
  s.bind_ms("tentative_max_gap_ms", o.tentative_max_gap_ns);
  s.bind("confirm_hits", o.confirm_hits);
  s.bind("box_smoothing", o.box_smoothing);
  s.bind("max_tracks", o.max_tracks);
  s.apply();
  s.check(o.validate());
  return o;
}

DepthSegmentationOptions load_depth_segmentation_options(const YAML::Node& node,
                                                         const std::string& file,
                                                         const std::string& section) {
  DepthSegmentationOptions o;
  Section s(node, file, section);
  s.bind("roi_scale", o.roi_scale);
  s.bind("bin_width_m", o.bin_width_m);
  s.bind("min_depth_m", o.min_depth_m);
  s.bind("max_depth_m", o.max_depth_m);
  s.bind("min_peak_pixels", o.min_peak_pixels);
  s.bind("min_peak_fraction", o.min_peak_fraction);
  s.bind("max_peaks", o.max_peaks);
  s.bind("window_sigmas", o.window_sigmas);
  s.bind("object_radius_m", o.object_radius_m);
  s.bind("default_window_radius_m", o.default_window_radius_m);
  s.bind("spread_gate", o.spread_gate);
  s.bind("max_fill_ratio", o.max_fill_ratio);
  s.bind("max_centroid_offset", o.max_centroid_offset);
  s.bind("radius_ratio_gate", o.radius_ratio_gate);
  s.bind("radius_relative_sigma", o.radius_relative_sigma);
  s.bind("min_sigma_m", o.min_sigma_m);
  s.on("noise", [&](const YAML::Node& n, const std::string& k) {
    Section m(n, file, k);
    m.bind("subpixel_px", o.noise.subpixel_px);
    m.bind("focal_px", o.noise.focal_px);
    m.bind("baseline_m", o.noise.baseline_m);
    m.apply();
    m.check(o.noise.validate());
  });
  s.apply();
  s.check(o.validate());
  return o;
}

EstimatorOptions load_estimator_options(const YAML::Node& node, const std::string& file,
                                        const std::string& section) {
  EstimatorOptions o;
  Section s(node, file, section);
  s.on("mode", [&](const YAML::Node&, const std::string& k) {
    throw InputError(file, "key " + k,
                     "not configurable: the pipeline runs fusion, and the monocular baseline "
                     "beside it when monocular_baseline is true");
  });
  s.on("gravity",
       [&](const YAML::Node& n, const std::string& k) { o.gravity_W = s.vector3(n, k); });
  s.bind("event_sigma_px", o.event_sigma_px);
  s.on("event_focal_px", [&](const YAML::Node& n, const std::string& k) {
    o.event_focal_px = s.number(n, k);
    if (o.event_focal_px < 0)
      throw InputError(file, "key " + k, "must be >= 0 (0 = the calibration's focal length)");
  });
  s.bind("huber_event", o.huber_event);
  s.bind("huber_depth", o.huber_depth);
  s.bind("min_event_observations", o.min_event_observations);
  s.bind("min_depth_observations", o.min_depth_observations);
  s.bind("min_residuals", o.min_residuals);
  s.bind("min_event_observations_event_only", o.min_event_observations_event_only);
  s.bind_ms("max_lateness_ms", o.max_lateness_ns);
  s.bind("max_observations", o.max_observations);
  s.bind("min_depth_in_front_m", o.min_depth_in_front_m);
  s.bind("max_range_m", o.max_range_m);
  s.bind("mono_prior_depth_m", o.mono_prior_depth_m);
  s.bind("min_reciprocal_condition", o.min_reciprocal_condition);
  s.bind("max_position_sigma_m", o.max_position_sigma_m);
  s.bind("usable_horizon_s", o.usable_horizon_s);
  s.bind("compute_covariance", o.compute_covariance);
  s.bind("max_iterations", o.max_iterations);
  s.bind("function_tolerance", o.function_tolerance);
  s.bind("parameter_tolerance", o.parameter_tolerance);
  s.apply();
  // validate() requires the focal length, which Perception takes from the calibration when it is
  // 0 here: check everything else with a stand-in.
  EstimatorOptions checked = o;
  if (checked.event_focal_px == 0) checked.event_focal_px = 1.0;
  s.check(checked.validate());
  return o;
}

PredictionOptions load_prediction_options(const YAML::Node& node, const std::string& file,
                                          const std::string& section) {
  PredictionOptions o;
  Section s(node, file, section);
  s.bind("horizon_s", o.horizon_s);
  s.bind("safety_radius_m", o.safety_radius_m);
  s.apply();
  s.check(o.validate());
  return o;
}

PerceptionOptions load_perception_options(const YAML::Node& root, const std::string& file) {
  PerceptionOptions o;
  Section s(root, file, "");
  s.list_keys_when_unknown("unknown section");
  s.on("compensation", [&](const YAML::Node& n, const std::string& k) {
    o.compensation = load_compensation_options(n, file, k);
  });
  s.on("detector", [&](const YAML::Node& n, const std::string& k) {
    o.detection = load_detector_options(n, file, k);
  });
  s.on("depth_registration", [&](const YAML::Node& n, const std::string& k) {
    o.depth_registration = load_depth_registration_options(n, file, k);
  });
  s.on("tracking", [&](const YAML::Node& n, const std::string& k) {
    o.tracking = load_tracker_options(n, file, k);
  });
  s.on("depth_segmentation", [&](const YAML::Node& n, const std::string& k) {
    o.depth_segmentation = load_depth_segmentation_options(n, file, k);
  });
  s.on("estimation", [&](const YAML::Node& n, const std::string& k) {
    o.estimation = load_estimator_options(n, file, k);
  });
  s.on("prediction", [&](const YAML::Node& n, const std::string& k) {
    o.prediction = load_prediction_options(n, file, k);
  });
  s.on("window_ms", [&](const YAML::Node& n, const std::string& k) {
    o.windows.window_ns = s.millis(n, k);
    if (o.windows.window_ns <= 0) throw InputError(file, "key " + k, "must be > 0");
  });
  s.on("max_empty_windows", [&](const YAML::Node& n, const std::string& k) {
    const long long v = s.integer(n, k);
    if (v < 0) throw InputError(file, "key " + k, "must be >= 0");
    o.windows.max_empty_windows = static_cast<std::uint64_t>(v);
  });
  s.bind("monocular_baseline", o.monocular_baseline);
  s.bind("estimate_aided_association", o.estimate_aided_association);
  s.bind("depth_since_first_detection", o.depth_since_first_detection);
  s.bind("estimate_trajectories", o.estimate_trajectories);
  s.on("max_lateness_ms", [&](const YAML::Node& n, const std::string& k) {
    o.max_lateness_ns = s.millis(n, k);
    if (o.max_lateness_ns < 0) throw InputError(file, "key " + k, "must be >= 0");
  });
  s.on("odometry_max_extrapolation_ms", [&](const YAML::Node& n, const std::string& k) {
    o.odometry_max_extrapolation_ns = s.millis(n, k);
    if (o.odometry_max_extrapolation_ns < 0) throw InputError(file, "key " + k, "must be >= 0");
  });
  s.apply();
  // A safety net: every section and scalar was validated above.
  s.check(o.validate());
  return o;
}

PerceptionOptions load_perception_options_text(std::string_view text, const std::string& file) {
  const YAML::Node root = parse_config_yaml(text, file);
  try {
    return load_perception_options(root, file);
  } catch (const YAML::Exception& e) {
    // A safety net: Section turns yaml-cpp errors into key-naming ones already.
    throw InputError(file, yaml_position(e.mark), yaml_reason(e));
  }
}

PerceptionOptions load_perception_options_file(const std::string& path) {
  return load_perception_options_text(read_config_file(path), path);
}

}  // namespace fdv
