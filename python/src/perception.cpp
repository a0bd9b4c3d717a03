// fdv.Perception and fdv.run: the streaming pipeline driven from Python. Results are the rows of
// the results schema (fdv/results/schema.h: window_row, depth_row, ... and their JSON), so a dict
// here has exactly the keys of the line `fdv run` writes. C++ work runs without the GIL; the rows
// it produced are handed to Python when the call returns.
#include <pybind11/stl.h>

#include <cstring>
#include <mutex>
#include <optional>
#include <string>
#include <tuple>

#include "common.h"
#include "fdv/core/error.h"
#include "fdv/detection/detector.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/pipeline/perception.h"
#include "fdv/results/schema.h"
#include "fdv/results/run.h"

namespace fdv::python {
namespace {

enum class RowKind { kWindow, kDepth, kTrajectory, kPrediction, kDodge, kWarning };
constexpr const char* kListNames[] = {"windows", "depth", "trajectories", "predictions", "dodge", "warnings"};

/// A window's detector images and gates (Detector's accessors), copied while the window is current.
struct WindowImages {
  cv::Mat count, normalized, segmentation, preprocessed;
  std::vector<DetectionPrior> priors;
  /// Each stateful source's state images (Detector::for_each_source_state): source, name, copy.
  std::vector<std::tuple<std::string, std::string, cv::Mat>> source_states;
};

struct Row {
  RowKind kind;
  nlohmann::json json;
  std::unique_ptr<WindowImages> images;  ///< windows only, when asked for
};

/// Rows in the order the pipeline produced them, kept until the GIL is held again.
struct RowQueue {
  bool images = false;  ///< copy each window's detector images (WindowImages) with its row
  std::vector<Row> rows;
  PerceptionCallbacks callbacks() {
    PerceptionCallbacks c;
    c.on_window = [this](const WindowResult& w) {
      std::unique_ptr<WindowImages> copy;
      if (images && w.detector) {
        const Detector& d = *w.detector;
        copy = std::make_unique<WindowImages>(WindowImages{d.time_images().count.clone(), d.time_images().normalized.clone(),
                                                           d.segmentation().clone(), d.preprocessed().clone(),
                                                           {w.priors.begin(), w.priors.end()}, {}});
        d.for_each_source_state([&](std::string_view source, const std::vector<SourceStateImage>& state) {
          for (const SourceStateImage& im : state)
            copy->source_states.emplace_back(std::string(source), std::string(im.name), im.image->clone());
        });
      }
      rows.push_back({RowKind::kWindow, window_row(w), std::move(copy)});
    };
    c.on_depth = [this](const DepthResult& d) { rows.push_back({RowKind::kDepth, depth_row(d), nullptr}); };
    c.on_estimate = [this](const EstimateResult& e) { rows.push_back({RowKind::kTrajectory, trajectory_row(e), nullptr}); };
    c.on_prediction = [this](const PredictionResult& p) { rows.push_back({RowKind::kPrediction, prediction_row(p), nullptr}); };
    c.on_dodge = [this](const DodgeDecision& d) { rows.push_back({RowKind::kDodge, dodge_row(d), nullptr}); };
    c.on_warning = [this](const std::string& w) { rows.push_back({RowKind::kWarning, w, nullptr}); };
    return c;
  }
};

/// A single-channel image as a (height, width) numpy array of its element type (a copy).
template <class T>
py::array_t<T> image_array(const cv::Mat& m) {
  py::array_t<T> a({m.rows, m.cols});
  if (m.empty()) return a;
  for (int r = 0; r < m.rows; ++r) std::memcpy(a.mutable_data(r, 0), m.ptr<T>(r), sizeof(T) * static_cast<std::size_t>(m.cols));
  return a;
}

/// A float image of one or more channels as a (height, width) or (height, width, channels) array.
py::array_t<float> float_image_array(const cv::Mat& m) {
  CV_Assert(m.depth() == CV_32F && m.isContinuous());
  std::vector<py::ssize_t> shape{m.rows, m.cols};
  if (m.channels() > 1) shape.push_back(m.channels());
  py::array_t<float> a(shape);
  std::memcpy(a.mutable_data(), m.ptr<float>(), m.total() * m.elemSize());
  return a;
}

/// {"count", "normalized", "segmentation", "preprocessed", "gates", "sources"}: the window's
/// detector images (docs/DETECTION.md: I, N, S, P on the compensated grid), the gates the tracks
/// lent it, and the state of the sources that keep one ({source: {name: array}}).
py::dict images_dict(const WindowImages& im) {
  py::dict d;
  d["count"] = image_array<std::int32_t>(im.count);
  d["normalized"] = image_array<float>(im.normalized);
  d["segmentation"] = image_array<float>(im.segmentation);
  d["preprocessed"] = image_array<float>(im.preprocessed);
  py::list gates;
  for (const DetectionPrior& p : im.priors) {
    py::dict g;
    g["center_raw"] = py::make_tuple(p.center_raw.x(), p.center_raw.y());
    g["box_size"] = py::make_tuple(p.box_size_px.x(), p.box_size_px.y());
    g["confirmed"] = p.confirmed;
    g["from_trajectory"] = p.from_trajectory;
    gates.append(g);
  }
  d["gates"] = gates;
  py::dict sources;
  for (const auto& [source, name, image] : im.source_states) {
    const py::str key(source);
    if (!sources.contains(key)) sources[key] = py::dict();
    sources[key].cast<py::dict>()[py::str(name)] = float_image_array(image);
  }
  d["sources"] = sources;
  return d;
}

/// Where the fields of an event record are: fdv.EVENT_DTYPE (aligned, 16 bytes) or the packed
/// 14-byte layout numpy's promotion gives it (np.concatenate of event arrays returns that).
struct EventLayout {
  std::size_t x, y, p, t, itemsize;
};

EventLayout event_layout(const py::array& a) {
  const py::dtype dt = a.dtype();
  auto fail = [&] {
    return py::type_error("push_events: expected an array of dtype " + py::repr(py::dtype::of<EventCD>()).cast<std::string>() +
                          " (or its packed form), got " + py::repr(dt).cast<std::string>());
  };
  const py::object fields = dt.attr("fields");
  if (fields.is_none() || py::len(fields) != 4) throw fail();
  std::size_t offsets[4];
  const char* names[] = {"x", "y", "p", "t"};
  const py::dtype types[] = {py::dtype::of<std::uint16_t>(), py::dtype::of<std::uint16_t>(), py::dtype::of<std::int16_t>(),
                             py::dtype::of<std::int64_t>()};
  for (int k = 0; k < 4; ++k) {
    if (!fields.contains(names[k])) throw fail();
    const py::tuple f = fields[names[k]];
    if (!f[0].cast<py::dtype>().equal(types[k])) throw fail();
    offsets[k] = f[1].cast<std::size_t>();
  }
  if (a.ndim() != 1) throw py::value_error("push_events: expected a 1-D array, got " + std::to_string(a.ndim()) + "-D");
  if (!(a.flags() & py::array::c_style))
    throw py::value_error("push_events: the array is not contiguous (use numpy.ascontiguousarray)");
  return {offsets[0], offsets[1], offsets[2], offsets[3], static_cast<std::size_t>(dt.itemsize())};
}

template <class T>
T field(const std::byte* record, std::size_t offset) {
  T v;
  std::memcpy(&v, record + offset, sizeof(T));
  return v;
}

/// fdv.Perception. Calls from several Python threads are serialised: each takes the object's lock
/// with the GIL released, so a push racing finish() waits for it (and is then refused as used
/// after finish) instead of corrupting the pipeline. A refused push changes nothing.
class PyPerception {
 public:
  PyPerception(const Calibration& calibration, const PerceptionOptions& options, const std::string& time_unit,
               py::object on_window, py::object on_depth, py::object on_estimate, py::object on_prediction,
               py::object on_dodge, py::object on_warning, bool images)
      : unit_(parse_time_unit(time_unit)),
        handlers_{std::move(on_window), std::move(on_depth), std::move(on_estimate), std::move(on_prediction),
                  std::move(on_dodge), std::move(on_warning)} {
    queue_.images = images;
    perception_ = std::make_unique<Perception>(calibration, options, queue_.callbacks());
  }

  void push_events(const py::array& a) {
    const EventLayout f = event_layout(a);
    const auto* base = static_cast<const std::byte*>(a.data());
    const auto n = static_cast<std::size_t>(a.size());
    locked("push_events", [&] {
      // Checked whole before anything is pushed, so that a refused array leaves the time cursor.
      TimeNs last = last_event_t_;
      events_.resize(n);
      for (std::size_t i = 0; i < n; ++i) {
        const std::byte* r = base + i * f.itemsize;
        const std::uint16_t x = field<std::uint16_t>(r, f.x), y = field<std::uint16_t>(r, f.y);
        const std::int16_t p = field<std::int16_t>(r, f.p);
        const std::int64_t t_unit = field<std::int64_t>(r, f.t);
        const TimeNs t = to_ns(t_unit, unit_);
        // A corrupt time (not valid_time) is Perception's to drop and count, not an order error.
        if (valid_time(t) && t < last)
          throw py::value_error("push_events: event times go backwards at index " + std::to_string(i) + " (t " +
                                std::to_string(t_unit) + " after " + std::to_string(from_ns(last, unit_)) +
                                "); events must be pushed in time order; nothing of this array was pushed");
        if (valid_time(t)) last = t;
        events_[i] = {t, x, y, p > 0};
      }
      perception_->push_events(events_);
      last_event_t_ = last;
    });
  }

  void push_imu(const py::array& a) {
    require_records(a, py::dtype::of<ImuRecord>(), "push_imu");
    const auto* in = static_cast<const ImuRecord*>(a.data());
    std::vector<ImuSample> samples(static_cast<std::size_t>(a.size()));
    for (std::size_t i = 0; i < samples.size(); ++i) {  // converted first: an overflow pushes nothing
      const ImuRecord& r = in[i];
      samples[i] = {to_ns(r.t, unit_), {r.gx, r.gy, r.gz}, {r.ax, r.ay, r.az}};
    }
    // Each sample is checked by Perception: an invalid one is dropped and counted (input_report).
    locked("push_imu", [&] {
      for (const ImuSample& s : samples) perception_->push_imu(s);
    });
  }

  void push_odometry(const py::array& a) {
    require_records(a, py::dtype::of<OdometryRecord>(), "push_odometry");
    const auto* in = static_cast<const OdometryRecord*>(a.data());
    std::vector<OdometrySample> samples(static_cast<std::size_t>(a.size()));
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const OdometryRecord& r = in[i];
      OdometrySample& s = samples[i];
      s.t = to_ns(r.t, unit_);
      s.p_W_B = {r.px, r.py, r.pz};
      s.q_W_B = Eigen::Quaterniond(r.qw, r.qx, r.qy, r.qz);
      s.v_W = {r.vx, r.vy, r.vz};
      s.omega_B = {r.wx, r.wy, r.wz};
    }
    locked("push_odometry", [&] {
      for (const OdometrySample& s : samples) perception_->push_odometry(s);
    });
  }

  /// A depth image in uint16 millimetres (0 = no depth) of the calibration's depth camera size.
  void push_depth(const py::array& a, std::int64_t t) {
    if (!a.dtype().equal(py::dtype::of<std::uint16_t>()))
      throw py::type_error("push_depth: expected uint16 millimetres, got dtype " + py::repr(a.dtype()).cast<std::string>());
    const auto& depth_camera = perception_->calibration().depth_camera;  // set at construction: no lock
    if (!depth_camera) throw py::value_error("push_depth: the calibration has no depth camera");
    const auto shape = [](py::ssize_t h, py::ssize_t w) { return "(" + std::to_string(h) + ", " + std::to_string(w) + ")"; };
    if (a.ndim() != 2 || a.shape(0) != depth_camera->height || a.shape(1) != depth_camera->width)
      throw py::value_error("push_depth: expected shape " + shape(depth_camera->height, depth_camera->width) +
                            " (the calibration's depth camera), got " +
                            (a.ndim() == 2 ? shape(a.shape(0), a.shape(1)) : std::to_string(a.ndim()) + "-D"));
    if (!(a.flags() & py::array::c_style))
      throw py::value_error("push_depth: the array is not contiguous (use numpy.ascontiguousarray)");
    const auto* in = static_cast<const std::uint16_t*>(a.data());
    locked("push_depth", [&] {
      DepthFrame f;
      f.t = to_ns(t, unit_);
      f.width = depth_camera->width;
      f.height = depth_camera->height;
      f.depth_m.resize(static_cast<std::size_t>(a.size()));
      for (std::size_t i = 0; i < f.depth_m.size(); ++i) f.depth_m[i] = static_cast<float>(in[i]) * 1e-3f;
      perception_->push_depth(f);
    });
  }

  py::dict finish() {
    locked("finish", [&] {
      perception_->finish();
      finished_ = true;
    });
    return results();
  }

  /// Every result not given to a callback so far, and the counters.
  py::dict results() const {
    py::dict d;
    for (std::size_t k = 0; k < lists_.size(); ++k) d[kListNames[k]] = lists_[k];
    d["counts"] = counts();
    d["input_report"] = input_report();
    return d;
  }
  py::object counts() const {
    PerceptionCounters c;
    {
      py::gil_scoped_release release;
      std::lock_guard lock(mutex_);
      c = perception_->counters();
    }
    return to_python(counts_json(c));
  }
  /// The pushed samples Perception dropped as invalid: {"dropped": {reason: {count, first}}, ...}.
  py::object input_report() const {
    nlohmann::json j;
    {
      py::gil_scoped_release release;
      std::lock_guard lock(mutex_);
      j = perception_->input_report().to_json();
    }
    return to_python(j);
  }
  const py::list& list(RowKind k) const { return lists_[static_cast<std::size_t>(k)]; }

 private:
  /// Runs `work` on the pipeline under the lock with the GIL released, then hands the rows it
  /// produced to the Python callbacks or lists (with the GIL, outside the lock).
  template <class Work>
  void locked(const char* what, Work&& work) {
    std::vector<Row> rows;
    {
      py::gil_scoped_release release;
      std::lock_guard lock(mutex_);
      if (finished_) throw py::value_error(std::string("Perception.") + what + ": used after finish()");
      work();
      rows.swap(queue_.rows);
    }
    for (const Row& r : rows) {
      const auto k = static_cast<std::size_t>(r.kind);
      py::object row = to_python(r.json);
      if (r.images) row["images"] = images_dict(*r.images);
      if (handlers_[k].is_none())
        lists_[k].append(row);
      else
        handlers_[k](row);
    }
  }

  TimeUnit unit_;
  std::array<py::object, 6> handlers_;
  std::array<py::list, 6> lists_;
  mutable std::mutex mutex_;  ///< guards everything below
  RowQueue queue_;
  std::unique_ptr<Perception> perception_;
  std::vector<Event> events_;
  TimeNs last_event_t_ = std::numeric_limits<TimeNs>::min();
  bool finished_ = false;
};

/// `fdv run` from Python: the library's one run of a recording (fdv/results/run.h), so the same
/// sensor policy, warnings and (with `out`) results folder.
py::dict run(const std::string& path, std::optional<Calibration> calibration, const std::string& calibration_name,
             const PerceptionOptions& requested, const std::string& out, const ReaderOptions& reader_options) {
  RowQueue queue;
  RunOutcome outcome;
  {
    py::gil_scoped_release release;
    RunRequest request;
    request.input = path;
    request.reader = reader_options;
    request.calibration = std::move(calibration);
    request.calibration_source = calibration_name;
    request.options = requested;
    RecordingRun recording(std::move(request));
    PerceptionCallbacks callbacks = queue.callbacks();
    // Ctrl-C at each window's end: the run unwinds, its partial folder is removed, and Python
    // gets its KeyboardInterrupt (the signal's handler runs only when asked, with the GIL).
    callbacks.on_window = [queue_row = callbacks.on_window](const WindowResult& w) {
      queue_row(w);
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    };
    outcome = recording.into(out, callbacks);
  }
  py::dict d;
  for (const char* name : kListNames) d[name] = py::list();
  for (const Row& r : queue.rows)
    if (r.kind != RowKind::kWarning) d[kListNames[static_cast<std::size_t>(r.kind)]].cast<py::list>().append(to_python(r.json));
  d["warnings"] = outcome.warnings;
  d["counts"] = to_python(counts_json(outcome.counts));
  d["reader_report"] = to_python(outcome.reader_report.to_json());
  d["options"] = to_python(outcome.summary.options);  // the options used, fallbacks applied
  return d;
}

}  // namespace

void register_perception(py::module_& m) {
  py::class_<PyPerception>(m, "Perception",
                           "The streaming pipeline (fdv::Perception). Push each stream in its time order; "
                           "results are dicts with the keys of the `fdv run` JSONL lines, given to the "
                           "on_* callbacks at the end of the push that produced them, else kept in the "
                           "lists windows, depth, trajectories, predictions, dodge, warnings.")
      .def(py::init<const Calibration&, const PerceptionOptions&, const std::string&, py::object, py::object,
                    py::object, py::object, py::object, py::object, bool>(),
           py::arg("calibration"), py::arg("options") = PerceptionOptions{}, py::kw_only(),
           py::arg("time_unit") = "us", py::arg("on_window") = py::none(), py::arg("on_depth") = py::none(),
           py::arg("on_estimate") = py::none(), py::arg("on_prediction") = py::none(),
           py::arg("on_dodge") = py::none(), py::arg("on_warning") = py::none(), py::arg("images") = false)
      .def("push_events", &PyPerception::push_events, py::arg("events"), "a 1-D contiguous fdv.EVENT_DTYPE array")
      .def("push_imu", &PyPerception::push_imu, py::arg("imu"), "fdv.IMU_DTYPE samples")
      .def("push_odometry", &PyPerception::push_odometry, py::arg("odometry"), "fdv.ODOMETRY_DTYPE samples")
      .def("push_depth", &PyPerception::push_depth, py::arg("depth_mm"), py::arg("t"),
           "uint16 millimetres, shape (height, width) of the calibration's depth camera; t in time_unit")
      .def("finish", &PyPerception::finish, "flushes the last windows; returns results() (no push after it)")
      .def("results", &PyPerception::results)
      .def_property_readonly("counts", &PyPerception::counts, "summary.json's counts")
      .def_property_readonly("input_report", &PyPerception::input_report,
                             "pushed samples dropped as invalid, by reason (as a reader's report)")
      .def_property_readonly("windows", [](const PyPerception& p) { return p.list(RowKind::kWindow); })
      .def_property_readonly("depth", [](const PyPerception& p) { return p.list(RowKind::kDepth); })
      .def_property_readonly("trajectories", [](const PyPerception& p) { return p.list(RowKind::kTrajectory); })
      .def_property_readonly("predictions", [](const PyPerception& p) { return p.list(RowKind::kPrediction); })
      .def_property_readonly("dodge", [](const PyPerception& p) { return p.list(RowKind::kDodge); })
      .def_property_readonly("warnings", [](const PyPerception& p) { return p.list(RowKind::kWarning); });

  m.def("_run", &run, py::arg("path"), py::arg("calibration"), py::arg("calibration_name"), py::arg("options"),
        py::arg("out"), py::arg("reader_options"));
  py::class_<ReaderOptions>(m, "_ReaderOptions")
      .def(py::init<>())
      .def_readwrite("events_topic", &ReaderOptions::events_topic)
      .def_readwrite("imu_topic", &ReaderOptions::imu_topic)
      .def_readwrite("depth_topic", &ReaderOptions::depth_topic)
      .def_readwrite("odometry_topic", &ReaderOptions::odometry_topic)
      .def_readwrite("ground_truth_topic", &ReaderOptions::ground_truth_topic)
      .def("set_resolution", [](ReaderOptions& o, std::optional<std::pair<int, int>> r) { set_resolution(o, r); });
}

}  // namespace fdv::python
