#pragma once
/// The one way to run the pipeline into a results folder (schema.h). `fdv run`, `fdv demo`,
/// `fdv dodge-eval` and Python's `fdv.run` all run a recording through RecordingRun; a program that
/// drives a live Perception itself fills a folder through RunRecorder.
///
///   RunRequest request;
///   request.input = "throw.aedat4";
///   RecordingRun run(std::move(request));               // opens it, applies the sensor policy
///   log(run.policy().options);                          // what will run, before it runs
///   PerceptionCallbacks also;                           // optional: called beside the writer
///   also.on_warning = [](const std::string& w) { log(w); };
///   const RunOutcome outcome = run.into("results/", also);   // "" writes no folder
///
///   RunRecorder recorder("results/", also);             // a live Perception instead
///   Perception perception(calib, options, recorder.callbacks());
///   ... push ...; perception.finish();
///   recorder.finish(summary);                           // input, format, ... filled by the caller
///
/// Every warning of a run, whoever raises it (the sensor policy, the pipeline while it runs, the
/// counters after it, the reader's drops), goes to `also.on_warning` as it is raised and into
/// summary.json's "warnings" in the same order.
///
/// A folder is replaced whole, never mixed: the run writes into a hidden sibling, `.NAME.partial-PID`,
/// renamed over NAME when it finishes. A run that ends early (an error, or an exception thrown
/// from a callback to stop it: that is how a signal stops `fdv run`) removes its partial folder and
/// leaves NAME as it was. An existing NAME is replaced only when it is empty or a results folder
/// (it holds summary.json or detections.jsonl), so that `--out .` cannot delete a user's files.
/// Not thread-safe: one run per object.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/io/read_report.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/perception.h"
#include "fdv/pipeline/sensor_policy.h"
#include "fdv/results/schema.h"
#include "fdv/results/writer.h"

namespace fdv {

/// What to run.
struct RunRequest {
  std::string input;      ///< recording file or dataset folder
  ReaderOptions reader;   ///< topics of a bag
  /// Replaces the recording's own calibration when set (a file the user gave).
  std::optional<Calibration> calibration;
  /// Where `calibration` came from (its path): summary.json's "calibration" and the file an error names.
  std::string calibration_source;
  PerceptionOptions options;  ///< as requested; the sensor policy applies its fallbacks
};

/// What a run gave besides the folder.
struct RunOutcome {
  PerceptionCounters counts;
  ReadReport reader_report;
  std::vector<std::string> warnings;  ///< every warning, in the order raised
  RunSummary summary;                 ///< summary.json as written (also when no folder was)
};

/// A results folder filled from a live Perception: the results writer behind its callbacks, the
/// run's warnings, and the summary with the after-run warnings.
class RunRecorder {
 public:
  /// `dir` empty: no folder is written; the warnings and the summary are still gathered.
  /// `also`: called after the writer for each result (and for each warning). Throws InputError
  /// when `dir` exists and is neither empty nor a results folder, or cannot be written beside.
  explicit RunRecorder(const std::filesystem::path& dir, PerceptionCallbacks also = {});
  /// Removes the partial folder of a run that did not finish.
  ~RunRecorder();
  RunRecorder(const RunRecorder&) = delete;
  RunRecorder& operator=(const RunRecorder&) = delete;

  /// The folder being written until finish() (the partial one), for files a caller adds beside
  /// the results (e.g. `fdv run --visualize`'s PNGs); empty without a folder.
  const std::filesystem::path& folder() const { return partial_; }

  /// The callbacks to build the Perception with.
  PerceptionCallbacks callbacks();
  /// A warning raised outside the pipeline (the sensor policy's, a reader's).
  void warn(const std::string& line);

  /// Once the Perception has finished: warns what the counters hold (fallback flags, overload
  /// decimation) and what the reader dropped, then writes the TUM files and summary.json. The
  /// caller fills the summary's description (input, format, resolution, calibration, method,
  /// threads, options, detector_in_use) and counts; warnings, timing and the reader's report are
  /// filled here. Then the partial folder replaces the destination. Returns the summary as written.
  RunSummary finish(RunSummary summary, const ReadReport* reader_report = nullptr);

 private:
  std::filesystem::path destination_, partial_;
  std::optional<ResultsWriter> writer_;
  PerceptionCallbacks also_;
  std::vector<std::string> warnings_;
};

/// A recording opened and the sensor policy applied (fdv/pipeline/sensor_policy.h): what will run,
/// known before it runs. Throws what open_recording throws, and InputError naming the calibration
/// file (or the recording) when the policy refuses its sizes.
class RecordingRun {
 public:
  explicit RecordingRun(RunRequest request);
  ~RecordingRun();

  const RecordingInfo& info() const { return info_; }
  const SensorPolicy& policy() const { return policy_; }
  /// summary.json's "calibration": the file given, "from the recording", or "none (...)".
  const std::string& calibration_source() const { return calibration_source_; }

  /// Replays the recording into the folder `out` ("" writes none). Once only.
  RunOutcome into(const std::filesystem::path& out, PerceptionCallbacks also = {});
  /// The same through a recorder the caller made (to know its folder() before the run).
  RunOutcome into(RunRecorder& recorder);

 private:
  RunRequest request_;
  std::unique_ptr<RecordingReader> reader_;
  RecordingInfo info_;
  SensorPolicy policy_;
  std::string calibration_source_;
};

}  // namespace fdv
