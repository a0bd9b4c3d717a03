#pragma once
/// Mean angular velocity of an event window from the IMU samples around it.
///
///   ImuWindowSummary s = summarize_imu(imu, t0, t1, 20 * kNsPerMs);
///   if (s.available) omega_E = calib.R_E_I() * s.mean_gyro_I;
///
/// The gyro signal is held piecewise linear between samples and constant beyond the first and
/// last ones; its time average over [t0, t1] is the paper's ω̄ (§IV-A). Samples must be time-ordered
/// (a sample older than its predecessor is skipped and counted); non-finite samples are skipped and
/// counted. The summary is "available" when at least one usable sample lies within max_gap_ns of
/// the window; a spacing larger than max_gap_ns between the samples that cover the window (or
/// between the window's ends and the nearest sample) is flagged as a gap: the mean is still
/// computed from what is there, and the caller reports the flag.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <Eigen/Core>
#include <optional>
#include <span>

#include "fdv/core/sensor_data.h"

namespace fdv {

struct ImuWindowSummary {
  bool available = false;
  Eigen::Vector3d mean_gyro_I = Eigen::Vector3d::Zero();  ///< [rad/s], IMU frame
  int samples_used = 0;
  int samples_skipped = 0;     ///< non-finite or out of time order
  TimeNs largest_gap_ns = 0;   ///< largest spacing covering the window (incl. its ends)
  bool gap = false;            ///< largest_gap_ns > max_gap_ns
};

ImuWindowSummary summarize_imu(std::span<const ImuSample> imu, TimeNs t0, TimeNs t1, TimeNs max_gap_ns);

/// How a fixed direction's coordinates in the IMU frame change from t0 to t1 (either order) as
/// the IMU turns: d_I(t1) = R d_I(t0), R = Π exp(−[ω̄_k]× Δt_k) over steps of at most 5 ms, each
/// with its mean gyro (summarize_imu). Nothing when summarize_imu has no sample for a step.
std::optional<Eigen::Matrix3d> imu_turn(std::span<const ImuSample> imu, TimeNs t0, TimeNs t1, TimeNs max_gap_ns);

}  // namespace fdv
