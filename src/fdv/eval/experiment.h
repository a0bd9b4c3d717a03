#pragma once
/// Running the pipeline for an experiment: replaying a recording through fdv::Perception, a cache
/// of simulated datasets, and one run over a simulated dataset that keeps what the evaluation
/// needs (detections, per-window timings, relative contrast, converged estimates, usable flagged)
/// in memory.
///
///   const std::string dir = ensure_simulated("scene2_ball", 101, "out/cache");   // simulates once
///   const DatasetTruth truth = load_dataset_truth(dir);
///   ExperimentOptions o;
///   o.perception.compensation.method = "rotation";
///   o.relative_contrast = true;
///   ExperimentRun run = run_experiment(truth, o);
///   detection_metrics(truth, run.windows);  summarize(run.relative_contrast);
///
/// Unlike the rest of eval (core only), this file drives the pipeline, the simulator and the
/// readers. Timings are wall-clock and depend on the machine's load; they are never unit-tested.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fdv/eval/dataset_truth.h"
#include "fdv/eval/detection_metrics.h"
#include "fdv/eval/estimate_metrics.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/perception.h"
#include "fdv/sim/scenario_config.h"

namespace fdv {

/// Feeds every stream of `reader` in time order into a Perception built from `calib`, `options`
/// and `callbacks`, then finishes it. Ground truth streams are never fed. Returns the counters.
PerceptionCounters replay(std::unique_ptr<RecordingReader> reader, const Calibration& calib,
                          const PerceptionOptions& options, const PerceptionCallbacks& callbacks,
                          ReadReport* reader_report = nullptr);

/// The dataset folder of simulator preset `preset` at `seed` under `cache_dir`
/// (CACHE/PRESET_seedSEED), simulated (sim::make_preset + sim::DatasetSink, as `fdv simulate`)
/// only when the folder is missing or incomplete. Complete = the marker file kSimulationMarker,
/// written last, holds the preset's full configuration as it is now and sim::kSimulatorRevision; a
/// folder from an interrupted run, a since-changed preset or another simulator revision is
/// simulated again. Not safe against two
/// processes filling the same folder at once. Throws ConfigError for an unknown preset.
std::string ensure_simulated(const std::string& preset, std::uint64_t seed,
                             const std::string& cache_dir);
/// The same for any configuration, into `dir`.
std::string ensure_simulated(const sim::ScenarioConfig& config, const std::string& dir);
inline constexpr const char* kSimulationMarker = "simulation_complete.yaml";

/// The camera a window's compensated image shows the ball from, for the method that was used:
/// none = the camera at each instant; rotation = its orientation held at t_start (rotation undone,
/// translation not); rotation_translation and contrast_max = its whole pose at t_start (the
/// events warped to t0, paper §III-A). The object's box in that image is where an exact warp of
/// that kind puts the ball's events.
GroundTruthBoxOptions compensated_image_frame(CompensationMethod used, TimeNs t_start);

/// Relative contrast η (paper §V-B) of one compensated window: the mean-time image after the
/// shared denoising (denoise_for_contrast with the detector's filter sizes), M = the true box over
/// the window on the undistorted grid, in compensated_image_frame(used, t_start), of each ball in
/// flight at the window's middle (true speed >= 1 m/s) whose box is non-empty in the image. A held
/// or lying ball, or a window without a ball, gives nothing: η is undefined without a moving
/// object (the paper computes it on scene 2 only).
std::vector<double> window_relative_contrast(const DatasetTruth& truth, const cv::Mat& mean_time_s,
                                             TimeNs t_start, TimeNs t_end, CompensationMethod used,
                                             const DetectorOptions& detector);

struct ExperimentOptions {
  PerceptionOptions perception;
  bool relative_contrast = false;  ///< compute window_relative_contrast for every window
};

struct ExperimentRun {
  std::vector<WindowDetections> windows;
  std::vector<double>
      compensation_ms;               ///< per window: ego-motion compensation (paper Table I's time)
  std::vector<double> front_end_ms;  ///< per window: compensation + detection
  std::vector<double> relative_contrast;  ///< η of every window and ball where it is defined
  std::vector<EstimateRecord>
      estimates;  ///< every converged estimate (usable flagged), in order made
  PerceptionCounters counters;
};

/// One run of the pipeline over the simulated dataset truth.dir with its own calibration.
ExperimentRun run_experiment(const DatasetTruth& truth, const ExperimentOptions& options);

/// Seeds from "101-105", "7" or "1,3,10-12" (inclusive ranges). Throws ConfigError naming the
/// offending part.
std::vector<std::uint64_t> parse_seed_list(const std::string& text);

}  // namespace fdv
