#include "fdv/compensation/compensator_base.h"

namespace fdv::internal {

CompensatorBase::CompensatorBase(CompensationMethod method, const Calibration& calibration,
                                 const CompensationOptions& options, std::shared_ptr<const UndistortionMap> map)
    : method_(method), calibration_(calibration), options_(options), map_(std::move(map)) {
  out_.width = map_->width();
  out_.height = map_->height();
  // A busy window holds about one event per pixel: its buffers are made and faulted in here, not
  // in the first window (docs/BENCHMARKS.md, "No cold first window"). A larger window grows them.
  out_.reserve_events(static_cast<std::size_t>(out_.width) * static_cast<std::size_t>(out_.height));
}

ImuWindowSummary CompensatorBase::begin_window(const CompensationInput& in) {
  out_.t_start = in.t_start;
  out_.t_end = in.t_end;
  out_.set_size(0);
  out_.set_window_t_s_size(0);
  CompensationReport& rep = out_.report;
  rep = CompensationReport{};
  rep.requested = rep.used = method_;
  rep.events_in = in.events.size();
  const ImuWindowSummary imu = summarize_imu(in.imu, in.t_start, in.t_end, options_.max_imu_gap_ns);
  rep.imu_samples = imu.samples_used;
  rep.imu_largest_gap_ns = imu.largest_gap_ns;
  rep.imu_gap = imu.available && imu.gap;
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();
  if (imu.available) {
    rep.has_omega = true;
    rep.omega_E = calibration_.R_E_I() * imu.mean_gyro_I;
    omega_B = calibration_.R_B_I * imu.mean_gyro_I;
  }
  if (in.odometry && in.odometry->v_W.allFinite() && in.odometry->q_W_B.coeffs().allFinite()) {
    rep.has_velocity = true;
    rep.v_E = camera_velocity_E(calibration_, *in.odometry, omega_B);
  }
  return imu;
}

}  // namespace fdv::internal
