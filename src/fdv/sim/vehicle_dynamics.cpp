#include "fdv/sim/vehicle_dynamics.h"

#include <algorithm>
#include <cmath>

#include "fdv/core/error.h"
#include "fdv/sim/geometry.h"

namespace fdv::sim {
namespace {

/// A height hold brakes once stopping at its limit needs this fraction of |g|.
constexpr double kBrakeStart = 0.5;

}  // namespace

FlownVehicle::FlownVehicle(const VehicleTrajectory& path, const VehicleResponseConfig& response,
                           const Eigen::Vector3d& gravity_W, const Eigen::AlignedBox3d& room)
    : path_(&path),
      response_(response),
      gravity_(gravity_W),
      up_(-gravity_W.normalized()),
      step_s_(response.step_s),
      room_(room) {}

FlownVehicle::FlownVehicle(const FlownVehicle& state, const VehicleTrajectory& path)
    : FlownVehicle(state) {
  path_ = &path;
}

void FlownVehicle::command(TimeNs t, const Eigen::Vector3d& a_W) {
  if (!a_W.allFinite()) throw ConfigError("vehicle command: the acceleration is not finite");
  ++counters_.commands;
  const TimeNs horizon = from_seconds(nodes_.empty() ? horizon_s_ : node_time(nodes_.size() - 1));
  if (t < horizon) {
    ++counters_.late;
    t = horizon;
  }
  if (nodes_.empty()) {
    t0_s_ = to_seconds(t);
    nodes_.emplace_back();
  }
  const Eigen::Vector3d f = a_W - gravity_;
  if (f.norm() > 1e-9 && std::acos(std::clamp(f.normalized().dot(up_), -1.0, 1.0)) >
                             response_.max_tilt_deg * kDegToRad)
    ++counters_.tilt_clipped;
  commands_.erase(commands_.lower_bound(t), commands_.end());
  commands_[t] = a_W;
}

Eigen::Vector3d FlownVehicle::command_at(std::size_t k) {
  const double t = node_time(k);
  Eigen::Vector3d a_c = Eigen::Vector3d::Zero();
  if (auto it = commands_.upper_bound(from_seconds(t)); it != commands_.begin()) a_c = std::prev(it)->second;
  // The height controller's band, in the vertical of gravity: the floor measured upwards, the
  // ceiling the same rule measured downwards.
  const BodyState path = path_->at(t);
  const double height = (path.p_W + nodes_[k].p).dot(up_);
  const double climb = (path.v_W + nodes_[k].v).dot(up_);
  const double vertical = a_c.dot(up_);
  double held = hold_at_limit(height - response_.min_height_m, climb, vertical, floor_holding_,
                              counters_.floor_holds);
  held = -hold_at_limit(response_.max_height_m - height, -climb, -held, ceiling_holding_,
                        counters_.ceiling_holds);
  if (floor_holding_ || ceiling_holding_) a_c += (held - vertical) * up_;
  if (room_.isEmpty()) return a_c;
  // The walls: the same rule along W x and y (the room is a box in W). The brake is a tilt, which
  // the attitude lags by about τ; the margin takes the overshoot.
  for (int axis : {0, 1}) {
    const double p = path.p_W[axis] + nodes_[k].p[axis], v = path.v_W[axis] + nodes_[k].v[axis];
    const double lo = room_.min()[axis] + response_.wall_margin_m, hi = room_.max()[axis] - response_.wall_margin_m;
    double across = hold_at_limit(p - lo, v, a_c[axis], wall_holding_[axis][0], counters_.wall_holds);
    across = -hold_at_limit(hi - p, -v, -across, wall_holding_[axis][1], counters_.wall_holds);
    if (wall_holding_[axis][0] || wall_holding_[axis][1]) a_c[axis] = across;
  }
  return a_c;
}

double FlownVehicle::hold_at_limit(double gap, double approach, double away, bool& holding,
                                   std::uint64_t& holds) const {
  // Brake a motion towards the limit once stopping there needs half of |g| (braking at up to |g|
  // then always stops it there), keep braking as needed until it stops, then drop the command's
  // part towards the limit while it points there (a height is then held; a wall's tilt lags, and
  // the vehicle drifts back from it while the tilt relaxes). `gap` is the distance to the limit,
  // `approach` the speed away from it and `away` the command's acceleration away from it, all
  // negative towards it.
  const double g = gravity_.norm();
  const double brake = approach >= 0 ? 0.0 : gap > 0 ? approach * approach / (2 * gap) : g;
  const bool hold = brake >= kBrakeStart * g || (gap <= 0 && away < 0) ||
                    (holding && (approach < 0 || away < 0));
  if (hold) {
    if (!holding) ++holds;
    away = std::max(away, std::min(brake, g));
    if (gap <= 0 || approach >= 0) away = std::max(away, 0.0);  // stopped: no more towards it
  }
  holding = hold;
  return away;
}

Eigen::Vector3d FlownVehicle::thrust_direction(const Eigen::Vector3d& a_c) const {
  const Eigen::Vector3d f = a_c - gravity_;
  if (f.norm() < 1e-9) return up_;  // free fall commanded: no direction, keep level
  const Eigen::Vector3d n = f.normalized();
  const double tilt = std::acos(std::clamp(n.dot(up_), -1.0, 1.0));
  const double max_tilt = response_.max_tilt_deg * kDegToRad;
  if (tilt <= max_tilt) return n;
  const Eigen::Vector3d side = n - n.dot(up_) * up_;  // horizontal part; zero only for tilt = 180°
  const Eigen::Vector3d across = side.norm() > 1e-12 ? side.normalized() : up_.unitOrthogonal();
  return std::cos(max_tilt) * up_ + std::sin(max_tilt) * across;
}

Eigen::Vector3d FlownVehicle::deviation_acceleration(const Eigen::Vector3d& a_c,
                                                     const Eigen::Quaterniond& q) const {
  const Eigen::Vector3d n = q * up_;
  // n stays within max_tilt (< 90°) of the vertical: it turns along the arc to a direction that is.
  const double thrust = (a_c.dot(up_) + gravity_.norm()) / n.dot(up_);
  return thrust * n + gravity_;
}

void FlownVehicle::advance_to(double t_s) {
  horizon_s_ = std::max(horizon_s_, t_s);
  if (nodes_.empty()) return;
  const double h = step_s_;
  while (node_time(nodes_.size() - 1) < t_s) {
    const std::size_t k = nodes_.size() - 1;
    const Eigen::Vector3d a_c = command_at(k);
    Node& node = nodes_[k];
    // First-order lag of the thrust direction, rate-limited.
    const Eigen::Vector3d n = node.q * up_, n_c = thrust_direction(a_c);
    const Eigen::Vector3d axis = n.cross(n_c);
    const double angle = std::atan2(axis.norm(), n.dot(n_c));
    node.w_W.setZero();
    if (axis.norm() > 1e-15)
      node.w_W = axis.normalized() *
                 std::min(angle / response_.attitude_time_constant_s, response_.max_body_rate_rad_s);
    Node next;
    next.q = (rotation_exp_q(node.w_W * h) * node.q).normalized();
    node.a = deviation_acceleration(a_c, node.q);
    node.da = deviation_acceleration(a_c, next.q) - node.a;
    // Exact for the acceleration running linearly over the step (what at() interpolates).
    next.v = node.v + h * (node.a + 0.5 * node.da);
    next.p = node.p + h * node.v + h * h * (0.5 * node.a + node.da / 6);
    nodes_.push_back(next);
  }
}

BodyState FlownVehicle::at(double t_s) const {
  BodyState s = path_->at(t_s);
  if (!deviates_at(t_s) || nodes_.size() < 2) return s;
  const auto last = static_cast<double>(nodes_.size() - 2);
  const double x = std::min((t_s - t0_s_) / step_s_, last + 1.0);
  const double k_real = std::min(std::floor(x), last);
  const Node& node = nodes_[static_cast<std::size_t>(k_real)];
  const double tau = (x - k_real) * step_s_, u = tau / step_s_;
  s.p_W += node.p + tau * node.v + tau * tau * (0.5 * node.a + u * node.da / 6);
  s.v_W += node.v + tau * (node.a + 0.5 * u * node.da);
  s.a_W += node.a + u * node.da;
  const Eigen::Matrix3d R_tilt = (rotation_exp_q(node.w_W * tau) * node.q).toRotationMatrix();
  s.R_W_B = R_tilt * s.R_W_B;
  s.omega_B += s.R_W_B.transpose() * node.w_W;
  return s;
}

}  // namespace fdv::sim
