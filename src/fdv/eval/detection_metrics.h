#pragma once
/// Detection metrics against a simulated dataset's truth: recall over the windows where a ball in
/// flight is well in view (Table I's), centre error of the detections that found it, and false
/// detections per window; and at any size: recall and centre error per apparent-size bin, for balls
/// cut by the border, and per ball with its identity switches.
///
///   DetectionMetrics m = detection_metrics(truth, windows);       // one run
///   total.merge(m);                                               // pooled over seeds
///   m.recall(), summarize(m.center_errors_px).median, m.false_per_window()
///   m.size_bins[size_bin_of(25)].recall(), m.partial.recall(), m.objects.at(2).id_switches
///
/// The windows come from a run in memory (run_experiment) or from a results folder
/// (read_detections in fdv/results/reader.h).
/// Thread safety: value types and pure functions; may be used from any thread.
#include <array>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "fdv/eval/dataset_truth.h"
#include "fdv/eval/ground_truth_box.h"

namespace fdv {

/// The window status text (DetectionStatus) a detector reports when an object is too large to
/// detect (larger than half the frame's shorter side).
inline constexpr const char* kFillsTheViewStatus = "object fills the view";

/// One window's detections as evaluation needs them.
struct WindowDetections {
  TimeNs t_start = 0, t_end = 0;
  struct Det {
    TimeNs t = 0;  ///< the detection's time (mean event time in its box)
    /// Raw sensor pixels; of a partial detection, the centre of its visible part.
    Eigen::Vector2d center_raw = Eigen::Vector2d::Zero();
    int track = -1;  ///< track it was assigned to; -1 none
    bool partial = false;          ///< the detector found it cut by the frame's border
    double visible_fraction = 1;   ///< the detector's estimate of its share in view
    /// The detector's estimate of the whole object's centre [raw px] (partial detections only).
    std::optional<Eigen::Vector2d> center_full_raw{};
  };
  std::vector<Det> detections;
  std::string status{};  ///< DetectionStatus text; empty when unknown
};

/// Apparent-size bins [px] (lower bound inclusive): < 10, 10-40, 40-100, > 100.
inline constexpr std::array<double, 3> kSizeBinEdges_px{10, 40, 100};

struct DetectionMetricsOptions {
  /// The window-level recall of Table I: a ball counts only when at least this fraction
  /// of its silhouette is in the image throughout the window ...
  double min_fraction_in_view = 0.8;
  double min_span_px = 8;  ///< ... and it spans at least this many pixels throughout it
  /// A detection belongs to a ball when its centre lies in the ball's true box over the window
  /// grown by this margin [px] (the box is exact; the margin absorbs pixel quantisation).
  double margin_px = 2;
  /// Eligibility at any size, per ball and window: at least this fraction in view throughout the
  /// window, and an apparent size (VisibleSilhouette::size_px at the window's middle) between
  /// min_size_px and max_size_of_short_side × the frame's shorter side; larger = fills the view.
  double min_fraction_in_view_any_size = 0.3;
  double min_size_px = 4;
  double max_size_of_short_side = 0.5;
  std::string validate() const;
};

/// Recall and centre errors over a set of (window, ball) pairs.
struct RecallCounts {
  std::size_t eligible = 0, found = 0;
  std::vector<double> center_errors_px;  ///< of the found pairs (none where truth is missing)
  std::vector<double> sizes_px;          ///< the ball's apparent size beside each error
  double recall() const {
    return eligible ? static_cast<double>(found) / static_cast<double>(eligible) : 0;
  }
  void merge(const RecallCounts& other);
  /// eligible_windows, detected, recall, median_center_error_px (null without errors),
  /// median_size_px.
  nlohmann::json to_json() const;
};

/// One ball over a run (pooled runs: summed; id switches also as the most in one run).
struct ObjectMetrics {
  RecallCounts counts;
  int id_switches = 0;
  int max_id_switches_per_run = 0;
  void merge(const ObjectMetrics& other);
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
  /// That ball's true box over the window (raw pixels, clipped to the image), to place a miss.
  GroundTruthBox box = {};
  double size_px = 0;       ///< that ball's apparent size at the window's middle
  bool fills_view = false;  ///< some ball in flight fills the view
};

/// One (window, ball) pair of the any-size metrics (the rows of `fdv eval`'s detection_pairs.csv):
/// every ball that is eligible or fills the view in the window, so that a ball's misses can be
/// placed when several are in flight.
struct PairOutcome {
  TimeNs t_start = 0, t_end = 0;
  int ball = -1;
  double size_px = 0;  ///< apparent size at the window's middle
  double fraction_in_view_min = 0;
  bool partial = false, fills_view = false, found = false;
  double center_error_px = -1;  ///< against the visible part's centre; -1 none (or not found)
  int track = -1;               ///< the track of the ball's detection (-1: none or untracked)
  GroundTruthBox box = {};      ///< the ball's true box over the window (raw pixels, clipped)
};

/// Two definitions side by side.
///
/// Table I's, per window: window w is *eligible* when some ball is in flight at its
/// middle (true speed >= 1 m/s), visible, and meets min_fraction_in_view and min_span_px
/// throughout it; *found* when a detection belongs to such a ball. Centre errors: |detected centre
/// − the true centre projected at the detection's time| of every detection belonging to an
/// eligible ball.
///
/// At any size, per (window, ball): a detection belongs to the ball whose true box over the window
/// (grown by margin_px) holds its centre, the nearest true centre where several do; a ball takes
/// at most one detection per window (the nearest to its true centre; the others are counted as
/// duplicates). A ball in flight at least min_fraction_in_view_any_size in view throughout the
/// window is *eligible* when its apparent size is in [min_size_px, max_size_of_short_side × the
/// shorter side], or *fills the view* when larger (a detection there is neither a hit nor false);
/// *partial* when eligible and some of its silhouette is out of the frame at some instant of the
/// window. Centre error of the ball's detection: against the centre of the ball's visible part at
/// the detection's time (VisibleSilhouette::visible_center_px: the projected centre when wholly in
/// view, else the in-view area's centroid); `center_full` of a partial window's detection against
/// the projected true centre, on its own. Identity switches of a ball: the changes of track id
/// between consecutive windows (in time order) in which the ball took a detection with a track
/// (track -1 skipped), in any window where it is visible.
///
/// Both: a detection in no visible ball's box is a *false detection* (in any window).
struct DetectionMetrics {
  std::size_t windows = 0, eligible = 0, found = 0, false_detections = 0;
  std::vector<double> center_errors_px;
  std::vector<WindowOutcome> per_window;  ///< in window order (runs appended by merge)
  std::vector<PairOutcome> per_pair;      ///< in window order, then ball id

  // At any size, per (window, ball).
  RecallCounts any_size;                                ///< every eligible (window, ball)
  std::array<RecallCounts, kSizeBinEdges_px.size() + 1> size_bins;  ///< by apparent size
  RecallCounts partial;                                 ///< the partial pairs (also in their bin)
  std::vector<double> center_full_errors_px;  ///< partial pairs' detections with center_full
  std::size_t partial_flagged = 0;  ///< found partial pairs whose detection said `partial`
  std::size_t fills_view_windows = 0;  ///< windows where some ball fills the view
  std::size_t fills_view_reported = 0;  ///< ... whose status was kFillsTheViewStatus
  std::size_t duplicate_detections = 0;  ///< a ball's detections beyond its one
  std::map<int, ObjectMetrics> objects;  ///< by ball id: every ball of the truth

  double recall() const {
    return eligible ? static_cast<double>(found) / static_cast<double>(eligible) : 0;
  }
  double false_per_window() const {
    return windows ? static_cast<double>(false_detections) / static_cast<double>(windows) : 0;
  }
  /// Pools another run's windows into this one (sums the counts, concatenates the errors).
  void merge(const DetectionMetrics& other);
  /// Table I's figures, plus "size_bins", "partial", "fills_view", "duplicate_detections".
  nlohmann::json to_json() const;
  /// metrics.json's "objects": one entry per ball: id, eligible_windows, recall,
  /// median_center_error_px, id_switches.
  nlohmann::json objects_json() const;
};

/// "< 10 px", "10-40 px", "40-100 px", "> 100 px".
std::string size_bin_label(std::size_t bin);
/// The bin of an apparent size.
std::size_t size_bin_of(double size_px);

/// CSV of the per-window outcomes, header first: t_start_s, t_end_s, eligible, found, detections,
/// false_detections, center_error_px (empty: none), ball, fraction_in_view_min, span_px_min,
/// size_px, fills_view, u_min, v_min, u_max, v_max (the box's four empty without a ball).
void write_window_outcomes_csv(std::ostream& out, const std::vector<WindowOutcome>& windows);

/// CSV of the (window, ball) pairs, header first: t_start_s, t_end_s, ball, size_px,
/// fraction_in_view_min, partial, fills_view, found, center_error_px (empty: none), track,
/// u_min, v_min, u_max, v_max.
void write_pair_outcomes_csv(std::ostream& out, const std::vector<PairOutcome>& pairs);

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
