#pragma once
/// Registration of a depth image into the event camera's raw pixel grid.
///
///   DepthRegistrar reg(calibration);                   // precomputes the depth rays once
///   DepthRegistrationResult r = reg.register_frame(frame);
///   if (r.ok()) use(r.depth);                          // z in E [m] per raw event pixel, 0 = hole
///   else report(r.rejected);                           // e.g. wrong frame size
///
/// Every valid depth pixel (u, v, z) is back-projected through the depth camera (intrinsics and
/// distortion), moved into the event camera frame with T_E_D = T_B_E⁻¹ T_B_D, projected with the
/// event camera's intrinsics and distortion, and rounded to the nearest raw event pixel. When
/// several depth pixels land on one event pixel the nearest surface (smallest z in E) wins
/// (z-buffer); event pixels no depth pixel lands on stay 0 (holes are not filled here; the
/// consumer decides, see docs/DETECTION.md). Thread-safe after construction (const).
#include <cstdint>
#include <string>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"

namespace fdv {

struct DepthRegistrationOptions {
  /// Depth values outside [min_depth_m, max_depth_m] are treated as invalid input (D435
  /// operating range 0.3-10 m, DESIGN.md; a little margin either side).
  double min_depth_m = 0.1;
  double max_depth_m = 20.0;
  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): YAML section `depth_registration`.
template <class V>
void describe(V& v, DepthRegistrationOptions& o) {
  v("min_depth_m", o.min_depth_m, "m", "depth below this is invalid input");
  v("max_depth_m", o.max_depth_m, "m", "depth above this is invalid input");
}

struct DepthRegistrationResult {
  RegisteredDepth depth;  ///< empty when rejected
  std::string rejected;   ///< empty when accepted, else the reason (the frame is not used)
  bool ok() const { return rejected.empty(); }
};

class DepthRegistrar {
 public:
  /// Throws ConfigError when the calibration has no depth camera or an option is invalid.
  explicit DepthRegistrar(const Calibration& calibration, const DepthRegistrationOptions& options = {});
  /// Registers one frame. A frame whose size differs from the depth camera's calibration, or
  /// whose buffer does not hold width·height values, is rejected with a reason; the caller
  /// counts rejections (the streaming pipeline reports them per reason).
  DepthRegistrationResult register_frame(const DepthFrame& frame) const;
  /// The plain reference of register_frame(): one pixel at a time with Eigen, a branch per check.
  /// For tests and benchmarks: register_frame() (single precision) must give the same frame up to
  /// points within ~1e-4 px of a cell border (docs/DETECTION.md, "Depth registration").
  DepthRegistrationResult register_frame_plain(const DepthFrame& frame) const;

 private:
  /// Empty when the frame fits the depth camera's calibration, else why not.
  std::string check_frame(const DepthFrame& frame) const;
  /// Checks the frame (false: rejected, with the reason) and sets up the output, every cell +inf.
  bool begin_frame(const DepthFrame& frame, DepthRegistrationResult& result) const;
  /// Cells no depth pixel reached (+inf) become 0.
  static void end_frame(RegisteredDepth& out);

  DepthRegistrationOptions options_;
  PinholeCamera depth_camera_;
  PinholeCamera event_camera_;
  Eigen::Matrix3d R_E_D_;
  Eigen::Vector3d t_E_D_;
  std::vector<float> rays_;  ///< interleaved normalised (x, y) per depth pixel, NaN = no inverse
  std::vector<float> ray_E_x_, ray_E_y_, ray_E_z_;  ///< R_E_D·[x; y; 1] per depth pixel (register_frame)
  /// Squared normalised radius beyond which the event lens polynomial is not trusted (it can
  /// fold far-off-axis points back into the image); +inf without distortion.
  double max_radius2_event_ = 0;
};

}  // namespace fdv
