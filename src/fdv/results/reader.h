#pragma once
/// Reads a `fdv run` results folder (schema.h) back into its rows, and into the records
/// evaluation scores (fdv/eval: WindowDetections, EstimateRecord).
///
///   const std::vector<WindowRow> windows = read_windows(dir);
///   const RunSummary summary = read_summary(dir);
///   DetectionMetrics m = detection_metrics(truth, read_detections(dir));
///
/// Throws InputError naming the file and line ("detections.jsonl:line 7") for a malformed line,
/// and naming the file when a file that must exist is missing.
#include <string>
#include <vector>

#include "fdv/eval/detection_metrics.h"
#include "fdv/eval/estimate_metrics.h"
#include "fdv/results/schema.h"

namespace fdv {

/// RESULTS/detections.jsonl, one row per window. Throws InputError when the file is missing.
std::vector<WindowRow> read_windows(const std::string& results_dir);
/// RESULTS/depth.jsonl (empty when absent).
std::vector<DepthRow> read_depth(const std::string& results_dir);
/// RESULTS/trajectories.jsonl, every solve (empty when absent: a run without 3D estimation). A
/// method other than "fusion" or "mono" is an error.
std::vector<TrajectoryRow> read_trajectories(const std::string& results_dir);
/// RESULTS/predictions.jsonl (empty when absent).
std::vector<PredictionRow> read_predictions(const std::string& results_dir);
/// RESULTS/dodge.jsonl (empty when absent: results of an older fdv).
std::vector<DodgeRow> read_dodge(const std::string& results_dir);
/// A dodge.jsonl file by its path. Throws InputError when it is missing or a line is malformed.
std::vector<DodgeRow> read_dodge_file(const std::string& path);
/// A TUM trajectory file (track_ID_{fusion,mono}.tum). Throws InputError when it is missing.
std::vector<TumPose> read_tum(const std::string& path);
/// RESULTS/summary.json. Throws InputError when it is missing or malformed.
RunSummary read_summary(const std::string& results_dir);
/// RESULTS/timing.csv, one row per window (empty when absent: results of an older fdv). Stage
/// columns are taken by their header names. Throws InputError (file, line) for a header that does
/// not start "window,t_start", a line with another number of cells, or a cell that is no number.
std::vector<WindowTimingRow> read_timing(const std::string& results_dir);

/// The windows as detection metrics take them (times in ns).
std::vector<WindowDetections> window_detections(const std::vector<WindowRow>& rows);
/// The converged solves as estimate metrics take them, in file order.
std::vector<EstimateRecord> estimate_records(const std::vector<TrajectoryRow>& rows);
/// The decisions the rows record (times in ns), for replaying a manoeuvre
/// (fdv/avoidance/maneuver_playback.h). Throws InputError for an unknown action text.
std::vector<DodgeDecision> dodge_decisions(const std::vector<DodgeRow>& rows);

/// window_detections(read_windows(results_dir)).
std::vector<WindowDetections> read_detections(const std::string& results_dir);
/// estimate_records(read_trajectories(results_dir)).
std::vector<EstimateRecord> read_estimates(const std::string& results_dir);

}  // namespace fdv
