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
/// (read_detections in fdv/results/reader.h).
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <ostream>
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

/// One window's outcome (the rows of `fdv eval`'s detection_windows.csv): what to look at when a
/// recall or a false-detection count needs explaining.
struct WindowOutcome {
  TimeNs t_start = 0, t_end = 0;
  bool eligible = false, found = false;
  int detections = 0, false_detections = 0;
  double center_error_px = -1;  ///< of the first detection that found the ball; -1 none
  /// The ball nearest to eligibility (eligible if any, else the most in view): its id (-1 no ball
  /// in flight and visible), its least in-view fraction and smallest span over the window.
  int ball = -1;
  double fraction_in_view_min = 0, span_px_min = 0;
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
  std::vector<WindowOutcome> per_window;  ///< in window order (runs appended by merge)
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

/// CSV of the per-window outcomes, header first: t_start_s, t_end_s, eligible, found, detections,
/// false_detections, center_error_px (empty: none), ball, fraction_in_view_min, span_px_min.
void write_window_outcomes_csv(std::ostream& out, const std::vector<WindowOutcome>& windows);

/// Throws ConfigError for invalid options.
DetectionMetrics detection_metrics(const DatasetTruth& truth,
                                   const std::vector<WindowDetections>& windows,
                                   const DetectionMetricsOptions& options = {});

/// The tracks that follow ball `id`: those with most of their detections inside the ball's true
/// box (grown by options.margin_px), ordered by how many such detections they have (most first).
std::vector<int> tracks_following(const DatasetTruth& truth,
                                  const std::vector<WindowDetections>& windows, int id,
                                  const DetectionMetricsOptions& options = {});

/// The first window holding a detection inside ball `id`'s true box (grown by options.margin_px),
/// and that detection; nothing when no detection ever lies on the ball.
struct FirstBallDetection {
  TimeNs window_end = 0;  ///< when the detection was made (its window's end, stream time)
  WindowDetections::Det detection;
};
std::optional<FirstBallDetection> first_ball_detection(const DatasetTruth& truth,
                                                       const std::vector<WindowDetections>& windows, int id,
                                                       const DetectionMetricsOptions& options = {});

}  // namespace fdv
