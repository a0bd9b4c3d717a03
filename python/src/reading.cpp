// fdv.open(): any supported recording as numpy arrays. Events are converted once, from the
// reader's buffer straight into the output array; slicing by time or count happens on the C++
// side, so no Python code runs per event.
#include <pybind11/stl.h>

#include <algorithm>
#include <deque>
#include <memory>
#include <optional>

#include "common.h"
#include "fdv/io/recording.h"
#include "fdv/io/recording_summary.h"
#include "fdv/io/time_ordered_merger.h"
#include "fdv/pipeline/event_windower.h"

namespace fdv::python {
namespace {

/// What every iterator of one fdv.Recording shares: where to read from, and whether it was closed.
struct Source {
  std::string path;
  ReaderOptions options;
  TimeUnit unit = TimeUnit::kUs;
  bool closed = false;
  void check_open() const {
    if (closed) throw py::value_error(path + ": the recording is closed");
  }
  std::unique_ptr<RecordingReader> open() const {
    check_open();
    py::gil_scoped_release release;
    return open_recording(path, options);
  }
};

/// Events of a recording in chunks (as read), or Metavision-style slices: `delta_t` [µs] gives
/// consecutive slices [t0 + k·Δt, t0 + (k+1)·Δt) from the first event's time t0, empty ones
/// included, up to kMaxEmptySlices in a row (the rest of a longer gap is skipped, as `fdv run`'s
/// windower does: a gap of a year would be 3e10 slices of 1 ms); `n_events` slices of that many
/// events; both: a slice ends at whichever comes first.
class EventIterator {
  static constexpr std::uint64_t kMaxEmptySlices = EventWindowerOptions{}.max_empty_windows;

 public:
  EventIterator(std::shared_ptr<Source> source, std::optional<std::int64_t> delta_t_us,
                std::optional<std::int64_t> n_events)
      : source_(std::move(source)), reader_(source_->open()) {
    if (delta_t_us) {
      // At most 1e15 µs (31 years): slice ends, up to two slices past a valid time, fit in TimeNs.
      if (*delta_t_us <= 0 || *delta_t_us > 1'000'000'000'000'000)
        throw py::value_error("delta_t must be in (0, 1e15] µs, got " + std::to_string(*delta_t_us));
      delta_t_ns_ = to_ns(*delta_t_us, TimeUnit::kUs);
    }
    if (n_events) {
      if (*n_events <= 0) throw py::value_error("n_events must be > 0, got " + std::to_string(*n_events));
      n_events_ = static_cast<std::size_t>(*n_events);
    }
  }

  py::array_t<EventCD> next() {
    const auto held = one_call_.enter();
    if (source_->closed) {
      reader_.reset();
      source_->check_open();
    }
    std::size_t n = 0;
    bool window_done = false;
    {
      py::gil_scoped_release release;
      if (!delta_t_ns_ && !n_events_) {
        if (buffered_ == 0) read_more();
        n = buffered_ == 0 ? 0 : buffer_.front().size() - front_pos_;
      } else if (!delta_t_ns_) {
        while (buffered_ < *n_events_ && read_more()) {
        }
        n = std::min(buffered_, *n_events_);
      } else {
        if (!window_end_) {
          if (buffered_ == 0) read_more();
          if (buffered_ > 0) window_end_ = buffer_.front()[front_pos_].t + *delta_t_ns_;
        }
        if (window_end_) {
          const std::size_t cap = n_events_.value_or(std::numeric_limits<std::size_t>::max());
          // Read on until an event at or past the window's end is buffered (or the end of file).
          while ((buffered_ == 0 || buffer_.back().back().t < *window_end_) && read_more()) {
          }
          n = count_before(*window_end_, cap);
          window_done = n < cap;
        }
      }
    }
    if (n == 0 && buffered_ == 0 && eof_) throw py::stop_iteration();
    py::array_t<EventCD> out(static_cast<py::ssize_t>(n));
    EventCD* data = out.mutable_data();
    {
      py::gil_scoped_release release;
      take(n, data);
    }
    if (window_done) next_slice(n == 0);
    return out;
  }

 private:
  /// Moves window_end_ to the next slice's end; past a gap's kMaxEmptySlices empty slices, to
  /// the end of the slice that holds the next event.
  void next_slice(bool empty) {
    empty_in_a_row_ = empty ? empty_in_a_row_ + 1 : 0;
    TimeNs end = *window_end_ + *delta_t_ns_;  // valid times and a Δt from to_ns: no overflow
    if (empty_in_a_row_ >= kMaxEmptySlices && buffered_ > 0) {
      const TimeNs next_t = buffer_.front()[front_pos_].t;
      if (next_t >= end) end += ((next_t - end) / *delta_t_ns_ + 1) * *delta_t_ns_;
      empty_in_a_row_ = 0;
    }
    window_end_ = end;
  }

  /// Appends the next chunk that has events to the buffer; false at the end of the recording.
  bool read_more() {
    if (eof_) return false;
    while (reader_->read(chunk_)) {
      if (chunk_.events.empty()) continue;
      buffered_ += chunk_.events.size();
      buffer_.push_back(std::move(chunk_.events));
      chunk_.events = std::move(spare_);  // the reader refills a buffer that is already allocated
      spare_ = {};
      return true;
    }
    eof_ = true;
    return false;
  }

  /// Buffered events with t < t_end (streams are time-sorted), at most `cap`.
  std::size_t count_before(TimeNs t_end, std::size_t cap) const {
    std::size_t n = 0;
    for (std::size_t i = 0; i < buffer_.size() && n < cap; ++i) {
      const auto first = buffer_[i].begin() + static_cast<std::ptrdiff_t>(i == 0 ? front_pos_ : 0);
      const auto end = std::lower_bound(first, buffer_[i].end(), t_end,
                                        [](const Event& e, TimeNs t) { return e.t < t; });
      n += static_cast<std::size_t>(end - first);
      if (end != buffer_[i].end()) break;
    }
    return std::min(n, cap);
  }

  /// Converts the first n buffered events into `out` (the one copy) and drops them.
  void take(std::size_t n, EventCD* out) {
    while (n > 0) {
      std::vector<Event>& front = buffer_.front();
      const std::size_t k = std::min(n, front.size() - front_pos_);
      fill_events(std::span<const Event>(front.data() + front_pos_, k), out, source_->unit);
      out += k;
      n -= k;
      buffered_ -= k;
      front_pos_ += k;
      if (front_pos_ == front.size()) {
        spare_ = std::move(front);
        buffer_.pop_front();
        front_pos_ = 0;
      }
    }
  }

  OneCallAtATime one_call_{"fdv.EventIterator"};
  std::shared_ptr<Source> source_;
  std::unique_ptr<RecordingReader> reader_;
  SensorChunk chunk_;
  std::deque<std::vector<Event>> buffer_;
  std::vector<Event> spare_;  ///< a consumed buffer, handed back to the reader
  std::size_t front_pos_ = 0, buffered_ = 0;
  bool eof_ = false;
  std::optional<TimeNs> delta_t_ns_;
  std::optional<std::size_t> n_events_;
  std::optional<TimeNs> window_end_;
  std::uint64_t empty_in_a_row_ = 0;
};

py::list depth_list(const std::vector<DepthFrame>& frames, TimeUnit u) {
  py::list l;
  for (const DepthFrame& f : frames) l.append(py::make_tuple(from_ns(f.t, u), depth_mm_array(f)));
  return l;
}

/// Every stream of one read() as arrays: the order to push them into a Perception.
py::dict chunk_dict(const SensorChunk& c, TimeUnit u) {
  py::dict d;
  py::array_t<EventCD> events(static_cast<py::ssize_t>(c.events.size()));
  fill_events(c.events, events.mutable_data(), u);
  d["events"] = events;
  d["imu"] = imu_array(c.imu, u);
  d["odometry"] = odometry_array(c.odometry, u);
  d["depth"] = depth_list(c.depth, u);
  d["ground_truth"] = object_array(c.ground_truth, u);
  return d;
}

class ChunkIterator {
 public:
  explicit ChunkIterator(std::shared_ptr<Source> source) : source_(std::move(source)), reader_(source_->open()) {}
  py::dict next() {
    const auto held = one_call_.enter();
    if (source_->closed) {
      reader_.reset();
      source_->check_open();
    }
    bool more;
    {
      py::gil_scoped_release release;
      more = reader_->read(chunk_);
    }
    if (!more) throw py::stop_iteration();
    return chunk_dict(chunk_, source_->unit);
  }

 private:
  OneCallAtATime one_call_{"fdv.ChunkIterator"};
  std::shared_ptr<Source> source_;
  std::unique_ptr<RecordingReader> reader_;
  SensorChunk chunk_;
};

/// Every stream in one time order (TimeOrderedMerger, as `fdv run` feeds its Perception):
/// ("events", array) for a run of events, ("imu" | "odometry" | "ground_truth", 1-record array),
/// ("depth", (t, uint16 mm array)).
class MergedIterator {
 public:
  explicit MergedIterator(std::shared_ptr<Source> source) : source_(std::move(source)) {
    std::vector<std::unique_ptr<RecordingReader>> readers;
    readers.push_back(source_->open());
    merger_ = std::make_unique<TimeOrderedMerger>(std::move(readers));
  }
  py::tuple next() {
    const auto held = one_call_.enter();
    if (source_->closed) {
      merger_.reset();
      source_->check_open();
    }
    StreamItem item;
    bool more;
    {
      py::gil_scoped_release release;
      more = merger_->next(item);
    }
    if (!more) throw py::stop_iteration();
    const TimeUnit u = source_->unit;
    switch (item.kind) {
      case StreamKind::kEvents: {
        py::array_t<EventCD> a(static_cast<py::ssize_t>(item.events.size()));
        fill_events(item.events, a.mutable_data(), u);
        return py::make_tuple("events", a);
      }
      case StreamKind::kImu: return py::make_tuple("imu", imu_array({*item.imu}, u));
      case StreamKind::kOdometry: return py::make_tuple("odometry", odometry_array({*item.odometry}, u));
      case StreamKind::kDepth:
        return py::make_tuple("depth", py::make_tuple(from_ns(item.depth->t, u), depth_mm_array(*item.depth)));
      default: return py::make_tuple("ground_truth", object_array({*item.ground_truth}, u));
    }
  }

 private:
  OneCallAtATime one_call_{"fdv.MergedIterator"};
  std::shared_ptr<Source> source_;
  std::unique_ptr<TimeOrderedMerger> merger_;
};

class Recording {
 public:
  Recording(const std::string& path, const ReaderOptions& options, const std::string& time_unit)
      : source_(std::make_shared<Source>(Source{path, options, parse_time_unit(time_unit)})) {
    info_ = source_->open()->info();  // opening checks the file: InputError now, not at first read
  }

  const RecordingInfo& recording_info() const { return info_; }
  const Source& source() const { return *source_; }

  /// `fdv info`'s summary (reads the whole recording once; kept).
  py::object info() {
    if (!summary_) {
      auto reader = source_->open();
      nlohmann::json j;
      {
        py::gil_scoped_release release;
        j = summarize_recording(*reader);
      }
      summary_ = to_python(j);
    }
    return *summary_;
  }

  EventIterator events(std::optional<std::int64_t> delta_t, std::optional<std::int64_t> n_events) {
    return EventIterator(source_, delta_t, n_events);
  }
  ChunkIterator chunks() { return ChunkIterator(source_); }
  MergedIterator merged() { return MergedIterator(source_); }

  /// One whole stream other than events (the recording is read once for it, events skipped).
  py::object stream(StreamKind kind) {
    auto reader = source_->open();
    SensorChunk chunk, all;
    {
      py::gil_scoped_release release;
      while (reader->read(chunk)) {
        auto append = [](auto& to, auto& from) { to.insert(to.end(), std::make_move_iterator(from.begin()), std::make_move_iterator(from.end())); };
        if (kind == StreamKind::kImu) append(all.imu, chunk.imu);
        if (kind == StreamKind::kOdometry) append(all.odometry, chunk.odometry);
        if (kind == StreamKind::kDepth) append(all.depth, chunk.depth);
        if (kind == StreamKind::kGroundTruth) append(all.ground_truth, chunk.ground_truth);
      }
    }
    const TimeUnit u = source_->unit;
    switch (kind) {
      case StreamKind::kImu: return imu_array(all.imu, u);
      case StreamKind::kOdometry: return odometry_array(all.odometry, u);
      case StreamKind::kDepth: return depth_list(all.depth, u);
      default: return object_array(all.ground_truth, u);
    }
  }

  void close() { source_->closed = true; }
  bool closed() const { return source_->closed; }

 private:
  std::shared_ptr<Source> source_;
  RecordingInfo info_;
  std::optional<py::object> summary_;
};

}  // namespace

void register_reading(py::module_& m) {
  py::class_<EventIterator>(m, "EventIterator")
      .def("__iter__", [](EventIterator& it) -> EventIterator& { return it; })
      .def("__next__", &EventIterator::next);
  py::class_<ChunkIterator>(m, "ChunkIterator")
      .def("__iter__", [](ChunkIterator& it) -> ChunkIterator& { return it; })
      .def("__next__", &ChunkIterator::next);

  py::class_<MergedIterator>(m, "MergedIterator")
      .def("__iter__", [](MergedIterator& it) -> MergedIterator& { return it; })
      .def("__next__", &MergedIterator::next);

  py::class_<Recording>(m, "Recording",
                        "A recording opened by fdv.open(). Iterating it yields numpy arrays of events "
                        "(fdv.EVENT_DTYPE), chunk by chunk as read.")
      .def_property_readonly("info", &Recording::info, "the JSON summary of `fdv info`, as a dict (reads the whole file once)")
      .def_property_readonly("path", [](const Recording& r) { return r.source().path; })
      .def_property_readonly("format", [](const Recording& r) { return r.recording_info().format; })
      .def_property_readonly("width", [](const Recording& r) { return r.recording_info().width; })
      .def_property_readonly("height", [](const Recording& r) { return r.recording_info().height; })
      .def_property_readonly("calibration", [](const Recording& r) { return r.recording_info().calibration; },
                             "the recording's own Calibration, or None")
      .def_property_readonly("time_unit", [](const Recording& r) { return r.source().unit == TimeUnit::kUs ? "us" : "ns"; })
      .def_property_readonly("closed", &Recording::closed)
      .def("events", &Recording::events, py::arg("delta_t") = py::none(), py::arg("n_events") = py::none(),
           py::keep_alive<0, 1>(),
           "Iterator of event arrays: by chunk as read (no arguments); slices of delta_t µs from the "
           "first event's time, empty ones included; slices of n_events; or both (a slice ends at "
           "whichever comes first), as Metavision's EventsIterator.")
      .def("__iter__", [](Recording& r) { return r.events(std::nullopt, std::nullopt); }, py::keep_alive<0, 1>())
      .def("chunks", &Recording::chunks, py::keep_alive<0, 1>(),
           "Iterator of dicts, one per read: events, imu, odometry, depth [(t, uint16 mm array)], ground_truth")
      .def("merged", &Recording::merged, py::keep_alive<0, 1>(),
           "Iterator of (kind, data) in one time order, as `fdv run` feeds its pipeline: (\"events\", "
           "array), (\"imu\" | \"odometry\" | \"ground_truth\", one-record array), (\"depth\", (t, uint16 mm))")
      .def("imu", [](Recording& r) { return r.stream(StreamKind::kImu); }, "the IMU stream (fdv.IMU_DTYPE)")
      .def("odometry", [](Recording& r) { return r.stream(StreamKind::kOdometry); }, "fdv.ODOMETRY_DTYPE")
      .def("depth", [](Recording& r) { return r.stream(StreamKind::kDepth); },
           "[(t, depth)]: uint16 millimetres, shape (height, width), 0 = no depth")
      .def("ground_truth", [](Recording& r) { return r.stream(StreamKind::kGroundTruth); }, "fdv.OBJECT_DTYPE")
      .def("close", &Recording::close)
      .def("__enter__", [](Recording& r) -> Recording& { return r; })
      .def("__exit__", [](Recording& r, const py::args&) { r.close(); })
      .def("__repr__", [](const Recording& r) {
        return "<fdv.Recording " + r.source().path + " (" + r.recording_info().format + ")" +
               (r.closed() ? " closed>" : ">");
      });

  m.def(
      "open",
      [](const std::string& path, const std::string& events_topic, const std::string& imu_topic,
         const std::string& depth_topic, const std::string& odometry_topic, const std::string& ground_truth_topic,
         std::size_t chunk_events, const std::string& time_unit,
         std::optional<std::pair<int, int>> resolution) {
        ReaderOptions o;
        set_resolution(o, resolution);
        o.events_topic = events_topic;
        o.imu_topic = imu_topic;
        o.depth_topic = depth_topic;
        o.odometry_topic = odometry_topic;
        o.ground_truth_topic = ground_truth_topic;
        if (chunk_events == 0) throw py::value_error("chunk_events must be > 0");
        o.chunk_events = chunk_events;
        return Recording(path, o, time_unit);
      },
      py::arg("path"), py::kw_only(), py::arg("events_topic") = "", py::arg("imu_topic") = "",
      py::arg("depth_topic") = "", py::arg("odometry_topic") = "", py::arg("ground_truth_topic") = "",
      py::arg("chunk_events") = std::size_t{1} << 16, py::arg("time_unit") = "us",
      py::arg("resolution") = py::none(),
      "Opens any supported recording (format detected, as `fdv info`). Topics: ROS bags only (empty: "
      "chosen by type). time_unit 'us' (Metavision's, default) or 'ns' for every `t` field. "
      "resolution=(width, height): the sensor size of a file that does not give it (HDF5, DSEC layout).");
}

}  // namespace fdv::python
