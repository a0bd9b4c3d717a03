#include "fdv/io/time_ordered_merger.h"

#include <algorithm>
#include <limits>

namespace fdv {
namespace {

constexpr TimeNs kNever = std::numeric_limits<TimeNs>::max();
constexpr TimeNs kBeforeAll = std::numeric_limits<TimeNs>::min();

template <typename T>
TimeNs front_time(const std::deque<T>& q) {
  return q.empty() ? kNever : q.front().t;
}

template <typename T>
void append(std::deque<T>& q, std::vector<T>& items, TimeNs& high_water) {
  for (auto& x : items) {
    high_water = std::max(high_water, x.t);
    q.push_back(std::move(x));
  }
}

}  // namespace

TimeOrderedMerger::TimeOrderedMerger(std::vector<std::unique_ptr<RecordingReader>> sources,
                                     std::size_t max_event_run, std::size_t max_buffered_events)
    : max_event_run_(std::max<std::size_t>(1, max_event_run)),
      max_buffered_events_(max_buffered_events) {
  sources_.resize(sources.size());
  for (std::size_t i = 0; i < sources.size(); ++i) {
    Source& s = sources_[i];
    s.reader = std::move(sources[i]);
    std::fill(std::begin(s.high_water), std::end(s.high_water), kBeforeAll);
    for (StreamKind k : s.reader->info().streams) s.declares[static_cast<std::size_t>(k)] = true;
  }
}

bool TimeOrderedMerger::pull(Source& s) {
  if (s.exhausted) return false;
  if (!s.reader->read(chunk_)) {
    s.exhausted = true;
    return false;
  }
  // A stream that shows up without being declared is still merged correctly from now on.
  auto mark = [&](StreamKind k, bool any) {
    if (any) s.declares[static_cast<std::size_t>(k)] = true;
  };
  mark(StreamKind::kEvents, !chunk_.events.empty());
  mark(StreamKind::kImu, !chunk_.imu.empty());
  mark(StreamKind::kDepth, !chunk_.depth.empty());
  mark(StreamKind::kOdometry, !chunk_.odometry.empty());
  mark(StreamKind::kGroundTruth, !chunk_.ground_truth.empty());
  append(s.events, chunk_.events, s.high_water[0]);
  append(s.imu, chunk_.imu, s.high_water[1]);
  append(s.depth, chunk_.depth, s.high_water[2]);
  append(s.odometry, chunk_.odometry, s.high_water[3]);
  append(s.truth, chunk_.ground_truth, s.high_water[4]);
  return true;
}

std::size_t TimeOrderedMerger::buffered_events() const {
  std::size_t n = 0;
  for (const auto& s : sources_) n += s.events.size();
  return n;
}

TimeNs TimeOrderedMerger::head_time(const Source& s, std::size_t kind) const {
  switch (kind) {
    case 0: return front_time(s.events);
    case 1: return front_time(s.imu);
    case 2: return front_time(s.depth);
    case 3: return front_time(s.odometry);
    default: return front_time(s.truth);
  }
}

TimeNs TimeOrderedMerger::future_bound(const Source& s, std::size_t kind) const {
  if (s.exhausted || !s.declares[kind]) return kNever;
  return s.high_water[kind];
}

bool TimeOrderedMerger::next(StreamItem& item) {
  while (true) {
    // The earliest buffered item.
    TimeNs best = kNever;
    std::size_t best_source = 0, best_kind = 0;
    for (std::size_t i = 0; i < sources_.size(); ++i)
      for (std::size_t k = 0; k < kKinds; ++k)
        if (const TimeNs t = head_time(sources_[i], k); t < best) {
          best = t, best_source = i, best_kind = k;
        }
    // Is any stream with nothing buffered possibly still going to produce something earlier?
    Source* lagging = nullptr;
    for (auto& s : sources_)
      for (std::size_t k = 0; k < kKinds && !lagging; ++k)
        if (head_time(s, k) == kNever && future_bound(s, k) < best) lagging = &s;
    if (lagging) {
      if (buffered_events() < max_buffered_events_) {
        pull(*lagging);
        continue;
      }
      report_.repair("merged past a silent stream (order across streams not guaranteed)",
                     "t " + std::to_string(best));
    }
    if (best == kNever) {
      bool pulled = false;
      for (auto& s : sources_) pulled = pull(s) || pulled;
      if (pulled) continue;
      return false;
    }

    Source& s = sources_[best_source];
    item = StreamItem{};
    item.kind = static_cast<StreamKind>(best_kind);
    item.t = best;
    item.source = best_source;
    switch (best_kind) {
      case 0: {
        // Events up to the earliest time anything else can still have.
        TimeNs limit = kNever;
        for (std::size_t i = 0; i < sources_.size(); ++i)
          for (std::size_t k = 0; k < kKinds; ++k) {
            if (i == best_source && k == 0) continue;
            const TimeNs h = head_time(sources_[i], k);
            limit = std::min(limit, h != kNever ? h : future_bound(sources_[i], k));
          }
        run_.clear();
        while (!s.events.empty() && run_.size() < max_event_run_ &&
               (s.events.front().t <= limit || run_.empty())) {
          run_.push_back(s.events.front());
          s.events.pop_front();
        }
        item.events = run_;
        break;
      }
      case 1:
        imu_out_ = std::move(s.imu.front());
        s.imu.pop_front();
        item.imu = &imu_out_;
        break;
      case 2:
        depth_out_ = std::move(s.depth.front());
        s.depth.pop_front();
        item.depth = &depth_out_;
        break;
      case 3:
        odometry_out_ = s.odometry.front();
        s.odometry.pop_front();
        item.odometry = &odometry_out_;
        break;
      default:
        truth_out_ = s.truth.front();
        s.truth.pop_front();
        item.ground_truth = &truth_out_;
    }
    return true;
  }
}

MemoryRecording::MemoryRecording(RecordingInfo info, SensorChunk data, std::size_t chunk_events)
    : info_(std::move(info)), data_(std::move(data)), chunk_events_(std::max<std::size_t>(1, chunk_events)) {}

bool MemoryRecording::read(SensorChunk& chunk) {
  chunk.clear();
  const std::size_t end = std::min(data_.events.size(), event_pos_ + chunk_events_);
  chunk.events.assign(data_.events.begin() + static_cast<std::ptrdiff_t>(event_pos_),
                      data_.events.begin() + static_cast<std::ptrdiff_t>(end));
  event_pos_ = end;
  const bool events_done = event_pos_ == data_.events.size();
  const TimeNs horizon = events_done ? kNever : chunk.events.back().t;
  auto take = [horizon](const auto& all, std::size_t& pos, auto& out) {
    while (pos < all.size() && all[pos].t <= horizon) out.push_back(all[pos++]);
  };
  take(data_.imu, imu_pos_, chunk.imu);
  take(data_.depth, depth_pos_, chunk.depth);
  take(data_.odometry, odometry_pos_, chunk.odometry);
  take(data_.ground_truth, truth_pos_, chunk.ground_truth);
  return !chunk.empty();
}

}  // namespace fdv
