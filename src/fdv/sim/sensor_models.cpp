#include "fdv/sim/sensor_models.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "fdv/sim/geometry.h"

namespace fdv::sim {

// ------------------------------------------------------------------------------------------ IMU

ImuModel::ImuModel(const ImuConfig& config, const Eigen::Matrix3d& R_B_I,
                   const Eigen::Vector3d& gravity_W, std::uint64_t seed)
    : config_(config),
      R_I_B_(R_B_I.transpose()),
      g_W_(gravity_W),
      rng_(Rng::stream(seed, RngStream::kImu)) {
  dt_ = 1.0 / config.rate_hz;
  bg_ = config.gyro_bias_sigma * rng_.normal3();
  ba_ = config.accel_bias_sigma * rng_.normal3();
}

ImuSample ImuModel::sample(TimeNs t, const BodyState& s) {
  const double sg = config_.gyro_noise_density / std::sqrt(dt_);
  const double sa = config_.accel_noise_density / std::sqrt(dt_);
  ImuSample out;
  out.t = t;
  const Eigen::Vector3d ng = rng_.normal3();
  const Eigen::Vector3d na = rng_.normal3();
  out.gyro_rad_s = R_I_B_ * s.omega_B + bg_ + sg * ng;
  out.accel_m_s2 = R_I_B_ * (s.R_W_B.transpose() * (s.a_W - g_W_)) + ba_ + sa * na;
  const Eigen::Vector3d wg = rng_.normal3();
  const Eigen::Vector3d wa = rng_.normal3();
  bg_ += config_.gyro_random_walk * std::sqrt(dt_) * wg;
  ba_ += config_.accel_random_walk * std::sqrt(dt_) * wa;
  return out;
}

// ------------------------------------------------------------------------------------- odometry

OdometryModel::OdometryModel(const OdometryConfig& config, std::uint64_t seed)
    : config_(config), rng_(Rng::stream(seed, RngStream::kOdometry)) {
  drift_dir_ = gauss3().normalized();
  v_err_ = config.velocity_sigma_m_s * gauss3();
  att_err_ = config.attitude_sigma_deg * kDegToRad * gauss3();
}

OdometrySample OdometryModel::sample(TimeNs t, const BodyState& s) {
  const double speed = s.v_W.norm();
  if (!first_) {
    const double dt = to_seconds(t - last_t_);
    path_m_ += 0.5 * (speed + last_speed_) * dt;
    const double fv = std::exp(-dt / config_.velocity_correlation_s);
    v_err_ = fv * v_err_ + std::sqrt(1 - fv * fv) * config_.velocity_sigma_m_s * gauss3();
    const double fa = std::exp(-dt / config_.attitude_correlation_s);
    att_err_ =
        fa * att_err_ + std::sqrt(1 - fa * fa) * config_.attitude_sigma_deg * kDegToRad * gauss3();
  }
  first_ = false;
  last_t_ = t;
  last_speed_ = speed;
  OdometrySample o;
  o.t = t;
  o.p_W_B =
      s.p_W + config_.drift_fraction * path_m_ * drift_dir_ + config_.position_sigma_m * gauss3();
  o.v_W = s.v_W + v_err_;
  const double angle = att_err_.norm();
  const Eigen::Matrix3d dR = angle > 0
                                 ? Eigen::AngleAxisd(angle, att_err_ / angle).toRotationMatrix()
                                 : Eigen::Matrix3d::Identity();
  o.q_W_B = Eigen::Quaterniond(s.R_W_B * dR).normalized();
  o.omega_B = s.omega_B + config_.angular_velocity_sigma_rad_s * gauss3();
  return o;
}

// ---------------------------------------------------------------------------------------- depth

DepthModel::DepthModel(const DepthCameraConfig& config, const Calibration& calib,
                       const Scene& scene, std::uint64_t seed, ThreadPool& pool)
    : config_(config),
      camera_(*calib.depth_camera),
      T_B_D_(calib.T_B_D),
      scene_(&scene),
      seed_(seed),
      pool_(&pool) {}

DepthModel::DepthModel(const DepthModel& state, const Scene& scene, ThreadPool& pool)
    : DepthModel(state) {
  scene_ = &scene, pool_ = &pool;
}

DepthFrame DepthModel::render(TimeNs t, const BodyState& body, const std::vector<BallState>& balls,
                              const std::vector<double>& radii, std::uint64_t frame_index) const {
  const int W = camera_.width, H = camera_.height;
  DepthFrame frame;
  frame.t = t;
  frame.width = W;
  frame.height = H;
  frame.depth_m.assign(static_cast<std::size_t>(W) * H, 0.0f);
  std::vector<float> clean(frame.depth_m.size());

  const Eigen::Matrix3d R = body.R_W_B * T_B_D_.linear();
  const Eigen::Vector3d o = body.p_W + body.R_W_B * T_B_D_.translation();
  float Rf[9], of[3];
  for (int r = 0; r < 3; ++r) {
    of[r] = static_cast<float>(o[r]);
    for (int c = 0; c < 3; ++c) Rf[3 * r + c] = static_cast<float>(R(r, c));
  }
  const std::size_t nb = balls.size();

  pool_->parallel_for(static_cast<std::size_t>(H), [&](std::size_t row) {
    const int v = static_cast<int>(row);
    for (int u = 0; u < W; ++u) {
      const float x = static_cast<float>((u - camera_.cx) / camera_.fx);
      const float y = static_cast<float>((v - camera_.cy) / camera_.fy);
      const float d[3] = {Rf[0] * x + Rf[1] * y + Rf[2], Rf[3] * x + Rf[4] * y + Rf[5],
                          Rf[6] * x + Rf[7] * y + Rf[8]};
      float inv[3];
      Scene::safe_inverse(d, inv);
      float z = scene_->cast_static(of, d, inv, scene_->all_panels()).t;
      const double norm = std::sqrt(static_cast<double>(x) * x + static_cast<double>(y) * y + 1.0);
      for (std::size_t b = 0; b < nb; ++b) {
        if (!balls[b].exists) continue;
        const Eigen::Vector3d oc = balls[b].p_W - o;
        const Eigen::Vector3d dh = Eigen::Vector3d(d[0], d[1], d[2]) / norm;
        const double along = dh.dot(oc);
        const double perp2 = oc.squaredNorm() - along * along;
        const double r2 = radii[b] * radii[b];
        if (along <= 0 || perp2 >= r2) continue;
        const double zb = (along - std::sqrt(r2 - perp2)) / norm;
        if (zb > 0 && zb < z) z = static_cast<float>(zb);
      }
      clean[static_cast<std::size_t>(v) * W + u] = z;
    }
  });

  const double k = config_.subpixel_px / (camera_.fx * config_.baseline_m);
  // Per pixel: holes, and a standard normal draw (same random streams and order as without
  // correlation, so noise_correlation_px = 1 reproduces independent noise exactly).
  std::vector<std::uint8_t> hole(clean.size(), 0);
  cv::Mat noise(H, W, CV_64F);
  pool_->parallel_for(static_cast<std::size_t>(H), [&](std::size_t row) {
    const int v = static_cast<int>(row);
    Rng rng =
        Rng::stream(seed_, RngStream::kDepth, frame_index * 65536 + static_cast<std::uint64_t>(v));
    double* g = noise.ptr<double>(v);
    for (int u = 0; u < W; ++u) {
      const std::size_t p = static_cast<std::size_t>(v) * W + u;
      const float z = clean[p];
      bool edge = false;
      const int nu[4] = {u - 1, u + 1, u, u}, nv[4] = {v, v, v - 1, v + 1};
      for (int q = 0; q < 4; ++q) {
        if (nu[q] < 0 || nu[q] >= W || nv[q] < 0 || nv[q] >= H) continue;
        const float zn = clean[static_cast<std::size_t>(nv[q]) * W + nu[q]];
        if (std::abs(zn - z) > config_.edge_jump_fraction * std::min(z, zn)) edge = true;
      }
      const double u_edge = rng.uniform(), u_hole = rng.uniform();
      g[u] = rng.normal();
      hole[p] = (edge && u_edge < config_.edge_hole_probability) || u_hole < config_.hole_fraction;
    }
  });
  // Stereo matching aggregates costs over a window, so its errors are correlated over a few
  // pixels: the mean of the white field over c x c pixels, times c, has unit variance again and a
  // correlation (c − |du|)(c − |dv|)/c² between pixels (du, dv) apart.
  const int c = config_.noise_correlation_px;
  if (c > 1) {
    cv::blur(noise, noise, cv::Size(c, c), cv::Point(-1, -1), cv::BORDER_REFLECT_101);
    noise *= c;
  }
  pool_->parallel_for(static_cast<std::size_t>(H), [&](std::size_t row) {
    const int v = static_cast<int>(row);
    const double* g = noise.ptr<double>(v);
    for (int u = 0; u < W; ++u) {
      const std::size_t p = static_cast<std::size_t>(v) * W + u;
      const float z = clean[p];
      if (hole[p]) continue;
      // Outside the operating range the camera reports nothing; inside, a noisy value that
      // leaves the range is not reported either.
      if (z < config_.min_range_m || z > config_.max_range_m) continue;
      const double noisy = z + k * z * z * g[u];
      if (noisy < config_.min_range_m || noisy > config_.max_range_m) continue;
      frame.depth_m[p] = static_cast<float>(noisy);
    }
  });
  return frame;
}

}  // namespace fdv::sim
