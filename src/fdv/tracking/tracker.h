#pragma once
/// Multi-object tracker on the event camera's image plane (paper §IV-C.1): associates each
/// event window's detections with tracks by time and image-distance gates, filters each
/// track with a constant-acceleration Kalman filter, and manages track ids, confirmation and
/// deletion.
///
///   Tracker tracker(TrackerOptions{});
///   for each event window at time t:
///     TrackerStep step = tracker.update(t, detections);   // detections of that window (may be
///     empty) for (auto& a : step.assignments) if (a.track_id >= 0) ... a.detection -> track
///     a.track_id
///   tracker.find(id)->predict(t_depth).box_size_px ...    // ROI for a depth frame at any time
///
/// Association: every (track, detection) pair must pass (1) the time gate: the detection is not
/// older than the track's last update and at most `max_gap_ns` newer; (2) the Mahalanobis gate
/// d² = y^T S^-1 y <= gate_chi2 with S the filter's innovation covariance at the detection's time;
/// (3) a hard radius cap |y| <= gate_max_distance_px. A detection's centre error grows with its
/// size (TrackerOptions::size_noise), and a detection smaller or larger than the track's box holds
/// part of its object or more than it (TrackerOptions::part_noise): S holds both. A pair that fails (2) may still pass on an ExternalGate given by
/// the caller (fdv::Perception: the track's 3D estimate). Gated pairs are assigned greedily in
/// order of increasing d² + ln|S|, the pair's negative log-likelihood (global nearest neighbour,
/// one detection per track and per window), so a vague new track does not win a detection from a
/// sharp one. A detection left over starts a new tentative track. Coordinates are raw (distorted) pixels of the event camera,
/// the grid in which detections, boxes and registered depth frames live.
/// Not thread-safe.
#include <Eigen/Core>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/time.h"
#include "fdv/tracking/kalman_filter.h"

namespace fdv {

/// One 2D detection as the tracker needs it (the detector's output converts to this).
struct TrackerDetection {
  TimeNs t = 0;                                         ///< time the centre refers to
  Eigen::Vector2d center_px = Eigen::Vector2d::Zero();  ///< raw (distorted) pixel
  Eigen::Vector2d center_normalized =
      Eigen::Vector2d::Zero();                            ///< undistorted x/z, y/z (passed through)
  Eigen::Vector2d box_size_px = Eigen::Vector2d::Zero();  ///< width, height [px]
  int event_count = 0;
};

struct TrackerOptions {
  ImageFilterOptions filter;
  /// Mahalanobis gate on the 2-dof innovation: 13.82 = χ²₂ 99.9 % quantile (a true
  /// detection is rejected once in 1000 when the filter is consistent).
  double gate_chi2 = 13.82;
  /// Hard cap on the innovation length [px], whatever the covariance: a new track's velocity
  /// prior is wide (1500 px/s), and without a cap it would claim anything within ~150 px.
  double gate_max_distance_px = 100.0;
  /// Time gate and deletion of a confirmed track [ns]: 4 event windows of 25 ms without an update.
  TimeNs max_gap_ns = 100 * kNsPerMs;
  /// The same for a tentative track [ns]: 2.5 windows, so that it outlives one missed window
  /// whatever its detections' mean event times jitter within their windows.
  TimeNs tentative_max_gap_ns = 62500 * kNsPerUs;
  /// Hits (updates, counting the first detection) that confirm a track: 3 windows = 50 ms after
  /// the first detection at 25 ms windows (issue target: first 3D estimate within 60 ms).
  int confirm_hits = 3;
  /// Weight of a new box size in the exponential smoothing of the track's box size.
  double box_smoothing = 0.5;
  /// Most tracks held at once; detections beyond are reported as rejected.
  int max_tracks = 16;
  /// Crossing objects: a detection whose centre lies within this times the mean of its box size
  /// and a track's of two confirmed tracks that pass each other (their image velocities differ
  /// by more than their mean box size per window) is their merged image. No track takes it, none
  /// starts on it, and the tracks coast, the time (up to max_gap_ns) not counting towards their
  /// deletion. 2 was tuned on two_balls seeds 1-4 (docs/DETECTION.md, "Several objects"). 0 = off.
  double crossing_scale = 2;
  /// A detection of part of a track's object (a fragment of its pattern, or the visible part of an
  /// object cut by the border) has a box smaller than the track's, and one of more than the object
  /// (its image merged with a neighbour's, or with clutter) a larger one; either way the object's
  /// centre may lie anywhere within the difference: the pair's measurement noise gains, per axis,
  /// this times the variance of a uniform spread over |track box - detection box|, Δ²/12. 0 = off.
  double part_noise = 1;
  /// The detector's centre error grows with the object's apparent size (a near ball is found by
  /// its densest part, or as the crescent its motion leaves): the pair's measurement noise gains,
  /// per axis, (size_noise · size)², size the larger side of the detection's box. The
  /// maximum-likelihood fit of σ² = measurement_sigma_px² + (κ size)² to the centre errors of 501
  /// detections on training seeds 1-24 gave κ = 0.095, so 0.1 describes the detector; it stays off
  /// (0) by default: it widens the gates lent to the detector, which then reported the streak of
  /// the real DAVIS346 ball after it left the view, and it changed no escape in dodge-eval
  /// (docs/ESTIMATION.md §1, "The object's size").
  double size_noise = 0;
  /// A confirmed track that an outside model still expects in view (update's `held`: in the
  /// pipeline, its usable 3D trajectory projected into the image) is deleted only after this long
  /// without an update [ns], when longer than max_gap_ns: a dodge's manoeuvre floods a few windows
  /// in a row, and the track would otherwise be deleted and its object re-found as a new track
  /// with no 3D history. Past max_gap_ns the image-plane filter has coasted too long to gate: only
  /// the outside model's pairings (ExternalGate) may update it, without the radius cap. 0 = off.
  TimeNs held_max_gap_ns = 0;

  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): YAML section `tracking`.
template <class V>
void describe(V& v, TrackerOptions& o) {
  v.section("filter", o.filter, "the image-plane Kalman filter (constant acceleration)");
  v("gate_chi2", o.gate_chi2, "-", "Mahalanobis gate on the 2-dof innovation (χ²₂ 99.9 %)");
  v("gate_max_distance_px", o.gate_max_distance_px, "px", "hard cap on the innovation length");
  v.ms("max_gap_ms", o.max_gap_ns, "a confirmed track without an update this long is deleted");
  v.ms("tentative_max_gap_ms", o.tentative_max_gap_ns, "the same for a tentative track");
  v("confirm_hits", o.confirm_hits, "-", "updates (the first detection included) that confirm a track");
  v("box_smoothing", o.box_smoothing, "-", "weight of a new box size in the track's smoothed size");
  v("max_tracks", o.max_tracks, "-", "most tracks held at once");
  v("crossing_scale", o.crossing_scale, "-",
    "reach, in mean box sizes, of a detection taken as the merged image of two crossing tracks (0 = off)");
  v.ms("held_max_gap_ms", o.held_max_gap_ns,
       "a confirmed track its outside model (the 3D estimate) still expects in view is deleted after this long (0 = off)");
  v("part_noise", o.part_noise, "-",
    "weight of the centre noise a detection whose box differs from its track's gains, (track box - box)²/12 per axis (0 = off)");
  v("size_noise", o.size_noise, "-",
    "a detection's centre noise per axis gains (size_noise × its box's larger side)² (0 = off)");
}

enum class TrackStatus { kTentative, kConfirmed };

/// A track's predicted state at some time (raw pixels).
struct TrackPrediction {
  TimeNs t = 0;
  Eigen::Vector2d center_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d velocity_px_s = Eigen::Vector2d::Zero();
  Eigen::Vector2d acceleration_px_s2 = Eigen::Vector2d::Zero();
  Eigen::Matrix2d center_covariance_px2 = Eigen::Matrix2d::Zero();
  Eigen::Vector2d box_size_px = Eigen::Vector2d::Zero();  ///< smoothed width, height
};

class Track {
 public:
  int id() const { return id_; }
  TrackStatus status() const { return status_; }
  bool confirmed() const { return status_ == TrackStatus::kConfirmed; }
  TimeNs first_time() const { return first_t_; }
  TimeNs last_update_time() const { return filter_.time(); }
  int hits() const { return hits_; }
  /// Consecutive tracker updates (windows) without an associated detection.
  int misses() const { return misses_; }
  Eigen::Vector2d box_size_px() const { return box_size_px_; }
  const ImageKalmanFilter& filter() const { return filter_; }
  /// State at any time (through missed detections, or before the last update for late depth).
  TrackPrediction predict(TimeNs t) const;
  /// Longest time without an update before deletion: the status's, plus the time spent crossing
  /// another track (TrackerOptions::crossing_scale), which no detection could update; for a track
  /// held by an outside model, at least TrackerOptions::held_max_gap_ns.
  TimeNs gap_limit(const TrackerOptions& o) const;
  /// The same without the hold: beyond it only the outside model's pairings update the track.
  TimeNs filter_gap_limit(const TrackerOptions& o) const;
  /// Whether the last update's `held` named this track.
  bool held() const { return held_; }
  /// Measurement variance [px²] per axis that a detection adds to the filter's
  /// measurement_sigma_px²: its size's (TrackerOptions::size_noise), and that of a detection of
  /// part of this track's object, or of more than it (TrackerOptions::part_noise).
  Eigen::Vector2d extra_variance_px2(const TrackerDetection& d, const TrackerOptions& o) const;

 private:
  friend class Tracker;
  Track(int id, const TrackerDetection& d, const ImageFilterOptions& o)
      : id_(id), first_t_(d.t), filter_(o, d.t, d.center_px), box_size_px_(d.box_size_px) {}
  int id_ = 0;
  TrackStatus status_ = TrackStatus::kTentative;
  TimeNs first_t_ = 0;
  int hits_ = 1;
  int misses_ = 0;
  TimeNs crossing_ns_ = 0;  ///< time spent crossing another track since the last update
  bool held_ = false;       ///< named in the last update's `held`
  ImageKalmanFilter filter_;
  Eigen::Vector2d box_size_px_;
};

/// What happened to one input detection.
struct TrackAssignment {
  enum class Outcome { kUpdated, kNewTrack, kRejected };
  std::size_t detection = 0;  ///< index in the update's input
  Outcome outcome = Outcome::kRejected;
  int track_id = -1;        ///< the track it now belongs to; -1 when rejected
  double mahalanobis2 = 0;  ///< gate statistic for kUpdated
  bool by_external_gate = false;  ///< kUpdated through an ExternalGate, the image gate having failed
  std::string reason;       ///< why it was rejected
};

/// A (track, detection) pairing vouched for by something outside the image-plane filter, e.g. the
/// track's 3D trajectory estimate projected to the detection's time: `mahalanobis2` is that
/// prediction's χ²₂ statistic for the detection. Used when the filter's own gate rejects the pair
/// (the image-plane model is only locally valid: a head-on ball's image motion bends and
/// accelerates); the time gate and the hard radius cap still apply, and gate_chi2 is the bound.
struct ExternalGate {
  int track_id = -1;
  std::size_t detection = 0;  ///< index in the update's input
  double mahalanobis2 = 0;
};

struct TrackerStep {
  std::vector<TrackAssignment> assignments;  ///< one per input detection, in input order
  std::vector<int> confirmed;                ///< ids confirmed during this step
  std::vector<int> deleted;                  ///< ids deleted during this step
};

class Tracker {
 public:
  /// Throws ConfigError when the options are invalid.
  explicit Tracker(TrackerOptions options = {});

  /// One event window ending at `t`: associates `detections` (each with its own time <= t),
  /// updates, creates, confirms and deletes tracks. Call it for every window, with no
  /// detections too, so that missed windows are counted. A call with t older than the previous
  /// call's rejects all its detections (reason "out of order") and changes nothing.
  /// `external` adds pairings vouched for from outside the filter (see ExternalGate); they compete
  /// with the filter-gated pairs by their own statistic. `held`: ids of confirmed tracks that the
  /// outside model still expects in view (TrackerOptions::held_max_gap_ns).
  TrackerStep update(TimeNs t, std::span<const TrackerDetection> detections,
                     std::span<const ExternalGate> external = {}, std::span<const int> held = {});

  /// The camera turned: re-expresses every track in the new image coordinates. `turn` maps a raw
  /// pixel before the turn to where the same direction is seen after it (a pure rotation); each
  /// filter's position moves with it, its velocity, acceleration and covariance by the map's
  /// Jacobian there (central differences over ±1 px). A pixel the map cannot take (NaN) leaves
  /// that track as it is.
  void change_coordinates(const std::function<Eigen::Vector2d(const Eigen::Vector2d&)>& turn);

  const std::vector<Track>& tracks() const { return tracks_; }
  /// The track with this id, or nullptr (deleted or never existed).
  const Track* find(int id) const;
  const TrackerOptions& options() const { return options_; }

 private:
  TrackerOptions options_;
  std::vector<Track> tracks_;
  int next_id_ = 1;
  TimeNs now_ = 0;
  bool started_ = false;
};

}  // namespace fdv
