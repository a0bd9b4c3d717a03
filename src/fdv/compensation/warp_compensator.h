#pragma once
/// Internal: the IMU / odometry / depth driven strategies "none", "rotation" (Falanga et al. 2020)
/// and "rotation_translation" (the paper, eqs. 6-8). Create through make_compensator().
/// Thread safety: not thread-safe (as CompensatorBase); one instance per thread.
#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "fdv/compensation/compensator_base.h"

namespace fdv::internal {

class WarpCompensator final : public CompensatorBase {
 public:
  WarpCompensator(CompensationMethod method, const Calibration& calibration, const CompensationOptions& options,
                  std::shared_ptr<const UndistortionMap> map);
  const CompensatedWindow& compensate(const CompensationInput& input) override;
  void prepare_depth_frame(const RegisteredDepth& depth) override;
  Eigen::Vector2d observed_position(const Eigen::Vector2d& px, double t_s) const override;

 private:
  /// K·R_s for each refresh slot of the window (row-major 3x3 floats), R_s the camera's rotation
  /// from the slot's middle time t_s back to the window's start: exp([ω̄]× t_s) with the mean rate
  /// (paper §IV-A), or the gyro integrated over [t0, t0 + t_s] with `integrate_gyro`. The mean rate
  /// stands in when the IMU does not cover a slot, which the window's `imu_gap` flag reports.
  void build_rotation_slots(const Eigen::Vector3d& omega_E, const CompensationInput& in, TimeNs duration_ns);
  /// Per raw pixel inverse depth ρ = 1/z (holes filled / fallback applied) and a fallback flag,
  /// rebuilt only when the depth frame changes. False when the frame holds no usable depth.
  bool prepare_depth(const RegisteredDepth& depth);
  /// `depth` (same object, buffer and time) is a frame prepare_depth prepared and still keeps.
  bool is_prepared(const RegisteredDepth& depth) const;
  /// The frame checks of compensate(): the event camera's size and a matching buffer.
  bool depth_fits(const RegisteredDepth& depth) const;
  /// How far [grid px] this window's warp (eqs. 6-8) can move an event from where the lens alone
  /// puts it; infinite when no useful bound exists. Needs the slots built.
  double warp_reach_px(CompensationMethod used, TimeNs duration_ns) const;
  /// CompensationInput::near_regions: the window's events whose raw pixel the lens and a warp of
  /// at most warp_reach_px() can bring into a region (a superset of those it does), and every
  /// in-sensor event's time into the output's window_t_s. Counts the whole window's time order.
  std::span<const Event> events_near(const CompensationInput& in, std::span<const Eigen::AlignedBox2d> regions,
                                     double reach_px);
  /// |ρ| the last window's warp used at normalised ray x (the nearest raw pixel), or the
  /// missing-depth policy's value outside the sensor.
  double warp_inverse_depth_at(const Eigen::Vector2d& x) const;

  std::vector<float> slots_;  ///< n_slots × 9
  /// With the integrated gyro: R(t) at the window's start (identity), each slot's middle and the
  /// window's end, for observed_position to interpolate; empty with the mean rate.
  struct RotationKnot {
    double t_s;
    Eigen::Quaterniond R;
  };
  std::vector<RotationKnot> knots_;
  /// A depth frame made ready for the warp, and the frame it was made from.
  struct PreparedDepth {
    const RegisteredDepth* key = nullptr;
    const float* data_key = nullptr;
    TimeNs t_key = 0;
    bool usable = false;
    float fallback_depth_m = 0;
    float max_rho = 0;  ///< max |ρ| over the frame
    /// ρ = 1/z per raw pixel [1/m]; sign bit set where the missing-depth policy was applied.
    std::vector<float> inv_depth;
    bool made_from(const RegisteredDepth& depth) const {
      return &depth == key && depth.depth_m.data() == data_key && depth.t == t_key;
    }
  };
  /// The last two frames prepared: when a frame arrives, the windows still waiting for their IMU
  /// use the frame before it and the next windows the new one (every step with overlapping
  /// windows), and with one kept each arrival made both again inside windows.
  std::array<PreparedDepth, 2> prepared_;
  int in_use_ = 0;  ///< prepared_'s slot the last prepare_depth made or found
  const PreparedDepth& depth_in_use() const { return prepared_[in_use_]; }
  std::vector<float> depth_sample_;  ///< the strided valid depths (median or reach)
  /// Rings of 2r + 1 rows (prepare_depth): ρ before hole filling, its running maximum along rows.
  std::vector<float> raw_rho_, row_max_;
  double grid_max_radius_ = 0;  ///< largest |x| (normalised) over the undistorted grid
  std::vector<Event> near_events_;  ///< events_near's selection, reused
  struct RawBox {
    int x0, y0, x1, y1;  ///< raw pixels, inclusive
  };
  std::vector<RawBox> raw_boxes_;               ///< events_near's regions in raw pixels, reused
  std::vector<Eigen::Vector2d> lattice_row_;  ///< events_near's previous lattice row, reused
};

}  // namespace fdv::internal
