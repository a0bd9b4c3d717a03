#pragma once
/// One run of the pipeline over a simulated dataset that keeps what the paper's tables need
/// (detections, per-window timings, relative contrast, converged estimates, usable flagged) in
/// memory, and the seed lists of `fdv table1/2`.
///
///   const std::string dir = sim::ensure_simulated("scene2_ball", 101, "out/cache");
///   const DatasetTruth truth = load_dataset_truth(dir);
///   ExperimentOptions o;
///   o.perception.compensation.method = CompensationMethod::kRotation;
///   o.relative_contrast = true;
///   ExperimentRun run = run_experiment(truth, o);
///   detection_metrics(truth, run.windows);  summarize(run.relative_contrast);
///
/// Timings are wall-clock and depend on the machine's load; they are never unit-tested.
/// Thread safety: a run shares no state with another; runs may go on in parallel threads.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fdv/eval/dataset_truth.h"
#include "fdv/eval/detection_metrics.h"
#include "fdv/eval/estimate_metrics.h"
#include "fdv/pipeline/perception.h"
#include "fdv/sim/scenario_config.h"

namespace fdv {


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

/// A window's detections as the evaluation scores them (fdv/eval/detection_metrics.h).
WindowDetections window_detections(const WindowResult& w);

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
