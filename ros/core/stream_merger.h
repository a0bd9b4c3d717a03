#pragma once
/// Puts the node's streams, which arrive over separate connections in any interleaving, into one
/// time order for a Perception (C++20, not for the ROS node). Items are held until every awaited
/// stream has passed their time, then released by fdv::io's time-order rule, the one `fdv run`'s
/// merger applies, so a complete, slow replay gives `fdv run`'s order exactly.
///
/// Awaited: the subscribed streams, depth only with NodeConfig::wait_for_depth; a stream silent
/// for max_hold_s of stream time is not awaited meanwhile, and one never seen within
/// missing_after_s is reported missing (a warning). An item older than what was already released
/// is late: still used, counted and warned about.
/// Not thread-safe: one caller at a time (NodeCore's).
#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "fdv/io/recording.h"
#include "fdv/io/time_order.h"
#include "fdv/pipeline/perception.h"
#include "node_core.h"
#include "streams.h"

namespace fdv::ros_core {

class StreamMerger {
 public:
  StreamMerger(const NodeConfig& config, Warn warn);

  /// Holds what `chunk` brought for `stream`, moved out of it.
  void hold(Stream stream, SensorChunk& chunk);
  /// Hands `perception` every held item that may go now in time order; all of them with
  /// `everything` (the end of input).
  void release(Perception& perception, bool everything);
  /// A new run: nothing held, no stream seen. The late counts stay.
  void clear();

  struct Progress {
    bool seen = false;
    bool missing = false;        ///< never seen within missing_after_s of stream time (reported)
    TimeNs newest = kBeforeAll;  ///< the newest time held
    std::uint64_t late = 0;      ///< items used late, over all runs
  };
  const Progress& progress(Stream s) const { return progress_[index(s)]; }

 private:
  /// A held item spans [first, last] of `stream`.
  void note_time(Stream stream, TimeNs first, TimeNs last);
  /// The earliest time each stream's next item can have; kNever for a stream not awaited.
  std::array<TimeNs, kStreams.size()> awaited_until();
  TimeNs held_time(Stream s) const;

  std::array<bool, kStreams.size()> awaited_{};
  TimeNs max_hold_, missing_after_;
  double max_hold_s_, missing_after_s_;  ///< as configured, for the warnings
  Warn warn_;

  /// Held events, as the messages brought them (each non-decreasing in time, as the decoder's
  /// sanitizer leaves them); the first `events_released_` of the front one have gone.
  std::deque<std::vector<Event>> events_;
  std::size_t events_released_ = 0;
  std::deque<ImuSample> imu_;
  std::deque<DepthFrame> depth_;
  std::deque<OdometrySample> odometry_;

  std::array<Progress, kStreams.size()> progress_;
  TimeNs first_t_ = kNever;       ///< first time of this run
  TimeNs newest_t_ = kBeforeAll;  ///< newest time of any stream
  TimeNs released_until_ = kBeforeAll;
};

}  // namespace fdv::ros_core
