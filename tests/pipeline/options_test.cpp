// PerceptionOptions in and out of YAML and JSON (`fdv run --config`, `--print-config`, summary.json),
// and the docs' key tables, all from the field lists.
#include "fdv/pipeline/options_yaml.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/core/field_list.h"
#include "test_support.h"

namespace fdv {
namespace {

using ::testing::HasSubstr;
using ::testing::IsEmpty;

/// Names of the fields that are equal in a and b, and of those that differ.
struct FieldComparison {
  std::vector<std::string> equal, different;
};
#define FDV_COMPARE_FIELD(name) (a.name == b.name ? r.equal : r.different).push_back(#name)

FieldComparison compare(const TrackerOptions& a, const TrackerOptions& b) {
  FieldComparison r;
  FDV_COMPARE_FIELD(filter.measurement_sigma_px);
  FDV_COMPARE_FIELD(filter.jerk_psd_px2_s5);
  FDV_COMPARE_FIELD(filter.init_velocity_sigma_px_s);
  FDV_COMPARE_FIELD(filter.init_acceleration_sigma_px_s2);
  FDV_COMPARE_FIELD(gate_chi2);
  FDV_COMPARE_FIELD(gate_max_distance_px);
  FDV_COMPARE_FIELD(max_gap_ns);
  FDV_COMPARE_FIELD(tentative_max_gap_ns);
  FDV_COMPARE_FIELD(confirm_hits);
  FDV_COMPARE_FIELD(box_smoothing);
  FDV_COMPARE_FIELD(max_tracks);
  return r;
}

FieldComparison compare(const DepthSegmentationOptions& a, const DepthSegmentationOptions& b) {
  FieldComparison r;
  FDV_COMPARE_FIELD(roi_scale);
  FDV_COMPARE_FIELD(bin_width_m);
  FDV_COMPARE_FIELD(min_depth_m);
  FDV_COMPARE_FIELD(max_depth_m);
  FDV_COMPARE_FIELD(min_peak_pixels);
  FDV_COMPARE_FIELD(min_peak_fraction);
  FDV_COMPARE_FIELD(max_peaks);
  FDV_COMPARE_FIELD(window_sigmas);
  FDV_COMPARE_FIELD(object_radius_m);
  FDV_COMPARE_FIELD(default_window_radius_m);
  FDV_COMPARE_FIELD(spread_gate);
  FDV_COMPARE_FIELD(max_fill_ratio);
  FDV_COMPARE_FIELD(max_centroid_offset);
  FDV_COMPARE_FIELD(radius_ratio_gate);
  FDV_COMPARE_FIELD(radius_relative_sigma);
  FDV_COMPARE_FIELD(min_sigma_m);
  FDV_COMPARE_FIELD(noise.subpixel_px);
  FDV_COMPARE_FIELD(noise.focal_px);
  FDV_COMPARE_FIELD(noise.baseline_m);
  return r;
}

/// Every field but `mode`, which is not configurable.
FieldComparison compare(const EstimatorOptions& a, const EstimatorOptions& b) {
  FieldComparison r;
  FDV_COMPARE_FIELD(gravity_W);
  FDV_COMPARE_FIELD(event_sigma_px);
  FDV_COMPARE_FIELD(event_focal_px);
  FDV_COMPARE_FIELD(huber_event);
  FDV_COMPARE_FIELD(huber_depth);
  FDV_COMPARE_FIELD(min_event_observations);
  FDV_COMPARE_FIELD(min_depth_observations);
  FDV_COMPARE_FIELD(min_residuals);
  FDV_COMPARE_FIELD(min_event_observations_event_only);
  FDV_COMPARE_FIELD(max_lateness_ns);
  FDV_COMPARE_FIELD(max_observations);
  FDV_COMPARE_FIELD(min_depth_in_front_m);
  FDV_COMPARE_FIELD(max_range_m);
  FDV_COMPARE_FIELD(mono_prior_depth_m);
  FDV_COMPARE_FIELD(min_reciprocal_condition);
  FDV_COMPARE_FIELD(max_position_sigma_m);
  FDV_COMPARE_FIELD(usable_horizon_s);
  FDV_COMPARE_FIELD(compute_covariance);
  FDV_COMPARE_FIELD(max_iterations);
  FDV_COMPARE_FIELD(function_tolerance);
  FDV_COMPARE_FIELD(parameter_tolerance);
  return r;
}

FieldComparison compare(const CompensationOptions& a, const CompensationOptions& b) {
  FieldComparison r;
  FDV_COMPARE_FIELD(method);
  FDV_COMPARE_FIELD(rotation_refresh_ns);
  FDV_COMPARE_FIELD(max_imu_gap_ns);
  FDV_COMPARE_FIELD(max_depth_age_ns);
  FDV_COMPARE_FIELD(missing_depth);
  FDV_COMPARE_FIELD(hole_fill_radius_px);
  FDV_COMPARE_FIELD(contrast_max.max_fit_events);
  FDV_COMPARE_FIELD(contrast_max.blur_sigma_px);
  FDV_COMPARE_FIELD(contrast_max.max_iterations);
  FDV_COMPARE_FIELD(contrast_max.max_expansion_per_s);
  FDV_COMPARE_FIELD(contrast_max.warm_start);
  return r;
}

/// The top-level keys, the prediction and depth registration sections.
FieldComparison compare_top(const PerceptionOptions& a, const PerceptionOptions& b) {
  FieldComparison r;
  FDV_COMPARE_FIELD(windows.window_ns);
  FDV_COMPARE_FIELD(windows.max_events_per_window);
  FDV_COMPARE_FIELD(windows.max_empty_windows);
  FDV_COMPARE_FIELD(threads);
  FDV_COMPARE_FIELD(monocular_baseline);
  FDV_COMPARE_FIELD(estimate_aided_association);
  FDV_COMPARE_FIELD(depth_since_first_detection);
  FDV_COMPARE_FIELD(depth_before_first_detection_ns);
  FDV_COMPARE_FIELD(estimate_trajectories);
  FDV_COMPARE_FIELD(assume_static_vehicle);
  FDV_COMPARE_FIELD(max_lateness_ns);
  FDV_COMPARE_FIELD(odometry_max_extrapolation_ns);
  FDV_COMPARE_FIELD(depth_registration.min_depth_m);
  FDV_COMPARE_FIELD(depth_registration.max_depth_m);
  FDV_COMPARE_FIELD(prediction.horizon_s);
  FDV_COMPARE_FIELD(prediction.safety_radius_m);
  return r;
}
#undef FDV_COMPARE_FIELD

// Every key but the detector's (its own test below), each set to a value that is not its default.
constexpr const char* kFullConfig = R"(
window_ms: 20
max_events_per_window: 500000
max_empty_windows: 80
threads: 2
monocular_baseline: false
estimate_aided_association: false
depth_since_first_detection: false
depth_before_first_detection_ms: 20.5
estimate_trajectories: false
assume_static_vehicle: true
max_lateness_ms: 30
odometry_max_extrapolation_ms: 15.5
compensation:
  method: rotation
  rotation_refresh_ms: 0.5
  max_imu_gap_ms: 12
  max_depth_age_ms: 66.5
  missing_depth: rotation_only
  hole_fill_radius_px: 2
  contrast_max: {max_fit_events: 5000, blur_sigma_px: 1.5, max_iterations: 7, max_expansion_per_s: 4, warm_start: false}
depth_registration: {min_depth_m: 0.2, max_depth_m: 12}
tracking:
  filter:
    measurement_sigma_px: 2.0
    jerk_psd_px2_s5: 3.0e7
    init_velocity_sigma_px_s: 1000
    init_acceleration_sigma_px_s2: 5000
  gate_chi2: 9.21
  gate_max_distance_px: 80
  max_gap_ms: 80
  tentative_max_gap_ms: 40.5
  confirm_hits: 2
  box_smoothing: 0.25
  max_tracks: 4
depth_segmentation:
  roi_scale: 2.5
  bin_width_m: 0.05
  min_depth_m: 0.4
  max_depth_m: 8
  min_peak_pixels: 12
  min_peak_fraction: 0.06
  max_peaks: 2
  window_sigmas: 3
  object_radius_m: 0.105
  default_window_radius_m: 0.12
  spread_gate: 2.5
  max_fill_ratio: 1.8
  max_centroid_offset: 1.2
  radius_ratio_gate: 1.4
  radius_relative_sigma: 0.3
  min_sigma_m: 0.02
  noise: {subpixel_px: 0.1, focal_px: 420.5, baseline_m: 0.095}
estimation:
  gravity: [0.1, -0.2, -9.8]
  event_sigma_px: 2
  event_focal_px: 320
  huber_event: 3
  huber_depth: 2.5
  min_event_observations: 3
  min_depth_observations: 2
  min_residuals: 8
  min_event_observations_event_only: 5
  max_lateness_ms: 150
  max_observations: 100
  min_depth_in_front_m: 0.1
  max_range_m: 30
  mono_prior_depth_m: 4
  min_reciprocal_condition: 1.0e-10
  max_position_sigma_m: 0.5
  usable_horizon_s: 0.3
  compute_covariance: false
  max_iterations: 25
  function_tolerance: 1.0e-8
  parameter_tolerance: 1.0e-9
prediction: {horizon_s: 1.5, safety_radius_m: 0.75}
)";

PerceptionOptions load(const std::string& yaml) { return load_perception_options_text(yaml, "cfg.yaml"); }

TEST(Options, FullFileLoadsEveryKey) {
  const PerceptionOptions o = load(kFullConfig);

  // Expected values written out by hand from kFullConfig (durations: ms -> ns).
  CompensationOptions comp;
  comp.method = CompensationMethod::kRotation;
  comp.rotation_refresh_ns = 500'000;
  comp.max_imu_gap_ns = 12'000'000;
  comp.max_depth_age_ns = 66'500'000;
  comp.missing_depth = MissingDepthPolicy::kRotationOnly;
  comp.hole_fill_radius_px = 2;
  comp.contrast_max.max_fit_events = 5000;
  comp.contrast_max.blur_sigma_px = 1.5;
  comp.contrast_max.max_iterations = 7;
  comp.contrast_max.max_expansion_per_s = 4;
  comp.contrast_max.warm_start = false;

  TrackerOptions tracking;
  tracking.filter.measurement_sigma_px = 2.0;
  tracking.filter.jerk_psd_px2_s5 = 3.0e7;
  tracking.filter.init_velocity_sigma_px_s = 1000;
  tracking.filter.init_acceleration_sigma_px_s2 = 5000;
  tracking.gate_chi2 = 9.21;
  tracking.gate_max_distance_px = 80;
  tracking.max_gap_ns = 80'000'000;
  tracking.tentative_max_gap_ns = 40'500'000;
  tracking.confirm_hits = 2;
  tracking.box_smoothing = 0.25;
  tracking.max_tracks = 4;

  DepthSegmentationOptions depth;
  depth.roi_scale = 2.5;
  depth.bin_width_m = 0.05;
  depth.min_depth_m = 0.4;
  depth.max_depth_m = 8;
  depth.min_peak_pixels = 12;
  depth.min_peak_fraction = 0.06;
  depth.max_peaks = 2;
  depth.window_sigmas = 3;
  depth.object_radius_m = 0.105;
  depth.default_window_radius_m = 0.12;
  depth.spread_gate = 2.5;
  depth.max_fill_ratio = 1.8;
  depth.max_centroid_offset = 1.2;
  depth.radius_ratio_gate = 1.4;
  depth.radius_relative_sigma = 0.3;
  depth.min_sigma_m = 0.02;
  depth.noise.subpixel_px = 0.1;
  depth.noise.focal_px = 420.5;
  depth.noise.baseline_m = 0.095;

  EstimatorOptions est;
  est.gravity_W = Eigen::Vector3d(0.1, -0.2, -9.8);
  est.event_sigma_px = 2;
  est.event_focal_px = 320;
  est.huber_event = 3;
  est.huber_depth = 2.5;
  est.min_event_observations = 3;
  est.min_depth_observations = 2;
  est.min_residuals = 8;
  est.min_event_observations_event_only = 5;
  est.max_lateness_ns = 150'000'000;
  est.max_observations = 100;
  est.min_depth_in_front_m = 0.1;
  est.max_range_m = 30;
  est.mono_prior_depth_m = 4;
  est.min_reciprocal_condition = 1.0e-10;
  est.max_position_sigma_m = 0.5;
  est.usable_horizon_s = 0.3;
  est.compute_covariance = false;
  est.max_iterations = 25;
  est.function_tolerance = 1.0e-8;
  est.parameter_tolerance = 1.0e-9;

  PerceptionOptions top;
  top.windows.window_ns = 20'000'000;
  top.windows.max_events_per_window = 500'000;
  top.windows.max_empty_windows = 80;
  top.threads = 2;
  top.monocular_baseline = false;
  top.estimate_aided_association = false;
  top.depth_since_first_detection = false;
  top.depth_before_first_detection_ns = 20'500'000;
  top.estimate_trajectories = false;
  top.assume_static_vehicle = true;
  top.max_lateness_ns = 30'000'000;
  top.odometry_max_extrapolation_ns = 15'500'000;
  top.depth_registration.min_depth_m = 0.2;
  top.depth_registration.max_depth_m = 12;
  top.prediction.horizon_s = 1.5;
  top.prediction.safety_radius_m = 0.75;

  EXPECT_THAT(compare(o.compensation, comp).different, IsEmpty());
  EXPECT_THAT(compare(o.tracking, tracking).different, IsEmpty());
  EXPECT_THAT(compare(o.depth_segmentation, depth).different, IsEmpty());
  EXPECT_THAT(compare(o.estimation, est).different, IsEmpty());
  EXPECT_THAT(compare_top(o, top).different, IsEmpty());
  EXPECT_EQ(o.estimation.mode, EstimatorMode::kFusion);

  // The file sets every key to a non-default value, so a key the loader ignored cannot pass.
  EXPECT_THAT(compare(comp, CompensationOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare(tracking, TrackerOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare(depth, DepthSegmentationOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare(est, EstimatorOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare_top(top, PerceptionOptions{}).equal, IsEmpty());
}

TEST(Options, DetectorKeysFillTheirFields) {
  const DetectorOptions d = load(R"(
detector:
  threshold_a_s_per_rad: 0.03
  threshold_b_s_per_m: 0.05
  threshold_c: 0.2
  opening_px: 7
  min_peak: 0.3
  refine_box_scale: 0
  refine_recenter_passes: 2
  square_box: false
  fit_max_iterations: 12
  roi_min_events: 11
  prior_min_peak: 0.5
  dense_motion: false
  dense_motion_radius_px: 7
  dense_motion_min_pixels: 9
  dense_motion_min_r2: 0.35
  count_contrast: false
  count_contrast_box_px: 7
  count_contrast_surround_scale: 2.5
  count_contrast_min_contrast: 4
  count_contrast_min_fill: 0.7
  count_contrast_in_gates: false
  count_contrast_still_motion: 0.02
  count_contrast_still_isolation: 6
  count_contrast_still_motion_z: 3
)").detection;
  EXPECT_DOUBLE_EQ(d.threshold_a_s_per_rad, 0.03);
  EXPECT_DOUBLE_EQ(d.threshold_b_s_per_m, 0.05);
  EXPECT_DOUBLE_EQ(d.threshold_c, 0.2);
  EXPECT_EQ(d.opening_px, 7);
  EXPECT_DOUBLE_EQ(d.gaussian_fit.min_peak, 0.3);
  EXPECT_DOUBLE_EQ(d.refine_box_scale, 0.0);
  EXPECT_EQ(d.refine_recenter_passes, 2);
  EXPECT_FALSE(d.square_box);
  EXPECT_EQ(d.fit_max_iterations, 12);
  EXPECT_EQ(d.roi_min_events, 11);
  EXPECT_DOUBLE_EQ(d.track_aided.min_peak, 0.5);
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
  EXPECT_DOUBLE_EQ(d.count_contrast.still_motion, 0.02);
  EXPECT_DOUBLE_EQ(d.count_contrast.still_min_isolation, 6.0);
  EXPECT_DOUBLE_EQ(d.count_contrast.still_min_motion_z, 3.0);
  EXPECT_EQ(d.mean_filter_px, DetectorOptions{}.mean_filter_px);  // absent: default kept
}

TEST(Options, EmptyFilesAndNullSectionsGiveDefaults) {
  for (const char* content : {"", "# only a comment\n", "tracking:\nestimation:\nprediction: {}\n"}) {
    const PerceptionOptions o = load(content);
    EXPECT_EQ(to_yaml(o), to_yaml(PerceptionOptions{})) << content;
    EXPECT_EQ(o.estimation.event_focal_px, 0.0);  // 0 = Perception takes it from the calibration
  }
}

TEST(Options, WrittenYamlReadsBackToTheSameOptions) {
  for (const std::string& yaml : {std::string(), std::string(kFullConfig)}) {
    const PerceptionOptions a = load(yaml);
    const std::string text = to_yaml(a);
    const PerceptionOptions b = load(text);
    EXPECT_EQ(to_yaml(b), text);
    EXPECT_THAT(compare(b.tracking, a.tracking).different, IsEmpty());
    EXPECT_THAT(compare(b.estimation, a.estimation).different, IsEmpty());
    EXPECT_THAT(compare(b.compensation, a.compensation).different, IsEmpty());
    EXPECT_THAT(compare_top(b, a).different, IsEmpty());
  }
  // Durations that are no round number of ms, and doubles with no short decimal form.
  PerceptionOptions o;
  o.tracking.max_gap_ns = 123'456'789;
  o.max_lateness_ns = 1;
  o.tracking.box_smoothing = 0.1 + 0.2;
  const PerceptionOptions back = load(to_yaml(o));
  EXPECT_EQ(back.tracking.max_gap_ns, 123'456'789);
  EXPECT_EQ(back.max_lateness_ns, 1);
  EXPECT_EQ(back.tracking.box_smoothing, 0.1 + 0.2);
}

/// The keys of a YAML map and of a JSON object, recursively: "a", "b.c", ...
void yaml_keys(const YAML::Node& n, const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& kv : n) {
    out.push_back(prefix + kv.first.Scalar());
    if (kv.second.IsMap()) yaml_keys(kv.second, prefix + kv.first.Scalar() + ".", out);
  }
}
void json_keys(const nlohmann::json& j, const std::string& prefix, std::vector<std::string>& out) {
  for (const auto& [key, value] : j.items()) {
    out.push_back(prefix + key);
    if (value.is_object()) json_keys(value, prefix + key + ".", out);
  }
}

TEST(Options, JsonHasTheKeysAndValuesOfTheYaml) {
  const PerceptionOptions o = load(kFullConfig);
  const nlohmann::json j = to_json(o);
  std::vector<std::string> from_yaml, from_json;
  yaml_keys(YAML::Load(to_yaml(o)), "", from_yaml);
  json_keys(j, "", from_json);
  std::sort(from_yaml.begin(), from_yaml.end());
  std::sort(from_json.begin(), from_json.end());
  EXPECT_EQ(from_json, from_yaml);
  EXPECT_EQ(j.at("compensation").at("method"), "rotation");
  EXPECT_EQ(j.at("tracking").at("max_gap_ms"), 80.0);
  EXPECT_EQ(j.at("threads"), 2);
  EXPECT_EQ(j.at("estimation").at("gravity"), nlohmann::json({0.1, -0.2, -9.8}));
  EXPECT_TRUE(j.at("detector").is_object());
}

// summary.json's "detector_in_use": the detector section with the gates scaled to the camera
// (fx 250 against gate_focal_px 500: half the density, the 4.5 px box rounded to 5), the rest and
// "options" as given.
TEST(Options, DetectorInUseHoldsTheGatesScaledToTheCamera) {
  PerceptionOptions o;
  o.detection.min_event_density = 1.5;
  o.detection.count_contrast.box_px = 9;
  o.detection.gate_focal_px = 500;
  PinholeCamera camera;
  camera.width = 346;
  camera.height = 260;
  camera.fx = camera.fy = 250;
  camera.cx = 173;
  camera.cy = 130;
  const nlohmann::json in_use = detector_in_use(o, camera);
  EXPECT_DOUBLE_EQ(in_use.at("min_event_density").get<double>(), 0.75);
  EXPECT_EQ(in_use.at("count_contrast_box_px"), 5);
  nlohmann::json as_given = to_json(o).at("detector");
  EXPECT_DOUBLE_EQ(as_given.at("min_event_density").get<double>(), 1.5);
  as_given["min_event_density"] = 0.75;
  as_given["count_contrast_box_px"] = 5;
  EXPECT_EQ(in_use, as_given);
}

/// "where | reason" of the InputError that loading `yaml` raises.
std::string error_of(const std::string& yaml) { return test::input_error_of("cfg.yaml", [&] { load(yaml); }); }

TEST(Options, MovedKeysSayWhereTheOptionWent) {
  EXPECT_EQ(error_of("compensation: {threads: 2}"),
            "key compensation.threads | moved to the top-level key threads (used by the compensation and "
            "the detector)");
  EXPECT_EQ(error_of("compensation: {max_events_per_window: 123456}"),
            "key compensation.max_events_per_window | moved to the top-level key max_events_per_window (the "
            "event windower's overload guard, which acts first)");
  EXPECT_EQ(error_of("estimation: {mode: monocular}"),
            "key estimation.mode | not configurable: the pipeline runs fusion, and the monocular "
            "baseline beside it when monocular_baseline is true");
}

// The detector's keys took their source's name (and "center"): an old key names its new one.
TEST(Options, RenamedDetectorKeysNameTheNewKey) {
  EXPECT_EQ(error_of("detector: {motion_cue: false}"), "key detector.motion_cue | renamed dense_motion");
  EXPECT_EQ(error_of("detector: {motion_cue_min_r2: 0.3}"),
            "key detector.motion_cue_min_r2 | renamed dense_motion_min_r2");
  EXPECT_EQ(error_of("detector: {count_cue: false}"), "key detector.count_cue | renamed count_contrast");
  EXPECT_EQ(error_of("detector: {count_cue_still_motion_z: 3}"),
            "key detector.count_cue_still_motion_z | renamed count_contrast_still_motion_z");
  EXPECT_EQ(error_of("detector: {refine_recentre_passes: 2}"),
            "key detector.refine_recentre_passes | renamed refine_recenter_passes");
}

TEST(Options, UnknownKeysNameTheKey) {
  EXPECT_THAT(error_of("tracking: {gate_chi3: 1}"), HasSubstr("key tracking.gate_chi3 | unknown key (known here: "));
  EXPECT_THAT(error_of("tracking: {filter: {sigma_px: 1}}"), HasSubstr("key tracking.filter.sigma_px | unknown key"));
  EXPECT_THAT(error_of("depth_segmentation: {noise: {fx: 1}}"),
              HasSubstr("key depth_segmentation.noise.fx | unknown key"));
  EXPECT_THAT(error_of("compensation: {contrast_max: {sigma: 1}}"),
              HasSubstr("key compensation.contrast_max.sigma | unknown key"));
  EXPECT_THAT(error_of("detector: {threshold_d: 1}"), HasSubstr("key detector.threshold_d | unknown key"));
  // A duration under its struct name, in ns, is not a key: YAML durations are in ms.
  EXPECT_THAT(error_of("estimation: {max_lateness_ns: 1}"), HasSubstr("key estimation.max_lateness_ns | unknown key"));
  EXPECT_THAT(error_of("estimator: {}"),
              HasSubstr("key estimator | unknown key (known here: assume_static_vehicle, compensation, "));
}

TEST(Options, WrongTypesNameTheKey) {
  EXPECT_EQ(error_of("prediction: {horizon_s: soon}"), "key prediction.horizon_s | 'soon' is not a number");
  EXPECT_EQ(error_of("tracking: {max_tracks: 2.5}"), "key tracking.max_tracks | '2.5' is not an integer");
  EXPECT_EQ(error_of("detector: {opening_px: 2.5}"), "key detector.opening_px | '2.5' is not an integer");
  EXPECT_EQ(error_of("estimation: {compute_covariance: sometimes}"),
            "key estimation.compute_covariance | 'sometimes' is not true or false");
  EXPECT_EQ(error_of("monocular_baseline: 2"), "key monocular_baseline | '2' is not true or false");
  EXPECT_EQ(error_of("window_ms: [25]"), "key window_ms | expected a number");
  EXPECT_EQ(error_of("tracking: {filter: 3}"), "key tracking.filter | expected a mapping of keys");
  EXPECT_EQ(error_of("prediction: [1, 2]"), "key prediction | expected a mapping of keys");
  EXPECT_EQ(error_of("compensation: {method: betterflow}"),
            "key compensation.method | 'betterflow' is not one of none, rotation, rotation_translation, contrast_max");
  EXPECT_EQ(error_of("compensation: {missing_depth: zero}"),
            "key compensation.missing_depth | 'zero' is not one of median_depth, rotation_only, beyond_range");
  EXPECT_EQ(error_of("max_empty_windows: -1"), "key max_empty_windows | '-1' is not a non-negative integer");
  EXPECT_EQ(error_of("estimation: {gravity: [0, -9.81]}"), "key estimation.gravity | expected a list of 3 numbers");
  EXPECT_EQ(error_of("estimation: {gravity: -9.81}"), "key estimation.gravity | expected a list of 3 numbers");
  EXPECT_EQ(error_of("estimation: {gravity: [0, 0, down]}"), "key estimation.gravity[2] | 'down' is not a number");
  EXPECT_EQ(error_of("estimation: {gravity: [0, 0, .nan]}"), "key estimation.gravity[2] | must be finite");
  EXPECT_EQ(error_of("tracking: {max_gap_ms: 1e300}"), "key tracking.max_gap_ms | duration out of range");
  // Block style works as well as flow style, and integers may be written as whole numbers.
  const PerceptionOptions o = load("estimation:\n  gravity:\n    - 0\n    - 0\n    - -9.7\ntracking: {max_tracks: 3.0}\n");
  EXPECT_EQ(o.estimation.gravity_W, Eigen::Vector3d(0, 0, -9.7));
  EXPECT_EQ(o.tracking.max_tracks, 3);
}

TEST(Options, InvalidValuesNameTheSectionAndTheYamlKey) {
  // validate() failures: `where` is the section, the reason names the key as written in YAML.
  EXPECT_EQ(error_of("tracking: {gate_chi2: -1}"), "key tracking | gate_chi2 must be > 0");
  EXPECT_EQ(error_of("tracking: {max_gap_ms: 0}"), "key tracking | max_gap_ms must be > 0");
  EXPECT_EQ(error_of("tracking: {tentative_max_gap_ms: -5}"), "key tracking | tentative_max_gap_ms must be > 0");
  EXPECT_EQ(error_of("tracking: {filter: {measurement_sigma_px: 0}}"),
            "key tracking.filter | measurement_sigma_px must be > 0");
  EXPECT_EQ(error_of("depth_segmentation: {min_depth_m: 5, max_depth_m: 4}"),
            "key depth_segmentation | need 0 <= min_depth_m < max_depth_m");
  EXPECT_THAT(error_of("depth_segmentation: {noise: {baseline_m: 0}}"), HasSubstr("key depth_segmentation.noise | "));
  EXPECT_EQ(error_of("estimation: {max_lateness_ms: -1}"), "key estimation | max_lateness_ms must be >= 0");
  EXPECT_EQ(error_of("estimation: {huber_depth: 0}"), "key estimation | huber thresholds must be > 0");
  EXPECT_EQ(error_of("estimation: {event_focal_px: -300}"),
            "key estimation | event_focal_px must be >= 0 (0 = the calibration's)");
  EXPECT_EQ(error_of("prediction: {safety_radius_m: -0.1}"), "key prediction | safety_radius_m must be >= 0");
  EXPECT_THAT(error_of("compensation: {max_imu_gap_ms: 0}"), HasSubstr("key compensation | max_imu_gap_ms must be positive"));
  EXPECT_THAT(error_of("detector: {opening_px: 4}"), HasSubstr("key detector | opening_px must be odd"));
  EXPECT_EQ(error_of("window_ms: 0"), " | window_ms must be positive");
  // 1e8 ms once allocated 3.7 GB, 1e9 ms threw std::bad_alloc.
  EXPECT_EQ(error_of("window_ms: 1000.5"), " | window_ms must be at most 1000 (a window's buffers grow with its length)");
  EXPECT_EQ(error_of("window_ms: 1e9"), " | window_ms must be at most 1000 (a window's buffers grow with its length)");
  EXPECT_EQ(error_of("step_ms: 30"), " | step_ms must be in [0, window_ms] (0 = window_ms)");
  EXPECT_EQ(error_of("step_ms: 10"), " | window_ms must be a multiple of step_ms");
  EXPECT_EQ(error_of("step_ms: 0.5"), " | step_ms must be at least window_ms / 25 (each window is computed anew)");
  EXPECT_EQ(error_of("step_ms: 1"), "no error");  // 25 windows per event: the most
  EXPECT_EQ(error_of("max_events_per_window: 0"), " | max_events_per_window must be positive");
  EXPECT_EQ(error_of("threads: 0"), " | threads must be in [1, 64], got 0");
  EXPECT_EQ(error_of("max_lateness_ms: -1"), " | max_lateness_ms must not be negative");
  EXPECT_EQ(error_of("odometry_max_extrapolation_ms: -2"), " | odometry_max_extrapolation_ms must not be negative");
  EXPECT_EQ(error_of("depth_before_first_detection_ms: -3"), " | depth_before_first_detection_ms must not be negative");
}

TEST(Options, ErrorsFromAFileNameThatFile) {
  const std::string dir = test::scratch_dir("options_file");
  const std::string path = dir + "/bad.yaml";
  std::ofstream(path) << "tracking:\n  gate_chi2: -1\n";
  try {
    load_perception_options_file(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":key tracking: gate_chi2 must be > 0");
  }
  std::ofstream(dir + "/ok.yaml") << "tracking:\n  max_tracks: 3\n";
  EXPECT_EQ(load_perception_options_file(dir + "/ok.yaml").tracking.max_tracks, 3);
  EXPECT_EQ(test::input_error_of(dir + "/missing.yaml", [&] { load_perception_options_file(dir + "/missing.yaml"); }),
            " | cannot open the file");
}

TEST(Options, MalformedStructureNamesFileAndKey) {
  // f9: a non-scalar key let yaml-cpp's "bad conversion" out, naming no file.
  EXPECT_EQ(error_of("? [a]\n: 1\n"), "key ? | a key must be a plain name, not a list or map (line 1)");
  EXPECT_EQ(error_of("tracking:\n  {a: 1}: 2\n"), "key tracking.? | a key must be a plain name, not a list or map (line 2)");
  EXPECT_EQ(error_of("compensation:\n  contrast_max:\n    [x]: 1\n"),
            "key compensation.contrast_max.? | a key must be a plain name, not a list or map (line 3)");
  EXPECT_EQ(error_of("7\n"), " | an options file must be a mapping of keys");
  EXPECT_EQ(error_of("- tracking\n"), " | an options file must be a mapping of keys");
  EXPECT_EQ(error_of("tracking: {gate_chi2: [1]}\n"), "key tracking.gate_chi2 | expected a number");
  EXPECT_EQ(error_of("tracking: {gate_chi2: [1\n").substr(0, 7), "line 2,");
  EXPECT_NE(error_of("tracking: " + std::string(60000, '{')).find("| nested deeper than"), std::string::npos);
  EXPECT_EQ(error_of(std::string(kMaxConfigFileBytes + 1, ' ')), " | larger than 1048576 bytes: not a configuration file");
}

TEST(Options, ADuplicateKeyIsAnErrorNamingItAndBothLines) {
  // yaml-cpp keeps both and finds the first: the second value was lost without a word.
  EXPECT_EQ(error_of("window_ms: 10\nthreads: 1\nwindow_ms: 20\n"),
            "line 3, column 1 | duplicate key 'window_ms' (first at line 1, column 1)");
  EXPECT_EQ(error_of("tracking:\n  gate_chi2: 9\n  gate_chi2: 12\n"),
            "line 3, column 3 | duplicate key 'gate_chi2' (first at line 2, column 3)");
}

TEST(Options, FuzzFindingNonScalarKey) {
  const auto path = test::fuzz_finding("options/f9-non-scalar-key.yaml");
  FDV_REQUIRE_REAL_FILE(path);
  EXPECT_EQ(test::input_error_of(path, [&] { load_perception_options_file(path); }),
            "key ? | a key must be a plain name, not a list or map (line 1)");
}

// ---- The docs' key tables are the field list's (regenerate: FDV_WRITE_OPTIONS_DOCS=1 options_test).

// Not from __FILE__: ccache's base_dir makes it relative to the build directory.
const std::filesystem::path kDocs = std::filesystem::path(FDV_SOURCE_DIR) / "docs";

/// Where each section's table lives: between `<!-- options.NAME:begin -->` and `<!-- options.NAME:end -->`.
struct DocsTable {
  const char* section;  ///< "" = the top level
  const char* file;
};
constexpr DocsTable kDocsTables[] = {
    {"compensation", "DETECTION.md"},     {"detector", "DETECTION.md"},  {"depth_registration", "DETECTION.md"},
    {"", "ESTIMATION.md"},                {"tracking", "ESTIMATION.md"}, {"looming", "ESTIMATION.md"}, {"depth_segmentation", "ESTIMATION.md"},
    {"estimation", "ESTIMATION.md"},      {"prediction", "ESTIMATION.md"}, {"dodge", "AVOIDANCE.md"},
};

std::string marker(const std::string& section, const char* end) {
  return "<!-- options." + (section.empty() ? std::string("top") : section) + ":" + end + " -->\n";
}

TEST(Options, DocsTablesAreTheFieldLists) {
  const bool write = std::getenv("FDV_WRITE_OPTIONS_DOCS") != nullptr;
  std::vector<std::string> covered;
  for (const DocsTable& t : kDocsTables) {
    SCOPED_TRACE(t.file + std::string(" ") + t.section);
    covered.push_back(t.section);
    const auto path = kDocs / t.file;
    std::ifstream in(path);
    ASSERT_TRUE(in.good()) << path;
    std::stringstream buffer;
    buffer << in.rdbuf();
    std::string doc = buffer.str();
    const std::string begin = marker(t.section, "begin"), end = marker(t.section, "end");
    const std::size_t b = doc.find(begin), e = doc.find(end);
    ASSERT_NE(b, std::string::npos) << "no " << begin;
    ASSERT_NE(e, std::string::npos) << "no " << end;
    const std::string expected = options_markdown_table(t.section);
    const std::string actual = doc.substr(b + begin.size(), e - b - begin.size());
    if (write && actual != expected) {
      doc.replace(b + begin.size(), e - b - begin.size(), expected);
      std::ofstream(path) << doc;
      continue;
    }
    EXPECT_EQ(actual, expected) << "docs/" << t.file << " differs from the field list: FDV_WRITE_OPTIONS_DOCS=1 "
                                << "options_test rewrites it";
  }
  std::vector<std::string> sections = options_sections();
  std::sort(covered.begin(), covered.end());
  std::sort(sections.begin(), sections.end());
  EXPECT_EQ(covered, sections) << "every section needs its table in the docs";
}

}  // namespace
}  // namespace fdv
