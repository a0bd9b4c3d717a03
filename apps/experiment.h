#pragma once
// Shared by the CLI's run, eval and table commands: replaying a recording through the streaming
// pipeline, and a simulated dataset's ground truth.
#include <map>
#include <string>
#include <vector>

#include "fdv/io/recording.h"
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "fdv/pipeline/perception.h"

namespace fdv::cli {

/// `fdv run`'s arguments.
struct RunArgs {
  std::string input, calib, config, method, out;
  bool visualize = false;
  bool assume_static = false;
  ReaderOptions reader;
};
/// `fdv run`: the pipeline over a recording, results into args.out (README, docs/OUTPUTS.md).
void run_recording(const RunArgs& args);
/// `fdv eval`: scores results against a simulated dataset; writes and returns metrics.json.
nlohmann::json evaluate(const std::string& results_dir, const std::string& dataset_dir);

/// Feeds every stream of `reader` in time order into a Perception built from `calib`, `options`
/// and `callbacks`, then finishes it. Returns the pipeline's counters.
PerceptionCounters replay(std::unique_ptr<RecordingReader> reader, const Calibration& calib,
                          const PerceptionOptions& options, const PerceptionCallbacks& callbacks,
                          ReadReport* reader_report = nullptr);

/// Ground truth of a simulated dataset folder (`fdv simulate`): calibration, true vehicle motion,
/// true object states, radii and gravity from dataset.yaml.
struct DatasetTruth {
  std::string dir;
  Calibration calibration;
  std::vector<OdometrySample> body;
  std::vector<ObjectState> objects;  ///< time-sorted
  std::map<int, double> radius_m;    ///< per object id
  Eigen::Vector3d gravity_W = Eigen::Vector3d(0, 0, -9.81);
  std::string scenario;
  /// The object's true state at t (nearest sample, propagated ballistically: exact in free flight).
  std::optional<ObjectState> object_at(int id, TimeNs t) const;
  /// The true vehicle state at t (interpolated).
  OdometrySample body_at(TimeNs t) const;
};
/// Throws InputError when the folder has no ground truth.
DatasetTruth load_dataset_truth(const std::string& dir);

}  // namespace fdv::cli

namespace fdv::cli {

/// One window's detection as evaluation needs it.
struct WindowDetections {
  TimeNs t_start = 0, t_end = 0;
  struct Det {
    TimeNs t = 0;
    Eigen::Vector2d center_raw = Eigen::Vector2d::Zero();
  };
  std::vector<Det> detections;
};

/// Detection metrics against the simulator's truth (issue 4): a window is eligible for recall
/// when a ball in flight (true speed >= 1 m/s) is at least `min_fraction_in_view` in view and
/// spans at least `min_span_px` throughout it; a detection is correct when its centre lies in that ball's true box over the
/// window (grown by `margin_px`); any detection in no visible ball's box is a false detection.
struct DetectionMetrics {
  std::size_t windows = 0, eligible = 0, found = 0, false_detections = 0;
  std::vector<double> center_errors_px;  ///< |detected − projected true centre at the detection's t|
  double recall() const { return eligible ? static_cast<double>(found) / static_cast<double>(eligible) : 0; }
  double false_per_window() const {
    return windows ? static_cast<double>(false_detections) / static_cast<double>(windows) : 0;
  }
  nlohmann::json to_json() const;
};
DetectionMetrics detection_metrics(const DatasetTruth& truth, const std::vector<WindowDetections>& windows,
                                   double min_fraction_in_view = 0.8, double min_span_px = 8,
                                   double margin_px = 2);

/// Reads a results folder's detections.jsonl.
std::vector<WindowDetections> read_detections(const std::string& results_dir);

/// The ball's true box over [t0, t1] on the undistorted grid K·xn where the time images live
/// (projection without distortion), as an integer pixel rectangle; empty when not visible.
cv::Rect undistorted_truth_rect(const DatasetTruth& truth, int id, TimeNs t0, TimeNs t1);

}  // namespace fdv::cli
