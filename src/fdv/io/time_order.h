#pragma once
/// The rule that puts several streams into one time order: TimeOrderedMerger applies it to
/// recordings it pulls from, the ROS node's core to messages pushed to it, so that both give the
/// same order.
///
/// Each stream holds items in non-decreasing time. The caller describes every stream by the time
/// of its earliest held item and by the earliest time an item it does not hold yet can have. The
/// earliest held item may go once no stream holding nothing can still bring an earlier one. Ties
/// go to the stream listed first (TimeOrderedMerger lists by source, then by StreamKind).
/// A pure function: safe to call from any thread.
#include <cstddef>
#include <limits>
#include <span>

#include "fdv/core/time.h"

namespace fdv {

/// Later than any time: a stream holds nothing, or nothing more can come from it.
inline constexpr TimeNs kNever = std::numeric_limits<TimeNs>::max();
/// Earlier than any time: no item seen yet.
inline constexpr TimeNs kBeforeAll = std::numeric_limits<TimeNs>::min();

struct StreamFront {
  TimeNs held = kNever;  ///< time of the earliest item held; kNever when none is
  TimeNs next = kNever;  ///< earliest time an item not yet held can have; kNever when none can come
};

struct TimeOrderStep {
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  /// The stream holding the earliest item; kNone when no stream holds any.
  std::size_t earliest = kNone;
  /// The first stream holding nothing that may still bring an item before that; kNone when none
  /// may, and the earliest item can go.
  std::size_t waiting_for = kNone;
  /// The earliest time any other stream can still give: the earliest stream's items up to it
  /// may go together (at least one).
  TimeNs run_until = kNever;
};

TimeOrderStep next_in_time_order(std::span<const StreamFront> streams);

}  // namespace fdv
