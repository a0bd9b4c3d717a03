#pragma once
/// What NodeCore::diagnostics() reports, and the counts behind it (C++20, not for the ROS node):
/// messages and drops per stream, drops by reason (each reason warned about as its count grows),
/// windows and runs, and the pipeline's counters of the last finished run; the streams' progress
/// and the latency come from the StreamMerger and the LatencyMeter.
/// Not thread-safe: one caller at a time (NodeCore's).
#include <array>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "fdv/io/read_report.h"
#include "fdv/pipeline/perception.h"
#include "latency_meter.h"
#include "node_core.h"
#include "stream_merger.h"
#include "streams.h"

namespace fdv::ros_core {

class NodeDiagnostics {
 public:
  NodeDiagnostics(const NodeConfig& config, Warn warn);

  /// A message of `stream` arrived; returns where it is, for the drop report ("imu message 12").
  std::string received(Stream stream);
  /// Where drops and repairs are counted by reason.
  ReadReport& report() { return report_; }
  /// Warns about each drop reason whose count grew since the last call.
  void warn_new_drops();
  /// A message of `stream` was dropped (its reason already in report()).
  void dropped(Stream stream) { ++dropped_[index(stream)]; }
  void window_done() { ++windows_; }
  void run_started() { ++runs_; }
  /// The pipeline's counters of a finished run, reported until the next run has a Perception;
  /// its input drops join report() for good.
  void run_finished(const Perception& perception);

  /// `running`: the Perception of the run in progress, or null when it has none yet.
  nlohmann::json to_json(const StreamMerger& merger, const LatencyMeter& latency,
                         const Perception* running) const;

 private:
  std::array<bool, kStreams.size()> subscribed_{};
  Warn warn_;
  std::array<std::uint64_t, kStreams.size()> messages_{}, dropped_{};
  ReadReport report_;
  std::map<std::string, std::uint64_t> warned_drops_;  ///< reason -> count already warned about
  std::uint64_t windows_ = 0, runs_ = 0;
  nlohmann::json finished_run_ = nlohmann::json::object();
};

}  // namespace fdv::ros_core
