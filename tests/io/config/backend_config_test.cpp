// YAML loading of the back end's options and of the whole PerceptionOptions (`fdv run --config`).
#include "fdv/io/config/backend_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <string>
#include <vector>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
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

FieldComparison compare(const PredictionOptions& a, const PredictionOptions& b) {
  FieldComparison r;
  FDV_COMPARE_FIELD(horizon_s);
  FDV_COMPARE_FIELD(safety_radius_m);
  return r;
}

/// The top-level scalars, and one field of each front-end section (their loaders have their own
/// tests in tests/detection/frontend_config_test.cpp; here only that they are wired in).
FieldComparison compare_top(const PerceptionOptions& a, const PerceptionOptions& b) {
  FieldComparison r;
  FDV_COMPARE_FIELD(windows.window_ns);
  FDV_COMPARE_FIELD(windows.max_empty_windows);
  FDV_COMPARE_FIELD(monocular_baseline);
  FDV_COMPARE_FIELD(estimate_aided_association);
  FDV_COMPARE_FIELD(depth_since_first_detection);
  FDV_COMPARE_FIELD(estimate_trajectories);
  FDV_COMPARE_FIELD(max_lateness_ns);
  FDV_COMPARE_FIELD(odometry_max_extrapolation_ns);
  FDV_COMPARE_FIELD(compensation.method);
  FDV_COMPARE_FIELD(compensation.max_imu_gap_ns);
  FDV_COMPARE_FIELD(detection.threshold_c);
  FDV_COMPARE_FIELD(detection.min_pixel_events);
  FDV_COMPARE_FIELD(depth_registration.max_depth_m);
  return r;
}
#undef FDV_COMPARE_FIELD

constexpr const char* kFullConfig = R"(
window_ms: 20
max_empty_windows: 80
monocular_baseline: false
estimate_aided_association: false
depth_since_first_detection: false
estimate_trajectories: false
max_lateness_ms: 30
odometry_max_extrapolation_ms: 15.5
compensation: {method: rotation, max_imu_gap_ms: 12}
detector: {threshold_c: 0.2, min_pixel_events: 1}
depth_registration: {max_depth_m: 12}
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

TEST(BackendConfig, FullFileRoundTripsEveryKey) {
  const PerceptionOptions o = load_perception_options(YAML::Load(kFullConfig), "cfg.yaml");

  // Expected values written out by hand from kFullConfig (durations: ms -> ns).
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

  PredictionOptions pred;
  pred.horizon_s = 1.5;
  pred.safety_radius_m = 0.75;

  PerceptionOptions top;
  top.windows.window_ns = 20'000'000;
  top.windows.max_empty_windows = 80;
  top.monocular_baseline = false;
  top.estimate_aided_association = false;
  top.depth_since_first_detection = false;
  top.estimate_trajectories = false;
  top.max_lateness_ns = 30'000'000;
  top.odometry_max_extrapolation_ns = 15'500'000;
  top.compensation.method = "rotation";
  top.compensation.max_imu_gap_ns = 12'000'000;
  top.detection.threshold_c = 0.2;
  top.detection.min_pixel_events = 1;
  top.depth_registration.max_depth_m = 12;

  EXPECT_THAT(compare(o.tracking, tracking).different, IsEmpty());
  EXPECT_THAT(compare(o.depth_segmentation, depth).different, IsEmpty());
  EXPECT_THAT(compare(o.estimation, est).different, IsEmpty());
  EXPECT_THAT(compare(o.prediction, pred).different, IsEmpty());
  EXPECT_THAT(compare_top(o, top).different, IsEmpty());
  EXPECT_EQ(o.estimation.mode, EstimatorMode::kFusion);

  // The file sets every key to a non-default value, so a key the loader ignored cannot pass.
  EXPECT_THAT(compare(tracking, TrackerOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare(depth, DepthSegmentationOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare(est, EstimatorOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare(pred, PredictionOptions{}).equal, IsEmpty());
  EXPECT_THAT(compare_top(top, PerceptionOptions{}).equal, IsEmpty());
}

TEST(BackendConfig, SectionLoadersReadTheirSectionAlone) {
  const YAML::Node root = YAML::Load(kFullConfig);
  EXPECT_EQ(load_tracker_options(root["tracking"], "cfg.yaml").max_tracks, 4);
  EXPECT_EQ(load_depth_segmentation_options(root["depth_segmentation"], "cfg.yaml").max_peaks, 2);
  EXPECT_EQ(load_estimator_options(root["estimation"], "cfg.yaml").max_iterations, 25);
  EXPECT_DOUBLE_EQ(load_prediction_options(root["prediction"], "cfg.yaml").horizon_s, 1.5);
}

TEST(BackendConfig, EmptyFileGivesAllDefaults) {
  const std::string dir = test::scratch_dir("backend_config_empty");
  for (const char* content : {"", "# only a comment\n"}) {
    const std::string path = dir + "/empty.yaml";
    std::ofstream(path) << content;
    const PerceptionOptions o = load_perception_options(YAML::LoadFile(path), path);
    const PerceptionOptions d;
    EXPECT_THAT(compare(o.tracking, d.tracking).different, IsEmpty());
    EXPECT_THAT(compare(o.depth_segmentation, d.depth_segmentation).different, IsEmpty());
    EXPECT_THAT(compare(o.estimation, d.estimation).different, IsEmpty());
    EXPECT_THAT(compare(o.prediction, d.prediction).different, IsEmpty());
    EXPECT_THAT(compare_top(o, d).different, IsEmpty());
    EXPECT_EQ(o.estimation.event_focal_px, 0.0);  // 0 = Perception takes it from the calibration
  }
}

TEST(BackendConfig, NullSectionsGiveDefaults) {
  const PerceptionOptions o =
      load_perception_options(YAML::Load("tracking:\nestimation:\nprediction: {}\n"), "cfg.yaml");
  EXPECT_EQ(o.tracking.max_gap_ns, TrackerOptions{}.max_gap_ns);
  EXPECT_EQ(o.estimation.gravity_W, EstimatorOptions{}.gravity_W);
  EXPECT_EQ(o.prediction.horizon_s, PredictionOptions{}.horizon_s);
}

/// "where | reason" of the InputError that loading `yaml` raises; the file must be cfg.yaml and
/// the full message must contain both.
std::string error_of(const std::string& yaml) {
  try {
    load_perception_options(YAML::Load(yaml), "cfg.yaml");
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "cfg.yaml");
    EXPECT_EQ(std::string(e.what()),
              "cfg.yaml" + (e.where().empty() ? "" : ":" + e.where()) + ": " + e.reason());
    return e.where() + " | " + e.reason();
  }
  return "no error";
}

TEST(BackendConfig, UnknownKeysNameTheKey) {
  EXPECT_EQ(error_of("tracking: {gate_chi3: 1}"), "key tracking.gate_chi3 | unknown key");
  EXPECT_EQ(error_of("tracking: {filter: {sigma_px: 1}}"),
            "key tracking.filter.sigma_px | unknown key");
  EXPECT_EQ(error_of("depth_segmentation: {noise: {fx: 1}}"),
            "key depth_segmentation.noise.fx | unknown key");
  // A duration under its struct name, in ns, is not a key: YAML durations are in ms.
  EXPECT_EQ(error_of("estimation: {max_lateness_ns: 1}"),
            "key estimation.max_lateness_ns | unknown key");
  EXPECT_EQ(error_of("estimation: {mode: monocular}"),
            "key estimation.mode | not configurable: the pipeline runs fusion, and the monocular "
            "baseline beside it when monocular_baseline is true");
  EXPECT_EQ(error_of("estimator: {}"),
            "key estimator | unknown section (expected compensation, depth_registration, "
            "depth_segmentation, depth_since_first_detection, detector, estimate_aided_association, "
            "estimate_trajectories, estimation, max_empty_windows, max_lateness_ms, monocular_baseline, "
            "odometry_max_extrapolation_ms, prediction, tracking, window_ms)");
  // Front-end sections go through the same function.
  EXPECT_EQ(error_of("detector: {threshold_d: 1}"), "key detector.threshold_d | unknown key");
}

TEST(BackendConfig, WrongTypesNameTheKey) {
  EXPECT_EQ(error_of("prediction: {horizon_s: soon}"),
            "key prediction.horizon_s | expected a number, got 'soon'");
  EXPECT_EQ(error_of("tracking: {max_tracks: 2.5}"),
            "key tracking.max_tracks | expected an integer, got '2.5'");
  EXPECT_EQ(error_of("estimation: {compute_covariance: sometimes}"),
            "key estimation.compute_covariance | expected true or false, got 'sometimes'");
  EXPECT_EQ(error_of("monocular_baseline: 2"),
            "key monocular_baseline | expected true or false, got '2'");
  EXPECT_EQ(error_of("window_ms: [25]"), "key window_ms | expected a number, got '(not a scalar)'");
  EXPECT_EQ(error_of("tracking: {filter: 3}"), "key tracking.filter | expected a map of options");
  EXPECT_EQ(error_of("prediction: [1, 2]"), "key prediction | expected a map of options");
  EXPECT_EQ(error_of("- tracking"), " | expected a map of options");
}

TEST(BackendConfig, GravityMustBeThreeNumbers) {
  EXPECT_EQ(error_of("estimation: {gravity: [0, -9.81]}"),
            "key estimation.gravity | expected a list of 3 numbers, got 2");
  EXPECT_EQ(error_of("estimation: {gravity: [0, 0, -9.81, 0]}"),
            "key estimation.gravity | expected a list of 3 numbers, got 4");
  EXPECT_EQ(error_of("estimation: {gravity: -9.81}"),
            "key estimation.gravity | expected a list of 3 numbers");
  EXPECT_EQ(error_of("estimation: {gravity: [0, 0, down]}"),
            "key estimation.gravity[2] | expected a number, got 'down'");
  EXPECT_EQ(error_of("estimation: {gravity: [0, 0, .nan]}"),
            "key estimation.gravity[2] | expected a finite number");
  // Block style works as well as flow style.
  const PerceptionOptions o = load_perception_options(
      YAML::Load("estimation:\n  gravity:\n    - 0\n    - 0\n    - -9.7\n"), "cfg.yaml");
  EXPECT_EQ(o.estimation.gravity_W, Eigen::Vector3d(0, 0, -9.7));
}

TEST(BackendConfig, InvalidValuesNameTheFileAndKey) {
  // validate() failures: `where` is the section, the reason names the key as written in YAML.
  EXPECT_EQ(error_of("tracking: {gate_chi2: -1}"), "key tracking | gate_chi2 must be > 0");
  EXPECT_EQ(error_of("tracking: {max_gap_ms: 0}"), "key tracking | max_gap_ms must be > 0");
  EXPECT_EQ(error_of("tracking: {tentative_max_gap_ms: -5}"),
            "key tracking | tentative_max_gap_ms must be > 0");
  EXPECT_EQ(error_of("tracking: {filter: {measurement_sigma_px: 0}}"),
            "key tracking.filter | measurement_sigma_px must be > 0");
  EXPECT_EQ(error_of("depth_segmentation: {min_depth_m: 5, max_depth_m: 4}"),
            "key depth_segmentation | need 0 <= min_depth_m < max_depth_m");
  EXPECT_THAT(error_of("depth_segmentation: {noise: {baseline_m: 0}}"),
              HasSubstr("key depth_segmentation.noise | "));
  EXPECT_EQ(error_of("estimation: {max_lateness_ms: -1}"),
            "key estimation | max_lateness_ms must be >= 0");
  EXPECT_EQ(error_of("estimation: {huber_depth: 0}"),
            "key estimation | huber thresholds must be > 0");
  EXPECT_EQ(error_of("estimation: {event_focal_px: -300}"),
            "key estimation.event_focal_px | must be >= 0 (0 = the calibration's focal length)");
  EXPECT_EQ(error_of("prediction: {safety_radius_m: -0.1}"),
            "key prediction | safety_radius_m must be >= 0");
  EXPECT_EQ(error_of("window_ms: 0"), "key window_ms | must be > 0");
  EXPECT_EQ(error_of("max_empty_windows: -1"), "key max_empty_windows | must be >= 0");
  EXPECT_EQ(error_of("max_lateness_ms: -1"), "key max_lateness_ms | must be >= 0");
  EXPECT_EQ(error_of("odometry_max_extrapolation_ms: -2"),
            "key odometry_max_extrapolation_ms | must be >= 0");
  // The front end's validation goes through the same path.
  EXPECT_THAT(error_of("detector: {opening_px: 4}"),
              HasSubstr("key detector | opening_px must be odd"));
}

TEST(BackendConfig, ErrorsFromAFileNameThatFile) {
  const std::string dir = test::scratch_dir("backend_config_file");
  const std::string path = dir + "/bad.yaml";
  std::ofstream(path) << "tracking:\n  gate_chi2: -1\n";
  try {
    load_perception_options(YAML::LoadFile(path), path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":key tracking: gate_chi2 must be > 0");
  }
}

/// "where | reason" of load_perception_options_text on `yaml` (named "cfg.yaml").
std::string text_error_of(const std::string& yaml) {
  return test::input_error_of("cfg.yaml", [&] { load_perception_options_text(yaml, "cfg.yaml"); });
}

TEST(BackendConfig, MalformedStructureNamesFileAndKey) {
  // f9: a non-scalar key let yaml-cpp's "bad conversion" out, naming no file.
  EXPECT_EQ(text_error_of("? [a]\n: 1\n"), "key ? | a key must be a plain name, not a list or map (line 1)");
  EXPECT_EQ(text_error_of("tracking:\n  {a: 1}: 2\n"),
            "key tracking.? | a key must be a plain name, not a list or map (line 2)");
  EXPECT_EQ(text_error_of("compensation:\n  contrast_max:\n    [x]: 1\n"),
            "key compensation.contrast_max.? | a key must be a plain name, not a list or map (line 3)");
  EXPECT_EQ(text_error_of("7\n"), " | expected a map of options");
  EXPECT_EQ(text_error_of("- tracking\n"), " | expected a map of options");
  EXPECT_EQ(text_error_of("tracking: [1, 2]\n"), "key tracking | expected a map of options");
  EXPECT_EQ(text_error_of("tracking: {gate_chi2: [1]}\n"),
            "key tracking.gate_chi2 | expected a number, got '(not a scalar)'");
  EXPECT_EQ(text_error_of("window_ms: {a: 1}\n"),
            "key window_ms | expected a number, got '(not a scalar)'");
  EXPECT_EQ(text_error_of("tracking: {gate_chi2: [1\n").substr(0, 7), "line 2,");
  EXPECT_NE(text_error_of("tracking: " + std::string(60000, '{')).find("| nested deeper than"),
            std::string::npos);
  EXPECT_EQ(text_error_of(std::string(kMaxConfigFileBytes + 1, ' ')),
            " | larger than 1048576 bytes: not a configuration file");
  EXPECT_EQ(text_error_of(""), "no error");
}

TEST(BackendConfig, FuzzFindingNonScalarKey) {
  const auto path = test::fuzz_finding("options/f9-non-scalar-key.yaml");
  FDV_REQUIRE_REAL_FILE(path);
  try {
    load_perception_options_file(path);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.where(), "key ?");
    EXPECT_EQ(e.reason(), "a key must be a plain name, not a list or map (line 1)");
  }
}

TEST(BackendConfig, FileLoaderReadsWhatTheTextLoaderReads) {
  const std::string dir = test::scratch_dir("backend_config_file_loader");
  const std::string path = dir + "/ok.yaml";
  std::ofstream(path) << "tracking:\n  max_tracks: 3\n";
  EXPECT_EQ(load_perception_options_file(path).tracking.max_tracks, 3);
  try {
    load_perception_options_file(dir + "/missing.yaml");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.reason(), "cannot open the file");
  }
}

}  // namespace
}  // namespace fdv
