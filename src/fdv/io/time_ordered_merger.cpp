#include "fdv/io/time_ordered_merger.h"

#include <algorithm>

namespace fdv {
namespace {

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
    fronts_.clear();
    for (const Source& s : sources_)
      for (std::size_t k = 0; k < kKinds; ++k)
        fronts_.push_back({head_time(s, k), future_bound(s, k)});
    const TimeOrderStep step = next_in_time_order(fronts_);
    const TimeNs best =
        step.earliest == TimeOrderStep::kNone ? kNever : fronts_[step.earliest].held;
    // A stream that may still bring an earlier item is read first, while memory allows.
    if (step.waiting_for != TimeOrderStep::kNone) {
      if (buffered_events() < max_buffered_events_) {
        pull(sources_[step.waiting_for / kKinds]);
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

    const std::size_t best_source = step.earliest / kKinds, best_kind = step.earliest % kKinds;
    Source& s = sources_[best_source];
    item = StreamItem{};
    item.kind = static_cast<StreamKind>(best_kind);
    item.t = best;
    item.source = best_source;
    switch (best_kind) {
      case 0: {
        // Events up to the earliest time anything else can still have.
        const TimeNs limit = step.run_until;
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
