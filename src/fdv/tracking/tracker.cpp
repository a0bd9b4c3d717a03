#include "fdv/tracking/tracker.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "fdv/core/error.h"
#include "fdv/core/numeric.h"

namespace fdv {

namespace {

bool finite(const Eigen::Vector2d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()); }

struct Candidate {
  double cost;  ///< d² + ln|S|: the pair's Gaussian negative log-likelihood, × 2 and less a constant
  double d2;
  std::size_t track;
  std::size_t detection;
  bool external = false;
};

}  // namespace

std::string TrackerOptions::validate() const {
  if (auto e = filter.validate(); !e.empty()) return "filter." + e;
  if (!positive_finite(gate_chi2)) return "gate_chi2 must be > 0";
  if (!(gate_max_distance_px > 0)) return "gate_max_distance_px must be > 0";
  if (max_gap_ns <= 0) return "max_gap_ns must be > 0";
  if (tentative_max_gap_ns <= 0) return "tentative_max_gap_ns must be > 0";
  if (held_max_gap_ns < 0) return "held_max_gap_ns must be >= 0";
  if (confirm_hits < 1) return "confirm_hits must be >= 1";
  if (!(box_smoothing > 0 && box_smoothing <= 1)) return "box_smoothing must be in (0, 1]";
  if (max_tracks < 1) return "max_tracks must be >= 1";
  if (!(crossing_scale >= 0 && std::isfinite(crossing_scale))) return "crossing_scale must be >= 0";
  if (!(part_noise >= 0 && std::isfinite(part_noise))) return "part_noise must be >= 0";
  if (!(size_noise >= 0 && std::isfinite(size_noise))) return "size_noise must be >= 0";
  return {};
}

TimeNs Track::filter_gap_limit(const TrackerOptions& o) const {
  return (confirmed() ? o.max_gap_ns : o.tentative_max_gap_ns) + crossing_ns_;
}

TimeNs Track::gap_limit(const TrackerOptions& o) const {
  const TimeNs limit = filter_gap_limit(o);
  return held_ && confirmed() ? std::max(limit, o.held_max_gap_ns) : limit;
}

Eigen::Vector2d Track::extra_variance_px2(const TrackerDetection& d, const TrackerOptions& o) const {
  const Eigen::Vector2d mismatch = box_size_px_ - d.box_size_px;
  const double size_sigma = o.size_noise * d.box_size_px.maxCoeff();
  return o.part_noise * mismatch.cwiseAbs2() / 12.0 + Eigen::Vector2d::Constant(size_sigma * size_sigma);
}

TrackPrediction Track::predict(TimeNs t) const {
  const ImagePrediction p = filter_.predict(t);
  TrackPrediction out;
  out.t = t;
  out.center_px = p.position();
  out.velocity_px_s = p.velocity();
  out.acceleration_px_s2 = p.acceleration();
  out.center_covariance_px2 = p.position_covariance();
  out.box_size_px = box_size_px_;
  return out;
}

Tracker::Tracker(TrackerOptions options) : options_(std::move(options)) {
  if (auto e = options_.validate(); !e.empty()) throw ConfigError("TrackerOptions: " + e);
}

const Track* Tracker::find(int id) const {
  for (const Track& tr : tracks_)
    if (tr.id() == id) return &tr;
  return nullptr;
}

void Tracker::change_coordinates(const std::function<Eigen::Vector2d(const Eigen::Vector2d&)>& turn) {
  for (Track& track : tracks_) {
    const Eigen::Vector2d u = track.filter_.state().head<2>();
    const Eigen::Vector2d moved = turn(u);
    Eigen::Matrix2d J;
    for (int k = 0; k < 2; ++k) {
      const Eigen::Vector2d step = Eigen::Vector2d::Unit(k);
      J.col(k) = (turn(u + step) - turn(u - step)) / 2;
    }
    if (!moved.allFinite() || !J.allFinite()) continue;
    track.filter_.change_coordinates(moved, J);
  }
}

TrackerStep Tracker::update(TimeNs t, std::span<const TrackerDetection> detections,
                            std::span<const ExternalGate> external, std::span<const int> held) {
  TrackerStep step;
  step.assignments.resize(detections.size());
  for (std::size_t i = 0; i < detections.size(); ++i) step.assignments[i].detection = i;

  if (started_ && t < now_) {
    for (auto& a : step.assignments)
      a.reason = "out of order: window time before the previous window";
    return step;
  }
  const TimeNs now_before = started_ ? now_ : t;
  started_ = true;
  now_ = t;
  for (Track& tr : tracks_) tr.held_ = std::find(held.begin(), held.end(), tr.id()) != held.end();

  // Valid detections only; the rest are rejected with a reason.
  std::vector<bool> usable(detections.size(), false);
  for (std::size_t i = 0; i < detections.size(); ++i) {
    const TrackerDetection& d = detections[i];
    if (!finite(d.center_px) || !finite(d.box_size_px) || d.box_size_px.minCoeff() < 0)
      step.assignments[i].reason = "non-finite centre or invalid box";
    else if (d.t > t)
      step.assignments[i].reason = "detection time after the window time";
    else
      usable[i] = true;
  }

  // Crossing objects (TrackerOptions::crossing_scale): a detection near the predictions of two
  // confirmed tracks passing each other, with no other detection near either, is their merged
  // image. No track takes it, none starts on it, and the tracks coast without that time counting
  // towards their deletion.
  std::vector<bool> merged(detections.size(), false);
  if (options_.crossing_scale > 0) {
    const TimeNs window = t - now_before;
    std::vector<TrackPrediction> at_t;
    for (const Track& tr : tracks_) at_t.push_back(tr.predict(t));
    const auto size = [](const Eigen::Vector2d& box) { return box.maxCoeff(); };
    const auto near = [&](std::size_t i, std::size_t k) {
      return tracks_[k].confirmed() && (detections[i].center_px - at_t[k].center_px).norm() <
                                           options_.crossing_scale * 0.5 *
                                               (size(at_t[k].box_size_px) + size(detections[i].box_size_px));
    };
    // Two tracks of one object (a duplicate) move alike; two objects crossing pass each other by
    // more than their size within a window.
    const auto passing = [&](std::size_t a, std::size_t b) {
      return (at_t[a].velocity_px_s - at_t[b].velocity_px_s).norm() * to_seconds(window) >
             0.5 * (size(at_t[a].box_size_px) + size(at_t[b].box_size_px));
    };
    std::vector<bool> coasting(tracks_.size(), false);
    for (std::size_t i = 0; i < detections.size(); ++i) {
      if (!usable[i]) continue;
      for (std::size_t a = 0; a < tracks_.size() && !merged[i]; ++a)
        for (std::size_t b = a + 1; b < tracks_.size() && !merged[i]; ++b) {
          if (!near(i, a) || !near(i, b) || !passing(a, b)) continue;
          bool alone = true;
          for (std::size_t j = 0; j < detections.size(); ++j)
            alone = alone && (j == i || !usable[j] || (!near(j, a) && !near(j, b)));
          if (!alone) continue;
          merged[i] = coasting[a] = coasting[b] = true;
          step.assignments[i].reason = "merged image of crossing tracks";
        }
    }
    for (std::size_t k = 0; k < tracks_.size(); ++k)
      if (coasting[k]) tracks_[k].crossing_ns_ = std::min(tracks_[k].crossing_ns_ + window, options_.max_gap_ns);
  }

  // Gate every (track, detection) pair.
  std::vector<Candidate> candidates;
  for (std::size_t k = 0; k < tracks_.size(); ++k) {
    const Track& tr = tracks_[k];
    const TimeNs gap_limit = tr.gap_limit(options_);
    for (std::size_t i = 0; i < detections.size(); ++i) {
      if (!usable[i] || merged[i]) continue;
      const TrackerDetection& d = detections[i];
      if (d.t < tr.last_update_time() || d.t - tr.last_update_time() > gap_limit) continue;
      // Held past the filter's own gap: its prediction has drifted, only the outside model gates.
      const bool stale = d.t - tr.last_update_time() > tr.filter_gap_limit(options_);
      const ImagePrediction p = tr.filter().predict(d.t, tr.extra_variance_px2(d, options_));
      if (!stale && (d.center_px - p.position()).norm() > options_.gate_max_distance_px) continue;
      const double d2 = p.mahalanobis2(d.center_px);
      const double log_det_s = std::log(p.innovation_covariance().determinant());
      if (!stale && d2 <= options_.gate_chi2) {
        candidates.push_back({d2 + log_det_s, d2, k, i});
        continue;
      }
      // The estimate's covariance is in normalised coordinates: the track's own S stands in for it.
      for (const ExternalGate& g : external)
        if (g.track_id == tr.id() && g.detection == i && g.mahalanobis2 <= options_.gate_chi2) {
          candidates.push_back({g.mahalanobis2 + log_det_s, g.mahalanobis2, k, i, true});
          break;
        }
    }
  }
  // Global nearest neighbour, greedy, most likely pair first; ties go to the older track. By the
  // likelihood, not d² alone: a new track's wide velocity prior gives it a large S, so a detection
  // far from it has a small d² and would be taken from the sharp track it belongs to.
  std::sort(candidates.begin(), candidates.end(), [this](const Candidate& a, const Candidate& b) {
    if (a.cost != b.cost) return a.cost < b.cost;
    return tracks_[a.track].id() < tracks_[b.track].id();
  });
  std::vector<bool> track_taken(tracks_.size(), false), detection_taken(detections.size(), false);
  for (const Candidate& c : candidates) {
    if (track_taken[c.track] || detection_taken[c.detection]) continue;
    track_taken[c.track] = detection_taken[c.detection] = true;
    Track& tr = tracks_[c.track];
    const TrackerDetection& d = detections[c.detection];
    tr.filter_.update(d.t, d.center_px, tr.extra_variance_px2(d, options_));
    const double a = options_.box_smoothing;
    tr.box_size_px_ = a * d.box_size_px + (1 - a) * tr.box_size_px_;
    ++tr.hits_;
    tr.misses_ = 0;
    tr.crossing_ns_ = 0;
    if (!tr.confirmed() && tr.hits_ >= options_.confirm_hits) {
      tr.status_ = TrackStatus::kConfirmed;
      step.confirmed.push_back(tr.id());
    }
    auto& out = step.assignments[c.detection];
    out.outcome = TrackAssignment::Outcome::kUpdated;
    out.track_id = tr.id();
    out.mahalanobis2 = c.d2;
    out.by_external_gate = c.external;
  }
  for (std::size_t k = 0; k < track_taken.size(); ++k)
    if (!track_taken[k]) ++tracks_[k].misses_;

  // Delete tracks not updated for too long (before creating new ones, so slots free up).
  for (auto it = tracks_.begin(); it != tracks_.end();) {
    if (t - it->last_update_time() > it->gap_limit(options_)) {
      step.deleted.push_back(it->id());
      it = tracks_.erase(it);
    } else {
      ++it;
    }
  }

  // Detections left over start tentative tracks.
  for (std::size_t i = 0; i < detections.size(); ++i) {
    if (!usable[i] || detection_taken[i] || merged[i]) continue;
    if (static_cast<int>(tracks_.size()) >= options_.max_tracks) {
      step.assignments[i].reason = "track limit reached (max_tracks)";
      continue;
    }
    tracks_.push_back(Track(next_id_++, detections[i], options_.filter));
    Track& tr = tracks_.back();
    if (options_.confirm_hits <= 1) {
      tr.status_ = TrackStatus::kConfirmed;
      step.confirmed.push_back(tr.id());
    }
    auto& out = step.assignments[i];
    out.outcome = TrackAssignment::Outcome::kNewTrack;
    out.track_id = tr.id();
  }
  return step;
}

}  // namespace fdv
