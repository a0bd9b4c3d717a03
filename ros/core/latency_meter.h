#pragma once
/// The node's latency (C++20, not for the ROS node): from the arrival of the event message that
/// completed a window (the first whose events reach the window's end) to the window's result, by
/// the steady clock. Summarized over the last 2000 windows (a flight runs for hours).
/// Not thread-safe: one caller at a time (NodeCore's).
#include <chrono>
#include <cstddef>
#include <deque>
#include <nlohmann/json.hpp>
#include <utility>

#include "fdv/core/time.h"

namespace fdv::ros_core {

class LatencyMeter {
 public:
  /// An event message whose events reach `t_last` arrived now.
  void arrived(TimeNs t_last);
  /// A window ending at `t_end` is done now: its latency [ms], counted in the summary; NaN after
  /// end_of_input() (such a window waited for the end of input, not for the pipeline) or when no
  /// message is known to have completed it.
  double window_done(TimeNs t_end);
  /// The input ended: the windows closed from now until new_run() have no latency.
  void end_of_input() { input_ended_ = true; }
  /// A new run: no arrivals yet. The summary keeps the earlier runs' windows.
  void new_run();
  /// {"count", "median", "p99", "max"} [ms]; null before the first measured window.
  nlohmann::json summary() const;

 private:
  using Clock = std::chrono::steady_clock;
  static constexpr std::size_t kWindows = 2000;
  std::deque<std::pair<TimeNs, Clock::time_point>> arrivals_;  ///< by the time their events reach
  std::deque<double> latencies_ms_;
  bool input_ended_ = false;
};

}  // namespace fdv::ros_core
