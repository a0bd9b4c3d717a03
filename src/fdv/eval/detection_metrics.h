#pragma once
/// Detection metrics against a simulated dataset's truth (issue 4): recall over the windows where
/// a ball in flight is well in view, centre error of the detections that found it, and false
/// detections per window.
///
///   DetectionMetrics m = detection_metrics(truth, windows);       // one run
///   total.merge(m);                                               // pooled over seeds
///   m.recall(), summarize(m.center_errors_px).median, m.false_per_window()
///
/// The windows come from a run in memory (run_experiment) or from a results folder
/// (read_detections in fdv/eval/run_results.h).
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "fdv/eval/dataset_truth.h"

namespace fdv {

/// One window's detections as evaluation needs them.
struct WindowDetections {
  TimeNs t_start = 0, t_end = 0;
  struct Det {
    TimeNs t = 0;  ///< the detection's time (mean event time in its box)
    Eigen::Vector2d center_raw = Eigen::Vector2d::Zero();  ///< raw sensor pixels
    int track = -1;                                        ///< track it was assigned to; -1 none
  };
  std::vector<Det> detections;
};

struct DetectionMetricsOptions {
  /// A ball counts for recall only when at least this fraction of its silhouette is in the image
  /// throughout the window (issue 4: 80 %).
  double min_fraction_in_view = 0.8;
  double min_span_px = 8;  ///< ... and it spans at least this many pixels throughout it (issue 4)
  /// A detection belongs to a ball when its centre lies in the ball's true box over the window
  /// grown by this margin [px] (the box is exact; the margin absorbs pixel quantisation).
  double margin_px = 2;
  std::string validate() const;
};

/// Window w is *eligible* when some ball is in flight at its middle (true speed >= 1 m/s), visible,
/// and meets the in-view and span bounds throughout it. It is *found* when a detection lies in
/// such a ball's box. A detection in no visible ball's box is a *false detection* (in any window).
/// Centre errors: |detected centre − the true centre projected at the detection's time| for each
/// detection that found an eligible ball (a partly hidden ball's visible centroid is not its
/// centre).
struct DetectionMetrics {
  std::size_t windows = 0, eligible = 0, found = 0, false_detections = 0;
  std::vector<double> center_errors_px;
  double recall() const {
    return eligible ? static_cast<double>(found) / static_cast<double>(eligible) : 0;
  }
  double false_per_window() const {
    return windows ? static_cast<double>(false_detections) / static_cast<double>(windows) : 0;
  }
  /// Pools another run's windows into this one (sums the counts, concatenates the errors).
  void merge(const DetectionMetrics& other);
  nlohmann::json to_json() const;
};

/// Throws ConfigError for invalid options.
DetectionMetrics detection_metrics(const DatasetTruth& truth,
                                   const std::vector<WindowDetections>& windows,
                                   const DetectionMetricsOptions& options = {});

/// The tracks that follow ball `id`: those with most of their detections inside the ball's true
/// box (grown by options.margin_px), ordered by how many such detections they have (most first).
std::vector<int> tracks_following(const DatasetTruth& truth,
                                  const std::vector<WindowDetections>& windows, int id,
                                  const DetectionMetricsOptions& options = {});

}  // namespace fdv
