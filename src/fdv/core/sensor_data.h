#pragma once
/// Value types for everything the sensors produce. Frames as in the paper: W world, B body,
/// E event camera, D depth camera, I IMU. A transform T_A_B maps B coordinates into A.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fdv/core/time.h"

namespace fdv {

/// One event: raw (distorted) sensor pixel, time, polarity (true = brightness increase, ON).
struct Event {
  TimeNs t = 0;
  std::uint16_t x = 0;
  std::uint16_t y = 0;
  bool polarity = false;
  friend bool operator==(const Event&, const Event&) = default;
};
static_assert(sizeof(Event) == 16, "Event is kept at 16 bytes for cache-friendly windows");

/// Default overload cap of one event window, above which it is decimated: the pipeline's
/// windower and a compensator's own guard share it. 20 M events/s sustained over 25 ms is 500 k
/// events; twice that is a burst the front end cannot absorb within one window period on one core
/// (docs/BENCHMARKS.md).
inline constexpr std::size_t kDefaultMaxEventsPerWindow = 1'000'000;

/// One IMU sample in the IMU frame I: angular velocity [rad/s], specific force [m/s^2].
struct ImuSample {
  TimeNs t = 0;
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

/// One depth image in the depth camera's raw pixel grid: z-depth along the optical axis in
/// metres, row-major; 0 marks an invalid pixel (hole, out of range).
struct DepthFrame {
  TimeNs t = 0;
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;
  float at(int u, int v) const { return depth_m[static_cast<std::size_t>(v) * width + u]; }
};

/// Vehicle state from odometry (e.g. VIO): pose of the body in the world, velocity in W,
/// and angular velocity in B (zero when the source does not give it).
struct OdometrySample {
  TimeNs t = 0;
  Eigen::Vector3d p_W_B = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_W_B = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();
  Eigen::Isometry3d T_W_B() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q_W_B.toRotationMatrix();
    T.translation() = p_W_B;
    return T;
  }
};

/// How far from 1 a quaternion's norm may be before it is not taken as a rotation (it is then
/// normalised): 1e-3 covers text files printed with 4 decimals. Every reader and Perception use it.
inline constexpr double kUnitQuaternionTolerance = 1e-3;

/// Why a sample cannot be used, or nullptr: a time outside valid_time(), a non-finite value, a
/// quaternion whose norm is not 1 within kUnitQuaternionTolerance (so also a zero one), a depth
/// frame whose size is outside 1..kMaxCameraSide or disagrees with its pixel count. Readers and
/// Perception drop such samples with this reason. Depth values themselves are not checked (0,
/// NaN or negative is a pixel without depth).
const char* why_invalid(const ImuSample& s);
const char* why_invalid(const OdometrySample& s);
const char* why_invalid(const DepthFrame& f);

/// Ground truth of a tracked object (ball): position and velocity of its centre in W.
struct ObjectState {
  TimeNs t = 0;
  int id = 0;
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
};

/// Odometry at time t by linear interpolation of position/velocity and slerp of attitude
/// between the two samples around t (clamped to the ends). `samples` must be time-sorted
/// and non-empty.
OdometrySample interpolate_odometry(const std::vector<OdometrySample>& samples, TimeNs t);
/// The same between two samples a.t <= t <= b.t.
OdometrySample interpolate_between(const OdometrySample& a, const OdometrySample& b, TimeNs t);

/// A depth image resampled onto the event camera's raw pixel grid (made by fdv/depth's
/// DepthRegistrar; compensation reads per-event depth from it).
struct RegisteredDepth {
  TimeNs t = 0;  ///< time of the source depth frame
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;  ///< z along E's optical axis [m], row-major, 0 = no depth
  // What happened to the source pixels (they sum to width·height of the depth frame):
  std::uint64_t registered = 0;       ///< landed on an event pixel (z-test winners and losers)
  std::uint64_t occluded = 0;         ///< of those, lost the z-test to a nearer surface
  std::uint64_t invalid_input = 0;    ///< 0, NaN or out of range in the depth frame
  std::uint64_t no_inverse = 0;       ///< depth lens map not invertible at that pixel
  std::uint64_t behind_camera = 0;    ///< z ≤ 0 in E
  std::uint64_t outside_image = 0;    ///< projected outside the event image
  float at(int x, int y) const { return depth_m[static_cast<std::size_t>(y) * width + x]; }
  bool empty() const { return depth_m.empty(); }
};

}  // namespace fdv
