#pragma once
/// Short histories of the slower sensors, queried by time as event windows complete.
/// Each buffer keeps at most `horizon_ns` of history behind the newest sample. Not thread-safe.
#include <deque>
#include <optional>
#include <string>

#include "fdv/core/sensor_data.h"

namespace fdv {

/// Result of a query over an interval: the value, and whether the data covering it was complete.
struct ImuWindowMean {
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();  ///< mean angular velocity, IMU frame
  int samples = 0;
  TimeNs largest_gap_ns = 0;  ///< largest spacing between samples covering the interval
  bool gap = false;           ///< largest_gap_ns exceeded the buffer's max_gap_ns
};

class ImuBuffer {
 public:
  /// max_gap_ns: spacing beyond which the interval is flagged (default 20 ms: at 200-1000 Hz a
  /// healthy IMU never leaves a gap of that size).
  explicit ImuBuffer(TimeNs horizon_ns = 2 * kNsPerS, TimeNs max_gap_ns = 20 * kNsPerMs)
      : horizon_ns_(horizon_ns), max_gap_ns_(max_gap_ns) {}
  /// Samples must arrive in time order; an older one is ignored and false returned.
  bool push(const ImuSample& s);
  /// Time-weighted mean angular velocity over [t0, t1] (samples held piecewise linear), or
  /// nothing when no sample lies within max_gap_ns of the interval.
  std::optional<ImuWindowMean> mean_gyro(TimeNs t0, TimeNs t1) const;
  bool empty() const { return samples_.empty(); }
  TimeNs newest() const { return samples_.empty() ? 0 : samples_.back().t; }

 private:
  TimeNs horizon_ns_, max_gap_ns_;
  std::deque<ImuSample> samples_;
};

class OdometryBuffer {
 public:
  /// max_extrapolation_ns: how far past the newest sample a query may be answered (held constant
  /// velocity); beyond that the answer is missing.
  explicit OdometryBuffer(TimeNs horizon_ns = 5 * kNsPerS, TimeNs max_extrapolation_ns = 50 * kNsPerMs)
      : horizon_ns_(horizon_ns), max_extrapolation_ns_(max_extrapolation_ns) {}
  bool push(const OdometrySample& s);
  /// The vehicle state at t: interpolated between samples; extrapolated at constant velocity up to
  /// max_extrapolation_ns beyond the ends; nothing otherwise.
  std::optional<OdometrySample> at(TimeNs t) const;
  bool empty() const { return samples_.empty(); }

 private:
  TimeNs horizon_ns_, max_extrapolation_ns_;
  std::deque<OdometrySample> samples_;
};

}  // namespace fdv
