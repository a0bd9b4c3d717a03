// The `fdv._fdv` extension: errors, record layouts, Calibration and PerceptionOptions; the other
// files register reading, the pipeline and the simulator.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>

#include "fdv/core/calibration.h"
#include "fdv/core/error.h"
#include "fdv/pipeline/options_yaml.h"
#include "common.h"

namespace fdv::python {

TimeUnit parse_time_unit(const std::string& name) {
  if (name == "us") return TimeUnit::kUs;
  if (name == "ns") return TimeUnit::kNs;
  throw py::value_error("time_unit must be 'us' or 'ns', got '" + name + "'");
}

TimeNs to_ns(std::int64_t t, TimeUnit u) {
  TimeNs out;
  if (__builtin_mul_overflow(t, ns_per_unit(u), &out))
    throw py::value_error("time " + std::to_string(t) + " overflows int64 nanoseconds");
  return out;
}

void set_resolution(ReaderOptions& o, const std::optional<std::pair<int, int>>& resolution) {
  if (!resolution) return;
  const auto [w, h] = *resolution;
  if (w < 1 || h < 1 || w > 65535 || h > 65535)
    throw py::value_error("resolution must be (width, height) with sides in 1..65535");
  o.width = w;
  o.height = h;
}

void fill_events(std::span<const Event> events, EventCD* out, TimeUnit u) {
  if (u == TimeUnit::kNs) {
    for (const Event& e : events) *out++ = {e.x, e.y, static_cast<std::int16_t>(e.polarity), e.t};
  } else {
    // A constant divisor: a multiply, not a division per event (a third of the conversion's time).
    for (const Event& e : events)
      *out++ = {e.x, e.y, static_cast<std::int16_t>(e.polarity), e.t >= 0 ? e.t / kNsPerUs : from_ns(e.t, u)};
  }
}

py::array_t<ImuRecord> imu_array(const std::vector<ImuSample>& samples, TimeUnit u) {
  py::array_t<ImuRecord> a(static_cast<py::ssize_t>(samples.size()));
  ImuRecord* out = a.mutable_data();
  for (const ImuSample& s : samples)
    *out++ = {from_ns(s.t, u), s.gyro_rad_s.x(), s.gyro_rad_s.y(), s.gyro_rad_s.z(),
              s.accel_m_s2.x(), s.accel_m_s2.y(), s.accel_m_s2.z()};
  return a;
}

py::array_t<OdometryRecord> odometry_array(const std::vector<OdometrySample>& samples, TimeUnit u) {
  py::array_t<OdometryRecord> a(static_cast<py::ssize_t>(samples.size()));
  OdometryRecord* out = a.mutable_data();
  for (const OdometrySample& s : samples)
    *out++ = {from_ns(s.t, u), s.p_W_B.x(), s.p_W_B.y(), s.p_W_B.z(), s.q_W_B.x(), s.q_W_B.y(),
              s.q_W_B.z(), s.q_W_B.w(), s.v_W.x(), s.v_W.y(), s.v_W.z(), s.omega_B.x(),
              s.omega_B.y(), s.omega_B.z()};
  return a;
}

py::array_t<ObjectRecord> object_array(const std::vector<ObjectState>& states, TimeUnit u) {
  py::array_t<ObjectRecord> a(static_cast<py::ssize_t>(states.size()));
  ObjectRecord* out = a.mutable_data();
  for (const ObjectState& s : states)
    *out++ = {from_ns(s.t, u), s.id, s.p_W.x(), s.p_W.y(), s.p_W.z(), s.v_W.x(), s.v_W.y(), s.v_W.z()};
  return a;
}

py::array_t<std::uint16_t> depth_mm_array(const DepthFrame& frame) {
  py::array_t<std::uint16_t> a({frame.height, frame.width});
  std::uint16_t* out = a.mutable_data();
  // Round half up by adding 0.5 (std::round per pixel took most of a frame's conversion time).
  for (const float d : frame.depth_m) {
    const float mm = d * 1000.0f + 0.5f;
    *out++ = !(mm >= 1.0f) ? 0 : mm >= 65535.0f ? 65535 : static_cast<std::uint16_t>(mm);  // NaN -> 0
  }
  return a;
}

void require_records(const py::array& a, const py::dtype& dtype, const char* what) {
  if (!a.dtype().equal(dtype))
    throw py::type_error(std::string(what) + ": expected an array of dtype " + py::repr(dtype).cast<std::string>() +
                         ", got " + py::repr(a.dtype()).cast<std::string>());
  if (a.ndim() != 1) throw py::value_error(std::string(what) + ": expected a 1-D array, got " + std::to_string(a.ndim()) + "-D");
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(what) + ": the array is not contiguous (use numpy.ascontiguousarray)");
}

py::object to_python(const nlohmann::json& j) {
  using T = nlohmann::json::value_t;
  switch (j.type()) {
    case T::object: {
      py::dict d;
      for (const auto& [key, value] : j.items()) d[py::str(key)] = to_python(value);
      return d;
    }
    case T::array: {
      py::list l(j.size());
      for (std::size_t i = 0; i < j.size(); ++i) l[i] = to_python(j[i]);
      return l;
    }
    case T::string: return py::str(j.get_ref<const std::string&>());
    case T::boolean: return py::bool_(j.get<bool>());
    case T::number_integer: return py::int_(j.get<std::int64_t>());
    case T::number_unsigned: return py::int_(j.get<std::uint64_t>());
    case T::number_float: return py::float_(j.get<double>());
    default: return py::none();
  }
}

nlohmann::json from_python(const py::handle& o) {
  const std::string text = py::module_::import("json").attr("dumps")(o).cast<std::string>();
  return nlohmann::json::parse(text);
}

namespace {

/// The dotted key of the first number in `o` that is not finite ("" when none): JSON, and so the
/// options' parser, has no NaN or infinity, and the error must name the key, not the parser's byte.
std::string non_finite_key(const py::handle& o, const std::string& key) {
  if (py::isinstance<py::float_>(o)) return std::isfinite(o.cast<double>()) ? "" : key;
  if (py::isinstance<py::dict>(o))
    for (const auto& [k, v] : o.cast<py::dict>()) {
      const std::string name = py::str(k).cast<std::string>();
      if (std::string found = non_finite_key(v, key.empty() ? name : key + "." + name); !found.empty()) return found;
    }
  if (py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o))
    for (const auto& v : o)
      if (std::string found = non_finite_key(v, key); !found.empty()) return found;
  return "";
}

py::array_t<double> matrix_array(const Eigen::Matrix4d& m) {
  py::array_t<double> a({4, 4});
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) a.mutable_at(r, c) = m(r, c);
  return a;
}

}  // namespace

void register_options(py::module_& m) {
  py::class_<Calibration>(m, "Calibration", "Sensor rig calibration (docs/FORMATS.md).")
      .def(py::init<>())
      .def_static("load", &load_calibration, py::arg("path"),
                  "Reads the project's YAML or OpenCV's XML/YAML layout; InputError names the key.")
      .def_static("from_text", &load_calibration_text, py::arg("text"), py::arg("name") = "<text>")
      .def("save", [](const Calibration& c, const std::string& path) { save_calibration(c, path); }, py::arg("path"))
      .def_property_readonly("width", [](const Calibration& c) { return c.event_camera.width; })
      .def_property_readonly("height", [](const Calibration& c) { return c.event_camera.height; })
      .def_property_readonly("K", [](const Calibration& c) {
        Eigen::Matrix3d K;
        K << c.event_camera.fx, 0, c.event_camera.cx, 0, c.event_camera.fy, c.event_camera.cy, 0, 0, 1;
        return K;
      }, "event camera matrix [px]")
      .def("project",
           [](const Calibration& c, const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>& points_E) {
             Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> px(points_E.rows(), 2);
             for (Eigen::Index i = 0; i < points_E.rows(); ++i) {
               const Eigen::Vector3d X = points_E.row(i).transpose();
               const Eigen::Vector2d p = X.z() > 0 ? c.event_camera.project(X)
                                                   : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
               px.row(i) = p.transpose();
             }
             return px;
           },
           py::arg("points_E"), "(N, 3) points in the event camera frame [m] -> (N, 2) raw pixels (NaN behind it)")
      .def_property_readonly("has_depth_camera", [](const Calibration& c) { return c.depth_camera.has_value(); })
      .def_property_readonly("T_B_E", [](const Calibration& c) { return matrix_array(c.T_B_E.matrix()); })
      .def_property_readonly("T_B_D", [](const Calibration& c) { return matrix_array(c.T_B_D.matrix()); })
      .def("__repr__", [](const Calibration& c) {
        return "<fdv.Calibration " + std::to_string(c.event_camera.width) + "x" + std::to_string(c.event_camera.height) +
               (c.depth_camera ? " with depth camera>" : ">");
      });

  // Every conversion goes through the C++ field list (options_yaml.h), so keys, units, defaults
  // and error messages are the ones of `fdv run --config`.
  py::class_<PerceptionOptions>(m, "PerceptionOptions",
                                "Options of every stage; keys as `fdv run --config` (docs/DETECTION.md, "
                                "docs/ESTIMATION.md).")
      .def(py::init<>())
      .def_static("from_yaml",
                  [](const std::string& text, const std::string& name) {
                    py::gil_scoped_release release;
                    return load_perception_options_text(text, name);
                  },
                  py::arg("text"), py::arg("name") = "<yaml>")
      .def_static("load", &load_perception_options_file, py::arg("path"))
      .def_static("from_dict",
                  [](const py::dict& d, const std::string& name) {
                    if (const std::string key = non_finite_key(d, ""); !key.empty())
                      throw InputError(name, "key " + key, "not a finite number");
                    // JSON is YAML: the dict goes through the same parser as a --config file.
                    return load_perception_options_text(from_python(d).dump(), name);
                  },
                  py::arg("d"), py::arg("name") = "<dict>")
      .def("to_yaml", [](const PerceptionOptions& o) { return to_yaml(o); })
      .def("to_dict", [](const PerceptionOptions& o) { return to_python(to_json(o)); })
      .def("__eq__", [](const PerceptionOptions& a, const PerceptionOptions& b) { return to_json(a) == to_json(b); })
      .def("__repr__", [](const PerceptionOptions& o) { return "fdv.PerceptionOptions.from_yaml('''\n" + to_yaml(o) + "''')"; });
}

}  // namespace fdv::python

PYBIND11_MODULE(_fdv, m) {
  namespace py = pybind11;
  using namespace fdv::python;
  m.doc() = "fast-dynamic-vision: readers, the perception pipeline and the simulator (see the fdv package)";
  PYBIND11_NUMPY_DTYPE(EventCD, x, y, p, t);
  PYBIND11_NUMPY_DTYPE(ImuRecord, t, gx, gy, gz, ax, ay, az);
  PYBIND11_NUMPY_DTYPE(OdometryRecord, t, px, py, pz, qx, qy, qz, qw, vx, vy, vz, wx, wy, wz);
  PYBIND11_NUMPY_DTYPE(ObjectRecord, t, id, px, py, pz, vx, vy, vz);
  m.attr("EVENT_DTYPE") = py::dtype::of<EventCD>();
  m.attr("IMU_DTYPE") = py::dtype::of<ImuRecord>();
  m.attr("ODOMETRY_DTYPE") = py::dtype::of<OdometryRecord>();
  m.attr("OBJECT_DTYPE") = py::dtype::of<ObjectRecord>();

  // Same message as the C++ what(): "file:where: reason" / the option's problem.
  py::register_exception<fdv::InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<fdv::ConfigError>(m, "ConfigError", PyExc_ValueError);

  register_options(m);
  register_reading(m);
  register_perception(m);
  register_simulation(m);
}
