#pragma once
/// Writes a `fdv run` results folder (schema.h): the JSON-lines files and timing.csv as the
/// pipeline's callbacks arrive, then the TUM trajectories and summary.json. A run goes through
/// RecordingRun or RunRecorder (run.h), which own one and fill the summary; this is their part.
///
///   ResultsWriter out(dir);                       // creates dir, the four .jsonl files, timing.csv
///   callbacks.on_window = [&](const WindowResult& w) { out.window(w); };   // likewise on_depth,
///   ...                                           // on_estimate, on_prediction, on_dodge
///   RunSummary s;  s.counts = replay(...);  s.timing_ms = out.timing_ms();  ...
///   out.finish(s);                                // TUM files and summary.json
///
/// Each line is written when its callback returns (buffered by the stream). Throws InputError when
/// a file cannot be created or written (checked as it is closed). Not thread-safe.
#include <array>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "fdv/results/schema.h"

namespace fdv {

class ResultsWriter {
 public:
  explicit ResultsWriter(const std::filesystem::path& dir);

  // Perception's callbacks: the row, plus the stage timings for summary.json and the final
  // usable estimate of each track for the TUM files.
  void window(const WindowResult& w);
  void depth(const DepthResult& d);
  void estimate(const EstimateResult& e);
  void prediction(const PredictionResult& p);
  void dodge(const DodgeDecision& d);

  // Rows as they are.
  void write(const WindowRow& row);
  void write(const DepthRow& row);
  void write(const TrajectoryRow& row);
  void write(const PredictionRow& row);
  void write(const DodgeRow& row);
  /// A timing.csv line; its stages go into timing_ms() too.
  void write(const WindowTimingRow& row);

  /// Wall-clock time per stage [ms] over the callbacks so far (summary.json's "timing_ms").
  std::map<std::string, Summary> timing_ms() const;

  /// Writes track_ID_{fusion,mono}.tum for the final usable estimate of each track (every 5 ms
  /// over its observed interval) and summary.json; closes the .jsonl files.
  void finish(const RunSummary& summary);

 private:
  /// The files written row by row, with their names.
  std::array<std::pair<const char*, std::ofstream*>, 6> row_files();

  std::filesystem::path dir_;
  std::ofstream detections_, depth_, trajectories_, predictions_, dodge_, timing_csv_;
  std::vector<std::string> timing_stages_;  ///< timing.csv's stage columns (window_timing_stages)
  std::map<std::string, std::vector<double>> timing_;
  std::map<int, TrajectoryEstimate> final_fusion_, final_mono_;
};

}  // namespace fdv
