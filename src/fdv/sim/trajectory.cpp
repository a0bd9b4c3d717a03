#include "fdv/sim/trajectory.h"

#include <fmt/format.h>

#include <Eigen/LU>
#include <cmath>
#include <numbers>

#include "fdv/core/error.h"
#include "fdv/sim/geometry.h"
#include "fdv/sim/random.h"

namespace fdv::sim {
namespace {

Eigen::Matrix3d rotation_exp(const Eigen::Vector3d& w) { return rotation_exp_q(w).toRotationMatrix(); }

}  // namespace

OdometrySample to_pose_sample(TimeNs t, const BodyState& s) {
  OdometrySample o;
  o.t = t;
  o.p_W_B = s.p_W;
  o.q_W_B = Eigen::Quaterniond(s.R_W_B).normalized();
  o.v_W = s.v_W;
  o.omega_B = s.omega_B;
  return o;
}

void VehicleTrajectory::Wave::eval(double t, double& f, double& df, double& ddf) const {
  f = offset, df = 0, ddf = 0;
  for (std::size_t k = 0; k < amp.size(); ++k) {
    const double arg = omega[k] * t + phase[k];
    const double s = std::sin(arg), c = std::cos(arg);
    f += amp[k] * s;
    df += amp[k] * omega[k] * c;
    ddf -= amp[k] * omega[k] * omega[k] * s;
  }
}

VehicleTrajectory::VehicleTrajectory(const VehicleConfig& config, std::uint64_t seed,
                                     const Eigen::Vector3d& gravity_W)
    : config_(config) {
  const double psi0 = config.heading_deg * kDegToRad;
  heading_dir_ = Eigen::Vector3d(std::cos(psi0), std::sin(psi0), 0);
  left_dir_ = Eigen::Vector3d(-std::sin(psi0), std::cos(psi0), 0);
  R0_ = rotation_from_rpy_deg(config.rpy0_deg);
  if (config.motion == MotionKind::kConstant) return;

  Rng rng = Rng::stream(seed, RngStream::kScenario, 1000);
  // Vibration: three incommensurate components per axis, random phases.
  const double rel_freq[3] = {1.0, 1.73, 2.91};
  const double rel_amp[3] = {1.0, 0.6, 0.4};
  const double axis_freq[3] = {1.0, 1.09, 0.93};
  for (int axis = 0; axis < 3; ++axis) {
    for (int k = 0; k < 3; ++k) {
      const double w = 2 * std::numbers::pi * config.vibration_frequency_hz * rel_freq[k] * axis_freq[axis];
      pos_[axis].add(config.vibration_position_m * rel_amp[k], w, rng.uniform(0, 2 * std::numbers::pi));
      angle_[axis].add(config.vibration_angle_deg * kDegToRad * rel_amp[k], w * 1.05,
                       rng.uniform(0, 2 * std::numbers::pi));
    }
  }
  if (config.motion == MotionKind::kHover) {
    const double wander_rel[3] = {1.0, 1.31, 0.73};
    for (int axis = 0; axis < 3; ++axis)
      pos_[axis].add(config.wander_position_m * (axis == 2 ? 0.5 : 1.0),
                     2 * std::numbers::pi * config.wander_frequency_hz * wander_rel[axis],
                     rng.uniform(0, 2 * std::numbers::pi));
  }
  angle_[1].offset = config.nose_down_deg * kDegToRad;
  angle_[2].offset = psi0;
  if (config.motion == MotionKind::kSwing) {
    const double omega = 2 * std::numbers::pi * config.swing_frequency_hz;
    const double phase = rng.uniform(0, 2 * std::numbers::pi);
    const double roll = config.swing_roll_deg * kDegToRad;
    angle_[0].add(roll, omega, phase);
    angle_[2].add(config.swing_yaw_deg * kDegToRad, omega, phase + 2 * std::numbers::pi / 4);
    // Lateral sway whose acceleration is the one the roll tilt produces (small-angle thrust
    // tilt: y'' = -g roll in the left direction).
    const double sway = gravity_W.norm() * roll / (omega * omega);
    for (int axis = 0; axis < 2; ++axis) pos_[axis].add(sway * left_dir_[axis], omega, phase);
  }
}

BodyState VehicleTrajectory::at(double t) const {
  BodyState s;
  const auto& c = config_;
  switch (c.motion) {
    case MotionKind::kConstant:
      s.p_W = c.start_W_m + c.velocity_W_m_s * t + 0.5 * c.acceleration_W_m_s2 * t * t;
      s.v_W = c.velocity_W_m_s + c.acceleration_W_m_s2 * t;
      s.a_W = c.acceleration_W_m_s2;
      s.R_W_B = R0_ * rotation_exp(c.omega_B_rad_s * t);
      s.omega_B = c.omega_B_rad_s;
      return s;
    case MotionKind::kHover:
      s.p_W = c.start_W_m;
      break;
    case MotionKind::kForward:
    case MotionKind::kSwing:
      s.p_W = c.start_W_m + c.speed_m_s * t * heading_dir_;
      s.v_W = c.speed_m_s * heading_dir_;
      break;
  }
  for (int axis = 0; axis < 3; ++axis) {
    double f, df, ddf;
    pos_[axis].eval(t, f, df, ddf);
    s.p_W[axis] += f;
    s.v_W[axis] += df;
    s.a_W[axis] += ddf;
  }
  double e[3], de[3], dde[3];
  for (int axis = 0; axis < 3; ++axis) angle_[axis].eval(t, e[axis], de[axis], dde[axis]);
  const double phi = e[0], theta = e[1], psi = e[2];
  s.R_W_B = (Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()) *
             Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitY()) *
             Eigen::AngleAxisd(phi, Eigen::Vector3d::UnitX()))
                .toRotationMatrix();
  const double sphi = std::sin(phi), cphi = std::cos(phi);
  const double sth = std::sin(theta), cth = std::cos(theta);
  s.omega_B = Eigen::Vector3d(de[0] - de[2] * sth, de[1] * cphi + de[2] * sphi * cth,
                              -de[1] * sphi + de[2] * cphi * cth);
  return s;
}

// ----------------------------------------------------------------------------------------- ball

BallTrajectory::BallTrajectory(const BallConfig& config, const VehicleTrajectory& vehicle,
                               const Eigen::Vector3d& gravity_W, double end_s)
    : config_(config), gravity_(gravity_W) {
  const double area = 3.141592653589793 * config.radius_m * config.radius_m;
  drag_k_ = 0.5 * config.air_density_kg_m3 * config.drag_coefficient * area / config.mass_kg;
  const double tr = config.release_t_s;
  if (config.mode == "explicit") {
    origin_ = config.origin_W_m;
    velocity0_ = config.velocity_W_m_s;
  } else {
    origin_ = vehicle.at(tr).p_W + config.from_m;
    // Flight time T such that the straight-line distance to the target (which moves with the
    // vehicle) divided by T is the requested speed: a fixed-point iteration.
    double T = std::max((config.to_m - config.from_m).norm() / config.speed_m_s, 1e-3);
    Eigen::Vector3d target;
    for (int it = 0; it < 100; ++it) {
      target = vehicle.at(tr + T).p_W + config.to_m;
      const double next = (target - origin_).norm() / config.speed_m_s;
      const bool done = std::abs(next - T) < 1e-12;
      T = next;
      if (done) break;
    }
    if (!(T > 1e-3))
      throw ConfigError(fmt::format("ball {}: aimed throw has no flight time", config.id));
    target = vehicle.at(tr + T).p_W + config.to_m;
    velocity0_ = (target - origin_) / T - 0.5 * gravity_ * T;
    if (drag_k_ > 0) {
      // Shooting: Newton on the release velocity with a finite-difference Jacobian.
      for (int it = 0; it < 20; ++it) {
        Eigen::Vector3d p, v;
        fly(velocity0_, T, p, v);
        const Eigen::Vector3d r = p - target;
        if (r.norm() < 1e-9) break;
        Eigen::Matrix3d J;
        for (int k = 0; k < 3; ++k) {
          Eigen::Vector3d dv = velocity0_, pk, vk;
          dv[k] += 1e-4;
          fly(dv, T, pk, vk);
          J.col(k) = (pk - p) / 1e-4;
        }
        velocity0_ -= J.partialPivLu().solve(r);
      }
      Eigen::Vector3d p, v;
      fly(velocity0_, T, p, v);
      if ((p - target).norm() > 1e-3)
        throw ConfigError(
            fmt::format("ball {}: aimed throw with drag does not reach its target "
                        "(drag too strong for the speed?)",
                        config.id));
    }
  }
  if (drag_k_ > 0) integrate(end_s);
}

namespace {

/// One classical Runge-Kutta step of length h of dp/dt = v, dv/dt = acceleration(v).
template <class Acceleration>
void rk4_step(const Acceleration& acceleration, double h, Eigen::Vector3d& p, Eigen::Vector3d& v) {
  const Eigen::Vector3d k1v = acceleration(v), k1p = v;
  const Eigen::Vector3d k2v = acceleration(v + 0.5 * h * k1v), k2p = v + 0.5 * h * k1v;
  const Eigen::Vector3d k3v = acceleration(v + 0.5 * h * k2v), k3p = v + 0.5 * h * k2v;
  const Eigen::Vector3d k4v = acceleration(v + h * k3v), k4p = v + h * k3v;
  p += h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p);
  v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
}

}  // namespace

Eigen::Vector3d BallTrajectory::acceleration(const Eigen::Vector3d& v) const {
  return gravity_ - drag_k_ * v.norm() * v;
}

void BallTrajectory::fly(const Eigen::Vector3d& v0, double tau, Eigen::Vector3d& p,
                         Eigen::Vector3d& v) const {
  p = origin_;
  v = v0;
  const int n = std::max(1, static_cast<int>(std::ceil(tau / node_dt_)));
  const double h = tau / n;
  for (int i = 0; i < n; ++i)
    rk4_step([this](const Eigen::Vector3d& u) { return acceleration(u); }, h, p, v);
}

void BallTrajectory::integrate(double end_s) {
  const double span = end_s - config_.release_t_s;
  const int n = span > 0 ? static_cast<int>(std::ceil(span / node_dt_)) + 1 : 1;
  node_p_.resize(n + 1);
  node_v_.resize(n + 1);
  Eigen::Vector3d p = origin_, v = velocity0_;
  node_p_[0] = p, node_v_[0] = v;
  const double h = node_dt_;
  for (int i = 0; i < n; ++i) {
    rk4_step([this](const Eigen::Vector3d& u) { return acceleration(u); }, h, p, v);
    node_p_[i + 1] = p, node_v_[i + 1] = v;
  }
}

BallState BallTrajectory::at(double t) const {
  BallState s;
  const double tau = t - config_.release_t_s;
  if (tau < 0) {
    s.p_W = origin_;
    s.exists = !config_.hidden_before_release;
    return s;
  }
  s.released = true;
  s.R_W_O = rotation_exp(config_.spin_W_rad_s * tau);
  if (drag_k_ <= 0) {
    s.p_W = origin_ + velocity0_ * tau + 0.5 * gravity_ * tau * tau;
    s.v_W = velocity0_ + gravity_ * tau;
    return s;
  }
  const auto last = static_cast<double>(node_p_.size() - 1);
  const double x = std::min(tau / node_dt_, last);
  const auto i = static_cast<std::size_t>(std::min(std::floor(x), last - 1));
  if (tau / node_dt_ > last) {  // past the integrated span: continue from the last node
    const double dt = tau - last * node_dt_;
    s.v_W = node_v_.back() + acceleration(node_v_.back()) * dt;
    s.p_W = node_p_.back() + node_v_.back() * dt + 0.5 * acceleration(node_v_.back()) * dt * dt;
    return s;
  }
  // Cubic Hermite on position (derivative v) and on velocity (derivative a).
  const double u = x - static_cast<double>(i), h = node_dt_;
  const double h00 = (1 + 2 * u) * (1 - u) * (1 - u), h10 = u * (1 - u) * (1 - u);
  const double h01 = u * u * (3 - 2 * u), h11 = u * u * (u - 1);
  const auto& p0 = node_p_[i];
  const auto& p1 = node_p_[i + 1];
  const auto& v0 = node_v_[i];
  const auto& v1 = node_v_[i + 1];
  s.p_W = h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1;
  s.v_W = h00 * v0 + h10 * h * acceleration(v0) + h01 * v1 + h11 * h * acceleration(v1);
  return s;
}

}  // namespace fdv::sim
