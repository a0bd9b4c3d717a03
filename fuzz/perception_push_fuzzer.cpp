// What fdv.Perception's push_events / push_imu / push_odometry / push_depth hand the pipeline
// (python/src/perception.cpp), from arbitrary record values: the binding checks an array's dtype,
// shape and event time order, and passes every value through; the pipeline must take any value
// without a crash, a sanitizer report or an exception (what it cannot use is dropped and
// counted), and finish() must account for every event: counted, or reported as dropped. The
// input is a list of pushes, each a kind byte and its records; a 64x48 event camera with a 16x12
// depth camera.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "fdv/pipeline/perception.h"
#include "fuzz/fuzz_support.h"

namespace {

using namespace fdv;

constexpr int kDepthWidth = 16, kDepthHeight = 12;

/// Reads fixed-size little-endian values from the input; zeros once it runs out.
class Records {
 public:
  Records(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  template <class T>
  T next() {
    T v{};
    const std::size_t n = std::min(sizeof(T), size_ - std::min(pos_, size_));
    if (n > 0) std::memcpy(&v, data_ + pos_, n);
    pos_ += sizeof(T);
    return v;
  }
  Eigen::Vector3d vector3() {
    const double x = next<double>(), y = next<double>(), z = next<double>();
    return {x, y, z};
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_, pos_ = 0;
};

Calibration small_rig() {
  Calibration c;
  c.event_camera = {.width = 64, .height = 48, .fx = 60, .fy = 60, .cx = 32, .cy = 24, .distortion = {}};
  c.depth_camera = PinholeCamera{.width = kDepthWidth, .height = kDepthHeight, .fx = 15, .fy = 15, .cx = 8, .cy = 6, .distortion = {}};
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const Calibration rig = small_rig();
  Perception perception(rig, PerceptionOptions{}, {});
  Records in(data, size);
  std::vector<Event> events;
  TimeNs last_event = std::numeric_limits<TimeNs>::min();
  std::uint64_t pushed = 0;
  while (!in.empty()) {
    switch (in.next<std::uint8_t>() % 4) {
      case 0: {  // push_events: up to 64 records of fdv.EVENT_DTYPE (x, y, p, t), t in ns
        events.resize(in.next<std::uint8_t>() % 65);
        TimeNs last = last_event;
        bool backwards = false;
        for (Event& e : events) {
          e.x = in.next<std::uint16_t>();
          e.y = in.next<std::uint16_t>();
          e.polarity = in.next<std::int16_t>() > 0;
          e.t = in.next<std::int64_t>();
          backwards = backwards || e.t < last;
          last = e.t;
        }
        if (backwards) break;  // the binding refuses the whole array
        perception.push_events(events);
        pushed += events.size();
        last_event = last;
        break;
      }
      case 1: {  // push_imu: one fdv.IMU_DTYPE record
        ImuSample s;
        s.t = in.next<std::int64_t>();
        s.gyro_rad_s = in.vector3();
        s.accel_m_s2 = in.vector3();
        perception.push_imu(s);
        break;
      }
      case 2: {  // push_odometry: one fdv.ODOMETRY_DTYPE record, its quaternion as given
        OdometrySample s;
        s.t = in.next<std::int64_t>();
        s.p_W_B = in.vector3();
        const double qw = in.next<double>(), qx = in.next<double>(), qy = in.next<double>(), qz = in.next<double>();
        s.q_W_B = Eigen::Quaterniond(qw, qx, qy, qz);
        s.v_W = in.vector3();
        s.omega_B = in.vector3();
        perception.push_odometry(s);
        break;
      }
      default: {  // push_depth: uint16 millimetres of the depth camera's shape, at t
        DepthFrame f;
        f.t = in.next<std::int64_t>();
        f.width = kDepthWidth;
        f.height = kDepthHeight;
        f.depth_m.resize(kDepthWidth * kDepthHeight);
        for (float& d : f.depth_m) d = static_cast<float>(in.next<std::uint16_t>()) * 1e-3f;
        perception.push_depth(f);
        break;
      }
    }
  }
  perception.finish();
  const PerceptionCounters& c = perception.counters();
  // Every pushed event is counted, or dropped for a corrupt time and reported (perception.h).
  const auto& dropped = perception.input_report().dropped();
  const auto corrupt = dropped.find("event: time out of range (corrupt)");
  const std::uint64_t dropped_events = corrupt == dropped.end() ? 0 : corrupt->second.count;
  if (c.events + dropped_events != pushed)
    fuzz::contract_broken("events pushed differ from those counted and dropped",
                          std::to_string(c.events) + " + " + std::to_string(dropped_events) + " != " + std::to_string(pushed));
  // events = events_in_windows + the windower's decimated ones, which `overload` counts with the
  // compensation's burst cap (perception.h).
  if (c.events < c.events_in_windows || c.events > c.events_in_windows + c.events_dropped.overload)
    fuzz::contract_broken("an event landed in no window and was not decimated", std::to_string(c.events));
  return 0;
}
