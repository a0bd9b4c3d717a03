#include "fdv/results/run.h"

#include <fmt/format.h>
#include <unistd.h>

#include <system_error>

#include "fdv/core/error.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/pipeline/replay.h"

namespace fdv {
namespace {

/// What the counters hold that the run did not say while running: a line each. With "none" the
/// compensation uses no sensor, and its fallback flags say nothing of the results.
std::vector<std::string> after_run_warnings(const PerceptionCounters& c, bool compensation_uses_sensors) {
  std::vector<std::string> lines;
  for (const auto& [flag, n] : windows_by_fallback_flag(c))
    if (n > 0 && compensation_uses_sensors)
      lines.push_back(fmt::format("{} of {} windows flagged '{}' by the compensation (windows_with_fallback_flag)",
                                  n, c.windows, flag));
  if (c.events_dropped.overload > 0)
    lines.push_back(fmt::format("{} of {} events decimated by the overload policy", c.events_dropped.overload, c.events));
  return lines;
}

namespace fs = std::filesystem;

/// A folder that a run may replace: absent, empty, or written by a run before (see run.h).
bool replaceable(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return true;
  if (!fs::is_directory(dir, ec)) return false;
  return fs::is_empty(dir, ec) || fs::exists(dir / kSummaryFile, ec) || fs::exists(dir / kDetectionsFile, ec);
}

/// `dir` with a file name: "out/" and "out/." name the folder "out".
fs::path named_folder(const fs::path& dir) {
  fs::path p = fs::absolute(dir).lexically_normal();
  return p.has_filename() ? p : p.parent_path();
}

/// The hidden sibling `.NAME.ROLE-PID` of the folder `dir` (one per process and role).
fs::path hidden_sibling(const fs::path& dir, const char* role) {
  return dir.parent_path() / fmt::format(".{}.{}-{}", dir.filename().string(), role, getpid());
}

/// Moves `from` over `to`: the old `to` is set aside, then removed once `from` is in its place;
/// put back when `from` cannot take its place, so that `to` is never lost.
void replace_folder(const fs::path& from, const fs::path& to) {
  const fs::path old = hidden_sibling(to, "old");
  fs::remove_all(old);
  const bool had_old = fs::exists(to);
  if (had_old) fs::rename(to, old);
  try {
    fs::rename(from, to);
  } catch (const fs::filesystem_error&) {
    if (had_old) fs::rename(old, to);
    throw;
  }
  if (had_old) fs::remove_all(old);
}

}  // namespace

RunRecorder::RunRecorder(const std::filesystem::path& dir, PerceptionCallbacks also) : also_(std::move(also)) {
  if (dir.empty()) return;
  destination_ = named_folder(dir);
  if (!replaceable(destination_))
    throw InputError(dir.string(), "",
                     "exists and is not a results folder (no summary.json or detections.jsonl): refusing to "
                     "replace it; name a new or empty folder");
  partial_ = hidden_sibling(destination_, "partial");
  fs::remove_all(partial_);  // a crashed run of a process that had this pid
  writer_.emplace(partial_);
}

RunRecorder::~RunRecorder() {
  if (partial_.empty()) return;
  writer_.reset();  // close the files first
  std::error_code ec;  // a destructor must not throw; what cannot be removed stays hidden
  fs::remove_all(partial_, ec);
}

PerceptionCallbacks RunRecorder::callbacks() {
  // Each writes its row, then calls the caller's callback of the same result.
  PerceptionCallbacks c;
  c.on_window = [this](const WindowResult& w) {
    if (writer_) writer_->window(w);
    if (also_.on_window) also_.on_window(w);
  };
  c.on_depth = [this](const DepthResult& d) {
    if (writer_) writer_->depth(d);
    if (also_.on_depth) also_.on_depth(d);
  };
  c.on_estimate = [this](const EstimateResult& e) {
    if (writer_) writer_->estimate(e);
    if (also_.on_estimate) also_.on_estimate(e);
  };
  c.on_prediction = [this](const PredictionResult& p) {
    if (writer_) writer_->prediction(p);
    if (also_.on_prediction) also_.on_prediction(p);
  };
  c.on_dodge = [this](const DodgeDecision& d) {
    if (writer_) writer_->dodge(d);
    if (also_.on_dodge) also_.on_dodge(d);
  };
  c.on_warning = [this](const std::string& w) { warn(w); };
  return c;
}

void RunRecorder::warn(const std::string& line) {
  warnings_.push_back(line);
  if (also_.on_warning) also_.on_warning(line);
}

RunSummary RunRecorder::finish(RunSummary summary, const ReadReport* reader_report) {
  const bool compensation_uses_sensors = summary.method != to_string(CompensationMethod::kNone);
  for (const std::string& w : after_run_warnings(summary.counts, compensation_uses_sensors)) warn(w);
  if (reader_report) {
    for (const auto& [reason, e] : reader_report->dropped())
      warn(fmt::format("the reader dropped {} record(s): {} (first at {})", e.count, reason, e.first_where));
    summary.reader_report = reader_report->to_json();
  }
  summary.warnings = warnings_;
  if (writer_) {
    summary.timing_ms = writer_->timing_ms();
    writer_->finish(summary);
    writer_.reset();
    replace_folder(partial_, destination_);
    partial_.clear();
  }
  return summary;
}

RecordingRun::RecordingRun(RunRequest request) : request_(std::move(request)) {
  reader_ = open_recording(request_.input, request_.reader);
  info_ = reader_->info();
  const bool calibration_given = request_.calibration.has_value();
  try {
    policy_ = apply_sensor_policy(declared_sensors(info_, request_.calibration), request_.options);
  } catch (const ConfigError& e) {  // a missing or mismatched sensor size: name where it came from
    throw InputError(calibration_given ? request_.calibration_source : request_.input, "", e.what());
  }
  calibration_source_ = calibration_given   ? request_.calibration_source
                        : policy_.pixel_only ? "none (pixel coordinates, no compensation)"
                                             : "from the recording";
}

RecordingRun::~RecordingRun() = default;

RunOutcome RecordingRun::into(const std::filesystem::path& out, PerceptionCallbacks also) {
  if (!reader_) throw std::logic_error("RecordingRun::into: the recording was run already");
  RunRecorder recorder(out, std::move(also));
  return into(recorder);
}

RunOutcome RecordingRun::into(RunRecorder& recorder) {
  if (!reader_) throw std::logic_error("RecordingRun::into: the recording was run already");
  for (const std::string& w : policy_.warnings) recorder.warn(w);
  RunOutcome outcome;
  outcome.counts = replay(std::move(reader_), policy_.calibration, policy_.options, recorder.callbacks(),
                          &outcome.reader_report);

  RunSummary summary;
  summary.input = request_.input;
  summary.format = info_.format;
  summary.width = info_.width;
  summary.height = info_.height;
  summary.calibration = calibration_source_;
  summary.method_requested = to_string(request_.options.compensation.method);
  summary.method = to_string(policy_.options.compensation.method);
  summary.threads = policy_.options.threads;
  summary.counts = outcome.counts;
  summary.options = to_json(policy_.options);
  summary.detector_in_use = detector_in_use(policy_.options, policy_.calibration.event_camera);
  outcome.summary = recorder.finish(std::move(summary), &outcome.reader_report);
  outcome.warnings = outcome.summary.warnings;
  return outcome;
}

}  // namespace fdv
