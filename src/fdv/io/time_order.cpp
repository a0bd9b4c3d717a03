#include "fdv/io/time_order.h"

#include <algorithm>

namespace fdv {

TimeOrderStep next_in_time_order(std::span<const StreamFront> streams) {
  TimeOrderStep step;
  TimeNs earliest = kNever;
  for (std::size_t i = 0; i < streams.size(); ++i)
    if (streams[i].held < earliest) earliest = streams[i].held, step.earliest = i;
  for (std::size_t i = 0; i < streams.size(); ++i) {
    const StreamFront& s = streams[i];
    if (s.held == kNever && s.next < earliest && step.waiting_for == TimeOrderStep::kNone)
      step.waiting_for = i;
    if (i != step.earliest)
      step.run_until = std::min(step.run_until, s.held != kNever ? s.held : s.next);
  }
  return step;
}

}  // namespace fdv
