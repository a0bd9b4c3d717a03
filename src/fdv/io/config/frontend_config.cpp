#include "fdv/io/config/frontend_config.h"

#include <yaml-cpp/yaml.h>

#include "fdv/core/error.h"
#include "fdv/io/config/yaml_section.h"

namespace fdv {
using config_internal::Section;

CompensationOptions load_compensation_options(const YAML::Node& node, const std::string& file,
                                              const std::string& section) {
  CompensationOptions o;
  Section s(node, file, section);
  s.on("method", [&](const YAML::Node& n, const std::string& k) { o.method = s.text(n, k); });
  s.on("rotation_refresh_ms",
       [&](const YAML::Node& n, const std::string& k) { o.rotation_refresh_ns = s.millis(n, k); });
  s.on("max_imu_gap_ms",
       [&](const YAML::Node& n, const std::string& k) { o.max_imu_gap_ns = s.millis(n, k); });
  s.on("max_depth_age_ms",
       [&](const YAML::Node& n, const std::string& k) { o.max_depth_age_ns = s.millis(n, k); });
  s.on("missing_depth", [&](const YAML::Node& n, const std::string& k) {
    const std::string v = s.text(n, k);
    const auto p = parse_missing_depth_policy(v);
    if (!p) throw InputError(file, "key " + k, "'" + v + "' is not median_depth or rotation_only");
    o.missing_depth = *p;
  });
  s.on("hole_fill_radius_px",
       [&](const YAML::Node& n, const std::string& k) { o.hole_fill_radius_px = s.int32(n, k); });
  s.on("threads", [&](const YAML::Node& n, const std::string& k) { o.threads = s.int32(n, k); });
  s.on("max_events_per_window", [&](const YAML::Node& n, const std::string& k) {
    const long long v = s.integer(n, k);
    if (v < 1) throw InputError(file, "key " + k, "must be positive");
    o.max_events_per_window = static_cast<std::size_t>(v);
  });
  s.on("contrast_max", [&](const YAML::Node& n, const std::string& k) {
    Section cm(n, file, k);
    ContrastMaxOptions& c = o.contrast_max;
    cm.on("max_fit_events",
          [&](const YAML::Node& m, const std::string& kk) { c.max_fit_events = cm.int32(m, kk); });
    cm.on("blur_sigma_px",
          [&](const YAML::Node& m, const std::string& kk) { c.blur_sigma_px = cm.number(m, kk); });
    cm.on("max_iterations",
          [&](const YAML::Node& m, const std::string& kk) { c.max_iterations = cm.int32(m, kk); });
    cm.on("max_expansion_per_s", [&](const YAML::Node& m, const std::string& kk) {
      c.max_expansion_per_s = cm.number(m, kk);
    });
    cm.on("warm_start",
          [&](const YAML::Node& m, const std::string& kk) { c.warm_start = cm.boolean(m, kk); });
    cm.apply();
  });
  s.apply();
  s.check(o.validate());
  return o;
}

DetectorOptions load_detector_options(const YAML::Node& node, const std::string& file,
                                      const std::string& section) {
  DetectorOptions o;
  Section s(node, file, section);
  auto num = [&](const char* key, double& field) {
    s.on(key, [&s, &field](const YAML::Node& n, const std::string& k) { field = s.number(n, k); });
  };
  auto integer = [&](const char* key, int& field) {
    s.on(key, [&s, &field](const YAML::Node& n, const std::string& k) { field = s.int32(n, k); });
  };
  num("threshold_a_s_per_rad", o.threshold_a_s_per_rad);
  num("threshold_b_s_per_m", o.threshold_b_s_per_m);
  num("threshold_c", o.threshold_c);
  integer("min_pixel_events", o.min_pixel_events);
  integer("mean_filter_px", o.mean_filter_px);
  integer("opening_px", o.opening_px);
  num("min_peak", o.gaussian_fit.min_peak);
  num("min_event_density", o.min_event_density);
  integer("max_candidates", o.gaussian_fit.max_candidates);
  num("prior_min_peak", o.track_aided.min_peak);
  num("prior_gate_scale", o.prior_gate_scale);
  num("prior_min_gate_px", o.prior_min_gate_px);
  integer("fit_max_iterations", o.fit_max_iterations);
  num("fit_delta_center_px", o.fit_delta_center_px);
  num("fit_delta_size_px", o.fit_delta_size_px);
  num("fit_min_size_px", o.fit_min_size_px);
  num("refit_min_roi_px", o.gaussian_fit.refit_min_roi_px);
  num("refit_local_scale", o.gaussian_fit.refit_local_scale);
  num("roi_max_fraction", o.gaussian_fit.roi_max_fraction);
  num("roi_max_aspect", o.roi_max_aspect);
  integer("roi_min_events", o.roi_min_events);
  integer("region_min_area_px", o.region_min_area_px);
  integer("min_window_events", o.min_window_events);
  num("refine_box_scale", o.refine_box_scale);
  integer("refine_recentre_passes", o.refine_recentre_passes);
  s.on("square_box", [&](const YAML::Node& n, const std::string& k) { o.square_box = s.boolean(n, k); });
  num("max_segmented_fraction", o.max_segmented_fraction);
  s.on("motion_cue", [&](const YAML::Node& n, const std::string& k) { o.dense_motion.enabled = s.boolean(n, k); });
  integer("motion_cue_density_px", o.dense_motion.density_px);
  integer("motion_cue_radius_px", o.dense_motion.radius_px);
  integer("motion_cue_min_pixels", o.dense_motion.min_pixels);
  num("motion_cue_min_r2", o.dense_motion.min_r2);
  num("motion_cue_min_span", o.dense_motion.min_span);
  s.on("count_cue", [&](const YAML::Node& n, const std::string& k) { o.count_contrast.enabled = s.boolean(n, k); });
  integer("count_cue_box_px", o.count_contrast.box_px);
  num("count_cue_surround_scale", o.count_contrast.surround_scale);
  num("count_cue_min_contrast", o.count_contrast.min_contrast);
  num("count_cue_min_fill", o.count_contrast.min_fill);
  s.on("count_cue_in_gates", [&](const YAML::Node& n, const std::string& k) { o.count_contrast.in_gates = s.boolean(n, k); });
  s.apply();
  s.check(o.validate());
  return o;
}

DepthRegistrationOptions load_depth_registration_options(const YAML::Node& node,
                                                         const std::string& file,
                                                         const std::string& section) {
  DepthRegistrationOptions o;
  Section s(node, file, section);
  s.on("min_depth_m",
       [&](const YAML::Node& n, const std::string& k) { o.min_depth_m = s.number(n, k); });
  s.on("max_depth_m",
       [&](const YAML::Node& n, const std::string& k) { o.max_depth_m = s.number(n, k); });
  s.apply();
  s.check(o.validate());
  return o;
}

}  // namespace fdv
