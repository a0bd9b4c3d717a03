// YAML loading of the front end's options.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "fdv/core/error.h"
#include "fdv/io/config/frontend_config.h"

namespace fdv {
namespace {

TEST(FrontendConfig, ReadsEveryKindOfValue) {
  const YAML::Node root = YAML::Load(R"(
compensation:
  method: rotation
  rotation_refresh_ms: 0.5
  max_imu_gap_ms: 12
  max_depth_age_ms: 66.5
  missing_depth: rotation_only
  hole_fill_radius_px: 2
  threads: 2
  max_events_per_window: 123456
  contrast_max: {max_fit_events: 5000, blur_sigma_px: 1.5, max_iterations: 7, max_expansion_per_s: 4, warm_start: false}
detector:
  threshold_a_s_per_rad: 0.03
  threshold_b_s_per_m: 0.04
  threshold_c: 0.2
  opening_px: 7
  min_peak: 0.3
  refine_box_scale: 0
  refine_recentre_passes: 2
  square_box: false
  fit_max_iterations: 12
  roi_min_events: 11
  motion_cue: false
  motion_cue_radius_px: 7
  motion_cue_min_pixels: 9
  motion_cue_min_r2: 0.35
  count_cue: false
  count_cue_box_px: 7
  count_cue_surround_scale: 2.5
  count_cue_min_contrast: 4
  count_cue_min_fill: 0.7
  count_cue_in_gates: false
depth_registration: {min_depth_m: 0.2, max_depth_m: 12}
)");
  const CompensationOptions c = load_compensation_options(root["compensation"], "cfg.yaml");
  EXPECT_EQ(c.method, "rotation");
  EXPECT_EQ(c.rotation_refresh_ns, 500'000);
  EXPECT_EQ(c.max_imu_gap_ns, 12'000'000);
  EXPECT_EQ(c.max_depth_age_ns, 66'500'000);
  EXPECT_EQ(c.missing_depth, MissingDepthPolicy::kRotationOnly);
  EXPECT_EQ(c.hole_fill_radius_px, 2);
  EXPECT_EQ(c.threads, 2);
  EXPECT_EQ(c.max_events_per_window, 123456u);
  EXPECT_EQ(c.contrast_max.max_fit_events, 5000);
  EXPECT_DOUBLE_EQ(c.contrast_max.blur_sigma_px, 1.5);
  EXPECT_EQ(c.contrast_max.max_iterations, 7);
  EXPECT_DOUBLE_EQ(c.contrast_max.max_expansion_per_s, 4.0);
  EXPECT_FALSE(c.contrast_max.warm_start);
  const DetectorOptions d = load_detector_options(root["detector"], "cfg.yaml");
  EXPECT_DOUBLE_EQ(d.threshold_a_s_per_rad, 0.03);
  EXPECT_DOUBLE_EQ(d.threshold_b_s_per_m, 0.04);
  EXPECT_DOUBLE_EQ(d.threshold_c, 0.2);
  EXPECT_EQ(d.opening_px, 7);
  EXPECT_DOUBLE_EQ(d.gaussian_fit.min_peak, 0.3);
  EXPECT_DOUBLE_EQ(d.refine_box_scale, 0.0);
  EXPECT_EQ(d.refine_recentre_passes, 2);
  EXPECT_FALSE(d.square_box);
  EXPECT_EQ(d.fit_max_iterations, 12);
  EXPECT_EQ(d.roi_min_events, 11);
  EXPECT_FALSE(d.dense_motion.enabled);
  EXPECT_EQ(d.dense_motion.radius_px, 7);
  EXPECT_EQ(d.dense_motion.min_pixels, 9);
  EXPECT_DOUBLE_EQ(d.dense_motion.min_r2, 0.35);
  EXPECT_FALSE(d.count_contrast.enabled);
  EXPECT_EQ(d.count_contrast.box_px, 7);
  EXPECT_DOUBLE_EQ(d.count_contrast.surround_scale, 2.5);
  EXPECT_DOUBLE_EQ(d.count_contrast.min_contrast, 4.0);
  EXPECT_DOUBLE_EQ(d.count_contrast.min_fill, 0.7);
  EXPECT_FALSE(d.count_contrast.in_gates);
  EXPECT_EQ(d.mean_filter_px, DetectorOptions{}.mean_filter_px);  // absent: default kept
  const DepthRegistrationOptions r = load_depth_registration_options(root["depth_registration"], "cfg.yaml");
  EXPECT_DOUBLE_EQ(r.min_depth_m, 0.2);
  EXPECT_DOUBLE_EQ(r.max_depth_m, 12.0);
}

TEST(FrontendConfig, MissingSectionGivesDefaults) {
  const YAML::Node root = YAML::Load("other: 1");
  const DetectorOptions d = load_detector_options(root["detector"], "cfg.yaml");
  EXPECT_DOUBLE_EQ(d.threshold_c, DetectorOptions{}.threshold_c);
  EXPECT_EQ(load_compensation_options(root["compensation"], "cfg.yaml").method, "rotation_translation");
}

// The InputError's `where` for a YAML snippet.
std::string where_of(const std::string& yaml, int which) {
  const YAML::Node root = YAML::Load(yaml);
  try {
    if (which == 0) load_compensation_options(root["compensation"], "cfg.yaml");
    if (which == 1) load_detector_options(root["detector"], "cfg.yaml");
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "cfg.yaml");
    return e.where() + " | " + e.reason();
  }
  return "no error";
}

TEST(FrontendConfig, BadKeysAndValuesNameTheKey) {
  EXPECT_EQ(where_of("detector: {threshold_d: 1}", 1), "key detector.threshold_d | unknown key");
  EXPECT_EQ(where_of("compensation: {contrast_max: {sigma: 1}}", 0), "key compensation.contrast_max.sigma | unknown key");
  EXPECT_EQ(where_of("detector: {threshold_c: high}", 1), "key detector.threshold_c | expected a number, got 'high'");
  EXPECT_EQ(where_of("detector: {opening_px: 2.5}", 1), "key detector.opening_px | expected an integer, got '2.5'");
  EXPECT_NE(where_of("detector: {opening_px: 4}", 1).find("key detector | opening_px must be odd"), std::string::npos);
  EXPECT_NE(where_of("compensation: {method: betterflow}", 0).find("'betterflow' is unknown"), std::string::npos);
  EXPECT_EQ(where_of("compensation: {missing_depth: zero}", 0),
            "key compensation.missing_depth | 'zero' is not median_depth or rotation_only");
  EXPECT_EQ(where_of("detector: [1, 2]", 1), "key detector | expected a map of options");
  EXPECT_NE(where_of("compensation: {threads: 0}", 0).find("threads must be in [1, 64], got 0"), std::string::npos);
}

}  // namespace
}  // namespace fdv
