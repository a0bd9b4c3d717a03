#pragma once
/// Ground truth of a simulated dataset folder (`fdv simulate`, sim::DatasetSink) and the truth
/// events the evaluation keys on: when a ball is in flight and in view, and when it passes closest
/// to the vehicle.
///
///   const DatasetTruth truth = load_dataset_truth("out/cache/scene2_ball_seed101");
///   const int ball = truth.radius_m.begin()->first;
///   if (auto t = first_in_flight_in_view(truth, ball)) ...       // release / first appearance
///   if (auto t_ca = true_closest_approach(truth, ball)) ...
///
/// Pitfall: the object samples are only as dense as the simulator wrote them (1 kHz); object_at()
/// propagates ballistically from the nearest one, which is exact in free flight only.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"
#include "fdv/eval/ground_truth_box.h"

namespace fdv {

/// A ball held or lying still makes no events of its own: below this true speed it is not "in
/// flight" and counts neither for recall nor for the relative contrast [m/s].
inline constexpr double kMinFlightSpeed_m_s = 1.0;

struct DatasetTruth {
  std::string dir;
  Calibration calibration;
  std::vector<OdometrySample> body;  ///< true vehicle motion T_W_B, time-sorted
  std::vector<ObjectState> objects;  ///< time-sorted
  std::map<int, double> radius_m;    ///< per object id
  Eigen::Vector3d gravity_W = Eigen::Vector3d(0, 0, -9.81);
  std::string scenario;
  /// The object's true state at t (nearest sample within 10 ms, propagated ballistically).
  std::optional<ObjectState> object_at(int id, TimeNs t) const;
  /// The true vehicle state at t (interpolated).
  OdometrySample body_at(TimeNs t) const;
  /// Whether object `id` exists at t and moves at >= kMinFlightSpeed_m_s.
  bool in_flight(int id, TimeNs t) const;
};

/// Reads dataset.yaml, calibration.yaml and truth/*.csv. Throws InputError when the folder is not
/// a dataset or has no ground truth.
DatasetTruth load_dataset_truth(const std::string& dir);

/// The ball's true box over [t0, t1] on the undistorted grid K·xn where the time images live
/// (projection without distortion), as an integer pixel rectangle; empty when not visible.
/// `options` may hold the camera fixed at a time (a compensated image, see GroundTruthBoxOptions).
cv::Rect undistorted_truth_rect(const DatasetTruth& truth, int id, TimeNs t0, TimeNs t1,
                                const GroundTruthBoxOptions& options = {});

/// First instant (1 ms steps over the vehicle truth) at which ball `id` is in flight with at least
/// `min_fraction_in_view` of its silhouette in the image: the release of a ball thrown in view, or
/// the entry into view of one thrown from outside it.
std::optional<TimeNs> first_in_flight_in_view(const DatasetTruth& truth, int id,
                                              double min_fraction_in_view = 0.8);

/// Time of the true closest approach of ball `id` to the vehicle body origin (over the truth
/// samples inside the vehicle truth's time span), with that distance [m].
struct TrueClosestApproach {
  TimeNs t = 0;
  double distance_m = 0;
};
std::optional<TrueClosestApproach> true_closest_approach(const DatasetTruth& truth, int id);

/// First truth sample (inside the vehicle truth's time span) at which ball `id` is within
/// `radius_m` of the vehicle body origin: the true contact with a safety sphere of that radius
/// (PredictionOptions::safety_radius_m), nothing when it never comes that close.
std::optional<TimeNs> true_contact_time(const DatasetTruth& truth, int id, double radius_m);

}  // namespace fdv
