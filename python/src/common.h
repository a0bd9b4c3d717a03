#pragma once
// What the binding files share: the numpy record layouts, time units, JSON to Python, and the
// registration function of each file (module.cpp calls them).
//
//   py::array_t<EventCD> a(n);   fill_events(events, a.mutable_data(), TimeUnit::kUs);
//   py::object row = to_python(nlohmann::json(window_row(w)));
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>
#include <nlohmann/json.hpp>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "fdv/core/sensor_data.h"
#include "fdv/io/recording.h"

namespace fdv::python {
namespace py = pybind11;

/// Metavision's EventCD layout: x, y at 0 and 2, p at 4, two bytes of padding, t at 8; 16 bytes.
struct EventCD {
  std::uint16_t x;
  std::uint16_t y;
  std::int16_t p;  ///< 1 ON (brightness increase), 0 OFF
  std::int64_t t;  ///< µs by default, ns with time_unit="ns"
};
static_assert(offsetof(EventCD, p) == 4 && offsetof(EventCD, t) == 8 && sizeof(EventCD) == 16);

struct ImuRecord {
  std::int64_t t;
  double gx, gy, gz;  ///< angular velocity in the IMU frame [rad/s]
  double ax, ay, az;  ///< specific force [m/s²]
};
struct OdometryRecord {
  std::int64_t t;
  double px, py, pz;      ///< body position in W [m]
  double qx, qy, qz, qw;  ///< body attitude q_W_B
  double vx, vy, vz;      ///< velocity in W [m/s]
  double wx, wy, wz;      ///< angular velocity in B [rad/s]
};
struct ObjectRecord {
  std::int64_t t;
  std::int32_t id;
  double px, py, pz;  ///< object centre in W [m]
  double vx, vy, vz;  ///< [m/s]
};

/// Thread safety of the Python objects: each call holds the GIL except where it reads or runs
/// C++ work, so an object whose calls release the GIL keeps a second thread out: fdv.Perception
/// serialises its calls (a lock taken with the GIL released); the iterators of a recording refuse
/// a call while another thread's runs (OneCallAtATime). The value classes (Calibration,
/// PerceptionOptions) and fdv.Recording's own methods run under the GIL throughout.
///
/// One call at a time on an object whose calls release the GIL: a second thread's call while one
/// runs raises RuntimeError naming the object, instead of racing on its state. (Blocking instead
/// would deadlock: the first call takes the GIL back while the second holds it, waiting.)
class OneCallAtATime {
 public:
  explicit OneCallAtATime(const char* name) : name_(name) {}
  /// Holds the object until the lock goes out of scope.
  [[nodiscard]] std::unique_lock<std::mutex> enter() {
    std::unique_lock lock(*mutex_, std::try_to_lock);
    if (!lock.owns_lock())
      throw std::runtime_error(std::string(name_) +
                               ": used from two threads at once; give each thread its own iterator");
    return lock;
  }

 private:
  const char* name_;
  std::unique_ptr<std::mutex> mutex_ = std::make_unique<std::mutex>();  ///< movable with its owner
};

/// Unit of the `t` field of every array in and out: Metavision's µs by default, or ns.
enum class TimeUnit { kUs, kNs };
TimeUnit parse_time_unit(const std::string& name);
inline std::int64_t ns_per_unit(TimeUnit u) { return u == TimeUnit::kUs ? kNsPerUs : 1; }
/// Floor division, so that a negative stamp keeps its order.
inline std::int64_t from_ns(TimeNs t, TimeUnit u) {
  const std::int64_t d = ns_per_unit(u);
  return t >= 0 ? t / d : -((-t + d - 1) / d);
}
TimeNs to_ns(std::int64_t t, TimeUnit u);  ///< throws ValueError on overflow

/// Sets the sensor size of a file that does not give it (HDF5's DSEC layout) from Python's
/// `resolution=(width, height)`; None leaves it to the file. ValueError outside 1..65535.
void set_resolution(ReaderOptions& o, const std::optional<std::pair<int, int>>& resolution);

void fill_events(std::span<const Event> events, EventCD* out, TimeUnit u);
py::array_t<ImuRecord> imu_array(const std::vector<ImuSample>& samples, TimeUnit u);
py::array_t<OdometryRecord> odometry_array(const std::vector<OdometrySample>& samples, TimeUnit u);
py::array_t<ObjectRecord> object_array(const std::vector<ObjectState>& states, TimeUnit u);
/// Depth in uint16 millimetres (0 = no depth; beyond 65.535 m saturates), shape (height, width).
py::array_t<std::uint16_t> depth_mm_array(const DepthFrame& frame);

/// A 1-D C-contiguous array of exactly `dtype`, else TypeError / ValueError naming `what`.
void require_records(const py::array& a, const py::dtype& dtype, const char* what);

/// Python objects of a JSON value (dict, list, float, int, bool, str, None).
py::object to_python(const nlohmann::json& j);
/// Through Python's json module: dicts of str keys, lists, numbers, bools, None.
nlohmann::json from_python(const py::handle& o);

void register_options(py::module_& m);     // module.cpp: Calibration, PerceptionOptions
// (module.cpp registers the record dtypes first: PYBIND11_NUMPY_DTYPE is a statement.)
void register_reading(py::module_& m);     // reading.cpp
void register_perception(py::module_& m);  // perception.cpp: Perception, run
void register_simulation(py::module_& m);  // simulation.cpp: simulate, load_truth

}  // namespace fdv::python
