#include "latency_meter.h"

#include <limits>
#include <vector>

#include "fdv/eval/statistics.h"

namespace fdv::ros_core {

void LatencyMeter::arrived(TimeNs t_last) { arrivals_.emplace_back(t_last, Clock::now()); }

double LatencyMeter::window_done(TimeNs t_end) {
  const Clock::time_point now = Clock::now();
  // The message that completed the window is the first whose events reach its end.
  while (arrivals_.size() > 1 && arrivals_.front().first < t_end) arrivals_.pop_front();
  if (input_ended_ || arrivals_.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double ms =
      std::chrono::duration<double, std::milli>(now - arrivals_.front().second).count();
  latencies_ms_.push_back(ms);
  if (latencies_ms_.size() > kWindows) latencies_ms_.pop_front();
  return ms;
}

void LatencyMeter::new_run() {
  arrivals_.clear();
  input_ended_ = false;
}

nlohmann::json LatencyMeter::summary() const {
  if (latencies_ms_.empty()) return nullptr;
  const Summary s = summarize(std::vector<double>(latencies_ms_.begin(), latencies_ms_.end()));
  return {{"count", latencies_ms_.size()}, {"median", s.median}, {"p99", s.p99}, {"max", s.max}};
}

}  // namespace fdv::ros_core
