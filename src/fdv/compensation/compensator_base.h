#pragma once
/// Internal: what every compensation strategy shares — the undistortion table, the output buffers,
/// the IMU / odometry summary of the window, the overload guard, and the per-event warp loop.
/// Include only from compensation/*.cpp and tests.
/// Thread safety: not thread-safe (output buffers reused per window); one instance per thread.
#include <cmath>
#include <limits>
#include <memory>

#include "fdv/compensation/compensator.h"
#include "fdv/compensation/imu_window.h"
#include "fdv/compensation/undistortion_map.h"

namespace fdv::internal {

class CompensatorBase : public Compensator {
 public:
  CompensatorBase(CompensationMethod method, const Calibration& calibration, const CompensationOptions& options,
                  std::shared_ptr<const UndistortionMap> map);
  CompensationMethod method() const override { return method_; }

 protected:
  /// Resets the output for a new window, fills the report's motion fields (ω in E from the IMU,
  /// camera velocity in E from the odometry, both whenever available, whatever the method) and
  /// returns the IMU summary.
  ImuWindowSummary begin_window(const CompensationInput& in);
  /// Stride of the overload guard (1 unless the window holds more than max_events_per_window).
  std::size_t burst_stride(std::size_t n) const {
    return n <= options_.max_events_per_window ? 1 : (n + options_.max_events_per_window - 1) / options_.max_events_per_window;
  }

  /// The per-event loop: undistort (table), warp (kernel), round to the nearest pixel, drop and
  /// count. Kernel: bool operator()(int raw_index, NormalizedRay ray, float dt_s, float& u, float& v)
  /// writes the warped undistorted-grid position, false when the point falls behind the camera.
  template <class Kernel>
  void run_warp(const CompensationInput& in, Kernel& kernel);

  CompensationMethod method_;
  Calibration calibration_;
  CompensationOptions options_;
  std::shared_ptr<const UndistortionMap> map_;
  CompensatedWindow out_;
};

template <class Kernel>
void CompensatorBase::run_warp(const CompensationInput& in, Kernel& kernel) {
  CompensationReport& rep = out_.report;
  const std::span<const Event> events = in.events;
  const std::size_t stride = burst_stride(events.size());
  const std::size_t visited = stride == 1 ? events.size() : (events.size() + stride - 1) / stride;
  rep.dropped_burst = events.size() - visited;
  out_.reserve_events(visited);
  const int w = map_->width(), h = map_->height();
  const float u_hi = static_cast<float>(w) - 0.5f, v_hi = static_cast<float>(h) - 0.5f;
  const NormalizedRay* rays = map_->rays();
  float* ox = out_.x_data();
  float* oy = out_.y_data();
  float* ot = out_.t_data();
  std::int32_t* op = out_.pixel_data();
  const TimeNs t0 = in.t_start, t1 = in.t_end;
  std::uint64_t outside_window = 0, outside_sensor = 0, no_inverse = 0, left = 0, out_of_order = 0;
  TimeNs previous_t = std::numeric_limits<TimeNs>::min();
  std::size_t n = 0;
  // Events arrive in time order, not pixel order: the table lookups are scattered over a table
  // larger than L2. Prefetching a few events ahead hides most of that latency.
  constexpr std::size_t kPrefetch = 16;
  const std::size_t n_events = events.size();
  for (std::size_t i = 0; i < n_events; i += stride) {
    if (i + kPrefetch * stride < n_events) {
      const Event& ahead = events[i + kPrefetch * stride];
      if (ahead.x < w && ahead.y < h) {
        __builtin_prefetch(rays + ahead.y * w + ahead.x);
        kernel.prefetch(ahead.y * w + ahead.x);
      }
    }
    const Event& e = events[i];
    out_of_order += e.t < previous_t;
    previous_t = e.t;
    if (e.t < t0 || e.t >= t1) {
      ++outside_window;
      continue;
    }
    if (e.x >= w || e.y >= h) {
      ++outside_sensor;
      continue;
    }
    const int raw = e.y * w + e.x;
    const NormalizedRay r = rays[raw];
    if (std::isnan(r.x)) {
      ++no_inverse;
      continue;
    }
    const float dt = static_cast<float>(e.t - t0) * 1e-9f;
    float u, v;
    // Nearest pixel: in range, u + 0.5 >= 0, so truncation is floor (round half up).
    if (!kernel(raw, r, dt, u, v) || !(u >= -0.5f && u < u_hi && v >= -0.5f && v < v_hi)) {
      ++left;
      continue;
    }
    ox[n] = u;
    oy[n] = v;
    ot[n] = dt;
    op[n] = static_cast<int>(v + 0.5f) * w + static_cast<int>(u + 0.5f);
    ++n;
  }
  out_.set_size(n);
  rep.events_kept = n;
  rep.dropped_outside_window = outside_window;
  rep.dropped_outside_sensor = outside_sensor;
  rep.dropped_no_inverse = no_inverse;
  rep.dropped_left_image = left;
  rep.events_out_of_order = out_of_order;
}

/// Undistortion only: u = fx·x + cx.
struct IdentityKernel {
  float fx, fy, cx, cy;
  void prefetch(int) const {}
  bool operator()(int, NormalizedRay r, float, float& u, float& v) const {
    u = fx * r.x + cx;
    v = fy * r.y + cy;
    return true;
  }
};

}  // namespace fdv::internal
