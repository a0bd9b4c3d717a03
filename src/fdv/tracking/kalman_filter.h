#pragma once
/// Kalman filter for one object's centre on the image plane, constant-acceleration model
/// (paper §IV-C.1), state x = (u, v, u', v', u'', v'') in raw pixels, px/s, px/s².
///
///   ImageFilterOptions o;                        // defaults: docs/ESTIMATION.md
///   ImageKalmanFilter f(o, t0, center_px);       // first detection
///   ImagePrediction p = f.predict(t1);           // any time: the filter is not changed
///   double d2 = p.mahalanobis2(z1);              // association gate
///   f.update(t1, z1);                            // t1 >= f.time()
///
/// The filter keeps its posterior at the time of the last update and predicts lazily to any
/// time, so "prediction through missed detections" is simply predict(t) with a larger gap
/// (the continuous-time model composes exactly: F(a)F(b) = F(a+b), Q(a) + F(a)Q(b)F(a)^T = Q(a+b)).
/// Process noise: continuous white jerk with power spectral density q [px²/s⁵] per axis.
/// Prediction to an earlier time uses F(dt < 0) for the mean and Q(|dt|) for the covariance
/// (an extrapolation, used for ROIs of depth frames that arrive late); update() never goes back.
///
/// Why Eigen and not cv::KalmanFilter: see docs/ESTIMATION.md (lazy prediction to arbitrary
/// times without mutating the filter, the innovation covariance for gating, fixed-size
/// allocation-free matrices, and the project's OpenCV subset excludes the video module).
/// Not thread-safe; const members may be called concurrently.
#include <Eigen/Core>
#include <string>

#include "fdv/core/time.h"

namespace fdv {

struct ImageFilterOptions {
  /// Detection centre noise, std per axis [px]. DESIGN.md: centroid noise ~1-2 px.
  double measurement_sigma_px = 1.5;
  /// White-jerk power spectral density per axis [px²/s⁵]. Chosen so that the acceleration
  /// change over one 25 ms window, sqrt(q·Δt), matches the image-plane jerk of a ball at 2-3 m
  /// closing at 10 m/s with 0.5 m offset (f≈536 px: u''' ≈ 6 f X V³ / Z⁴ ≈ 2e4-1e5 px/s³):
  /// q ≈ (5e4)² · 0.025 ≈ 6e7. docs/ESTIMATION.md.
  double jerk_psd_px2_s5 = 6e7;
  /// Prior std of the image velocity of a new track [px/s]: a ball at 12 m/s seen at 3 m with
  /// f≈536 px moves ≈2100 px/s; 1500 covers most throws at 1σ.
  double init_velocity_sigma_px_s = 1500.0;
  /// Prior std of the image acceleration of a new track [px/s²] (≈ u'' of the head-on case at 2 m).
  double init_acceleration_sigma_px_s2 = 1e4;

  /// Empty when valid, else a readable reason.
  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): YAML section `tracking.filter`.
template <class V>
void describe(V& v, ImageFilterOptions& o) {
  v("measurement_sigma_px", o.measurement_sigma_px, "px", "detection centre noise, std per axis");
  v("jerk_psd_px2_s5", o.jerk_psd_px2_s5, "px²/s⁵", "white-jerk power spectral density per axis");
  v("init_velocity_sigma_px_s", o.init_velocity_sigma_px_s, "px/s", "prior std of a new track's image velocity");
  v("init_acceleration_sigma_px_s2", o.init_acceleration_sigma_px_s2, "px/s²",
    "prior std of a new track's image acceleration");
}

/// Prediction of the filter at a time t (nothing in the filter changes).
struct ImagePrediction {
  TimeNs t = 0;
  Eigen::Matrix<double, 6, 1> x = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 6> P = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix2d R = Eigen::Matrix2d::Zero();  ///< measurement noise covariance [px²]

  Eigen::Vector2d position() const { return x.head<2>(); }
  Eigen::Vector2d velocity() const { return x.segment<2>(2); }
  Eigen::Vector2d acceleration() const { return x.tail<2>(); }
  Eigen::Matrix2d position_covariance() const { return P.topLeftCorner<2, 2>(); }
  /// Innovation covariance S = H P H^T + R [px²].
  Eigen::Matrix2d innovation_covariance() const { return position_covariance() + R; }
  /// Squared Mahalanobis distance of a measurement z: (z - Hx)^T S^-1 (z - Hx).
  double mahalanobis2(const Eigen::Vector2d& z) const;
};

class ImageKalmanFilter {
 public:
  using State = Eigen::Matrix<double, 6, 1>;
  using Covariance = Eigen::Matrix<double, 6, 6>;

  /// Starts at the first measurement: position z, velocity and acceleration zero with the
  /// prior stds of the options. Throws ConfigError when options are invalid.
  ImageKalmanFilter(const ImageFilterOptions& options, TimeNs t, const Eigen::Vector2d& z_px);

  /// `extra_variance_px2` adds to the measurement noise R, per axis, for a measurement less
  /// precise than measurement_sigma_px (e.g. a detection of part of the object).
  ImagePrediction predict(TimeNs t, const Eigen::Vector2d& extra_variance_px2 = Eigen::Vector2d::Zero()) const;
  /// Measurement update at t >= time(), R grown as in predict(). Returns the innovation's squared
  /// Mahalanobis distance.
  double update(TimeNs t, const Eigen::Vector2d& z_px,
                const Eigen::Vector2d& extra_variance_px2 = Eigen::Vector2d::Zero());

  /// A change of image coordinates u -> f(u) (the camera turned): the position becomes `position`
  /// = f(u), velocity and acceleration are carried by f's Jacobian `J` there, and the covariance
  /// by the same linear map, blockdiag(J, J, J).
  void change_coordinates(const Eigen::Vector2d& position, const Eigen::Matrix2d& J);

  TimeNs time() const { return t_; }
  const State& state() const { return x_; }
  const Covariance& covariance() const { return P_; }
  const ImageFilterOptions& options() const { return options_; }

  /// Transition matrix for a step of dt seconds (state order u, v, u', v', u'', v'').
  static Covariance transition(double dt_s);
  /// Process noise for a step of |dt| seconds under white jerk of PSD q per axis.
  static Covariance process_noise(double dt_s, double q);

 private:
  ImageFilterOptions options_;
  TimeNs t_ = 0;
  State x_ = State::Zero();
  Covariance P_ = Covariance::Zero();
};

}  // namespace fdv
