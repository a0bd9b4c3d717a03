#include "fdv/sim/event_camera.h"

#include <algorithm>
#include <cmath>

#include "fdv/core/error.h"
#include "fdv/sim/fast_math.h"
#include "fdv/sim/geometry.h"

namespace fdv::sim {
namespace {

constexpr int kPlanSamples = 9;  ///< trajectory samples per chunk for the motion bounds

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace

EventCameraSim::EventCameraSim(const ScenarioConfig& config, const Calibration& calib,
                               const Scene& scene, const VehicleTrajectory& vehicle,
                               const std::vector<BallTrajectory>& balls, ThreadPool& pool)
    : config_(config),
      scene_(scene),
      vehicle_(vehicle),
      balls_(balls),
      calib_(calib),
      width_(calib.event_camera.width),
      height_(calib.event_camera.height),
      pool_(pool) {
  const auto& ec = config.event_camera;
  refractory_ns_ = from_seconds(ec.refractory_s);
  resolution_ns_ = std::max<TimeNs>(1, from_seconds(ec.timestamp_resolution_s));
  jitter_ns_ = ec.timestamp_jitter_s * 1e9;
  dark_ = static_cast<float>(ec.dark_current_lux);
  if (balls.size() > 8) throw ConfigError("at most 8 balls");

  const auto n = static_cast<std::size_t>(width_) * height_;
  // Tiles, and the per-pixel arrays in tile-major order: each tile's pixels are contiguous
  // (blocks padded to 32 pixels), so threads working on neighbouring tiles share at most the
  // cache line at a block boundary instead of one per image row.
  const int ts = ec.tile_px;
  tiles_x_ = (width_ + ts - 1) / ts;
  tiles_y_ = (height_ + ts - 1) / ts;
  tiles_.resize(static_cast<std::size_t>(tiles_x_) * tiles_y_);
  std::size_t total = 0;
  for (int ty = 0; ty < tiles_y_; ++ty)
    for (int tx = 0; tx < tiles_x_; ++tx) {
      Tile& t = tiles_[static_cast<std::size_t>(ty) * tiles_x_ + tx];
      t.x0 = tx * ts, t.y0 = ty * ts;
      t.x1 = std::min(width_, t.x0 + ts), t.y1 = std::min(height_, t.y0 + ts);
      t.offset = total;
      total += (static_cast<std::size_t>(t.x1 - t.x0) * (t.y1 - t.y0) + 31) / 32 * 32;
    }
  ray_x_.assign(total, 0.0f), ray_y_.assign(total, 0.0f), footprint_.assign(total, 0.0f);
  pixel_angle_.assign(total, 0.0f), log_i_.assign(total, 0.0f), label_.assign(total, 0);
  memory_.resize(total), threshold_.resize(total);
  noise_next_.assign(total, 0), noise_interval_ns_.assign(total, 0.0f), hot_.assign(total, 0);

  // Viewing ray of every pixel centre (normalised undistorted coordinates).
  const PinholeCamera& cam = calib.event_camera;
  std::vector<double> rx(n), ry(n);
  // Newton's method on the lens map, started from the left neighbour's solution (2-3 steps
  // instead of a cold start per pixel); the camera model's own inverse where that fails.
  pool_.parallel_for(static_cast<std::size_t>(height_), [&](std::size_t row) {
    const int v = static_cast<int>(row);
    const auto& dist = cam.distortion;
    Eigen::Vector2d guess((0 - cam.cx) / cam.fx, (v - cam.cy) / cam.fy);
    for (int u = 0; u < width_; ++u) {
      const Eigen::Vector2d xd((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy);
      Eigen::Vector2d xn = guess;
      bool ok = false;
      for (int it = 0; it < 20; ++it) {
        const double x = xn.x(), y = xn.y(), r2 = x * x + y * y;
        const double radial = 1 + r2 * (dist.k1 + r2 * (dist.k2 + r2 * dist.k3));
        const double dradial = dist.k1 + r2 * (2 * dist.k2 + 3 * r2 * dist.k3);
        const Eigen::Vector2d res = cam.distort(xn) - xd;
        if (res.norm() < 1e-13) {
          ok = true;
          break;
        }
        Eigen::Matrix2d J;
        J(0, 0) = radial + 2 * x * x * dradial + 2 * dist.p1 * y + 6 * dist.p2 * x;
        J(0, 1) = 2 * x * y * dradial + 2 * dist.p1 * x + 2 * dist.p2 * y;
        J(1, 0) = J(0, 1);
        J(1, 1) = radial + 2 * y * y * dradial + 6 * dist.p1 * y + 2 * dist.p2 * x;
        if (J.determinant() <= 0) break;
        xn -= J.inverse() * res;
      }
      if (!ok) xn = cam.pixel_to_normalized({u, v});
      if (!xn.allFinite()) xn = radial_extension(cam, xd);  // beyond the lens model's fold
      guess = xn;
      rx[row * width_ + u] = xn.x(), ry[row * width_ + u] = xn.y();
    }
  });
  // Local lens Jacobian (normalised units per pixel) by differences with a neighbour.
  std::vector<float> scale_px(n), footprint(n), pixel_angle(n);
  for (int v = 0; v < height_; ++v)
    for (int u = 0; u < width_; ++u) {
      const auto p = static_cast<std::size_t>(v) * width_ + u;
      const auto pu = u + 1 < width_ ? p + 1 : p - 1;
      const auto pv = v + 1 < height_ ? p + width_ : p - width_;
      const double su = u + 1 < width_ ? 1 : -1, sv = v + 1 < height_ ? 1 : -1;
      Eigen::Matrix2d J;
      J << (rx[pu] - rx[p]) * su, (rx[pv] - rx[p]) * sv, (ry[pu] - ry[p]) * su,
          (ry[pv] - ry[p]) * sv;
      const Eigen::Vector2d sv2 = J.jacobiSvd().singularValues();
      const double norm = std::sqrt(rx[p] * rx[p] + ry[p] * ry[p] + 1);
      footprint[p] = static_cast<float>(sv2[0] * norm);
      pixel_angle[p] = static_cast<float>(sv2[0] / norm);
      scale_px[p] = static_cast<float>(1.0 / std::max(sv2[1], 1e-12));
    }

  // Tile geometry, random streams, and the per-pixel draws made in tile order.
  for (int ty = 0; ty < tiles_y_; ++ty)
    for (int tx = 0; tx < tiles_x_; ++tx) {
      const auto index = static_cast<std::size_t>(ty) * tiles_x_ + tx;
      Tile& t = tiles_[index];
      for (int y = t.y0; y < t.y1; ++y)
        for (int x = t.x0; x < t.x1; ++x) {
          const auto q = static_cast<std::size_t>(y) * width_ + x, p = pixel(t, x, y);
          ray_x_[p] = static_cast<float>(rx[q]), ray_y_[p] = static_cast<float>(ry[q]);
          footprint_[p] = footprint[q], pixel_angle_[p] = pixel_angle[q];
        }
      t.noise_rng = Rng::stream(config.seed, RngStream::kPixelNoise, index);
      t.jitter_rng = Rng::stream(config.seed, RngStream::kJitter, index);
      Rng setup = Rng::stream(config.seed, RngStream::kPixelSetup, index);
      Eigen::Vector3d mean_dir = Eigen::Vector3d::Zero();
      t.xmin = t.ymin = 1e9f, t.xmax = t.ymax = -1e9f;
      for (int y = t.y0; y < t.y1; ++y)
        for (int x = t.x0; x < t.x1; ++x) {
          const auto p = pixel(t, x, y);
          const float margin = footprint_[p];  // ≥ one pixel in normalised units
          const float px = ray_x_[p], py = ray_y_[p];
          t.x_abs = std::max(t.x_abs, std::abs(px) + margin);
          t.y_abs = std::max(t.y_abs, std::abs(py) + margin);
          t.xy_abs = std::max(t.xy_abs, (std::abs(px) + margin) * (std::abs(py) + margin));
          t.r_max = std::max(t.r_max, std::sqrt(px * px + py * py) + margin);
          t.xmin = std::min(t.xmin, px - margin), t.xmax = std::max(t.xmax, px + margin);
          t.ymin = std::min(t.ymin, py - margin), t.ymax = std::max(t.ymax, py + margin);
          t.scale_px =
              std::max(t.scale_px, scale_px[static_cast<std::size_t>(y) * width_ + x] * 1.02f);
          mean_dir += Eigen::Vector3d(px, py, 1).normalized();
          // Pixel constants: contrast thresholds, noise rate, hot pixels.
          auto draw_threshold = [&] {
            const double c =
                ec.contrast_threshold_mean + ec.contrast_threshold_spread * setup.normal();
            return static_cast<float>(std::max(c, ec.contrast_threshold_min));
          };
          threshold_[p].on = draw_threshold();
          threshold_[p].off = draw_threshold();
          double rate = ec.background_rate_hz *
                        std::pow(10.0, ec.background_rate_spread_decades * setup.normal());
          const double hot_draw = setup.normal();
          if (setup.bernoulli(ec.hot_pixel_fraction)) {
            hot_[p] = 1;
            rate = std::max(ec.hot_pixel_rate_min_hz,
                            ec.hot_pixel_rate_median_hz *
                                std::pow(10.0, ec.hot_pixel_rate_spread_decades * hot_draw));
          }
          noise_interval_ns_[p] = rate > 0 ? static_cast<float>(1e9 / rate) : 0.0f;
        }
      t.center_dir = mean_dir.normalized();
      for (int y = t.y0; y < t.y1; ++y)
        for (int x = t.x0; x < t.x1; ++x) {
          const auto p = pixel(t, x, y);
          const double a = angle_between(t.center_dir, Eigen::Vector3d(ray_x_[p], ray_y_[p], 1));
          t.radius_rad = std::max(t.radius_rad, a + 1.5 * pixel_angle_[p]);
        }
    }
}

EventCameraSim::Frame EventCameraSim::make_frame(TimeNs t) const {
  Frame f;
  const BodyState s = vehicle_.at(to_seconds(t));
  const Eigen::Matrix3d R_W_E = s.R_W_B * calib_.T_B_E.linear();
  const Eigen::Vector3d o = s.p_W + s.R_W_B * calib_.T_B_E.translation();
  for (int r = 0; r < 3; ++r) {
    f.o[r] = static_cast<float>(o[r]);
    for (int c = 0; c < 3; ++c) f.R[3 * r + c] = static_cast<float>(R_W_E(r, c));
  }
  f.ball_count = static_cast<int>(balls_.size());
  for (int b = 0; b < f.ball_count; ++b) {
    const BallState bs = balls_[b].at(to_seconds(t));
    BallFrame& bf = f.ball[b];
    for (int r = 0; r < 3; ++r) {
      bf.c[r] = static_cast<float>(bs.p_W[r]);
      for (int c = 0; c < 3; ++c) bf.R_O_W[3 * r + c] = static_cast<float>(bs.R_W_O(c, r));
    }
    bf.r = static_cast<float>(balls_[b].config().radius_m);
    bf.index = b;
    bf.exists = bs.exists;
  }
  return f;
}

void EventCameraSim::render_tile(const Tile& tile, const Frame& f, float* log_i,
                                 std::int16_t* label, float& rho_max) const {
  using namespace lanes;
  // Per-frame ball constants.
  struct BallConst {
    float oc[3], oc_len, alpha, r;
  } bc[8];
  for (int b = 0; b < f.ball_count; ++b) {
    const BallFrame& bf = f.ball[b];
    float len2 = 0;
    for (int a = 0; a < 3; ++a) bc[b].oc[a] = bf.c[a] - f.o[a], len2 += bc[b].oc[a] * bc[b].oc[a];
    bc[b].oc_len = std::sqrt(len2);
    bc[b].r = bf.r;
    bc[b].alpha = bc[b].oc_len > bf.r ? std::asin(bf.r / bc[b].oc_len) : 1.5707963f;
  }
  const float* R = f.R;
  float z_min = 1e30f;
  int j = 0;
  for (int y = tile.y0; y < tile.y1; ++y) {
    for (int x = tile.x0; x < tile.x1; x += kLanes) {
      // kLanes pixels of the row (a short last group repeats its last pixel).
      const int n = std::min(kLanes, tile.x1 - x);
      const std::size_t p0 = pixel(tile, x, y);
      vf px, py, fp;
      if (n == kLanes) {
        px = load(&ray_x_[p0]), py = load(&ray_y_[p0]), fp = load(&footprint_[p0]);
      } else {
        for (int k = 0; k < kLanes; ++k) {
          const std::size_t p = p0 + std::min(k, n - 1);
          px[k] = ray_x_[p], py[k] = ray_y_[p], fp[k] = footprint_[p];
        }
      }
      const vf d[3] = {R[0] * px + R[1] * py + R[2], R[3] * px + R[4] * py + R[5],
                       R[6] * px + R[7] * py + R[8]};
      vf inv[3];
      for (int a = 0; a < 3; ++a) {
        const vf tiny = select(d[a] < 0, splat(-1e-20f), splat(1e-20f));
        inv[a] = 1.0f / select(abs(d[a]) < 1e-20f, tiny, d[a]);
      }
      vf t;
      vi surf;
      scene_.cast_static_v(f.o, d, inv, tile.panels, t, surf);
      vf intensity;
      if (all_equal(surf)) {
        intensity = scene_.static_radiance_v(surf[0], t, f.o, d, fp);
      } else {  // the group straddles a surface boundary: shade lane by lane
        for (int k = 0; k < kLanes; ++k) {
          const float dk[3] = {d[0][k], d[1][k], d[2][k]};
          intensity[k] = scene_.static_radiance(RayHit{t[k], surf[k]}, f.o, dk, fp[k]);
        }
      }
      vf z = t;
      std::int16_t lab[kLanes] = {};
      if (tile.balls) {
        for (int k = 0; k < n; ++k) {
          const float norm = std::sqrt(px[k] * px[k] + py[k] * py[k] + 1.0f);
          const float dh[3] = {d[0][k] / norm, d[1][k] / norm, d[2][k] / norm};
          const std::size_t p = p0 + k;
          for (int b = 0; b < f.ball_count; ++b) {
            if (!(tile.balls & (1u << b)) || !f.ball[b].exists) continue;
            const BallConst& c = bc[b];
            const float along = dh[0] * c.oc[0] + dh[1] * c.oc[1] + dh[2] * c.oc[2];
            if (along <= 0) continue;
            const float perp2 = std::max(c.oc_len * c.oc_len - along * along, 0.0f);
            const float beta = std::atan2(std::sqrt(perp2), along);
            const float ang = pixel_angle_[p];
            const float s = (beta - c.alpha) / ang;  // signed distance to the silhouette [px]
            if (s >= 0.5f) continue;
            const float coverage = std::min(1.0f, 0.5f - s);
            const float r2 = c.r * c.r;
            const float t_unit = perp2 < r2 ? along - std::sqrt(r2 - perp2) : along;
            const float z_ball = t_unit / norm;
            if (z_ball >= z[k]) continue;  // behind the static scene
            float nrm[3];
            float nlen2 = 0;
            for (int a = 0; a < 3; ++a) {
              nrm[a] = t_unit * dh[a] - c.oc[a];
              nlen2 += nrm[a] * nrm[a];
            }
            const float inv_nlen = 1.0f / std::sqrt(std::max(nlen2, 1e-20f));
            for (float& v : nrm) v *= inv_nlen;
            const float* Ro = f.ball[b].R_O_W;
            const float n_o[3] = {Ro[0] * nrm[0] + Ro[1] * nrm[1] + Ro[2] * nrm[2],
                                  Ro[3] * nrm[0] + Ro[4] * nrm[1] + Ro[5] * nrm[2],
                                  Ro[6] * nrm[0] + Ro[7] * nrm[1] + Ro[8] * nrm[2]};
            const float cos_inc = -(dh[0] * nrm[0] + dh[1] * nrm[1] + dh[2] * nrm[2]);
            const float ball_i =
                scene_.ball_radiance(f.ball[b].index, nrm, n_o, t_unit, ang, cos_inc);
            intensity[k] = coverage * ball_i + (1 - coverage) * intensity[k];
            lab[k] = static_cast<std::int16_t>(scene_.ball_look(f.ball[b].index).id);
            z[k] = z_ball;
          }
        }
      }
      const vf L = fast_log(intensity + dark_);
      for (int k = 0; k < n; ++k) {
        log_i[j + k] = L[k];
        label[j + k] = lab[k];
        z_min = std::min(z_min, z[k]);
      }
      j += n;
    }
  }
  rho_max = std::max(rho_max, 1.0f / z_min);
}

void EventCameraSim::initialize(TimeNs t0) {
  const Frame f = make_frame(t0);
  pool_.parallel_for(tiles_.size(), [&](std::size_t i) {
    Tile& tile = tiles_[i];
    tile.panels = scene_.all_panels();
    tile.balls = (1u << f.ball_count) - 1u;
    const int area = (tile.x1 - tile.x0) * (tile.y1 - tile.y0);
    std::vector<float> li(area);
    std::vector<std::int16_t> lab(area);
    tile.rho_max = 0;
    render_tile(tile, f, li.data(), lab.data(), tile.rho_max);
    int j = 0;
    for (int y = tile.y0; y < tile.y1; ++y)
      for (int x = tile.x0; x < tile.x1; ++x, ++j) {
        const auto p = tile.offset + j;
        log_i_[p] = li[j];
        label_[p] = lab[j];
        memory_[p] = PixelMemory{li[j], PixelMemory::kNoLatch};
        if (noise_interval_ns_[p] > 0)
          noise_next_[p] =
              t0 +
              std::max<TimeNs>(1, std::llround(tile.noise_rng.exponential(noise_interval_ns_[p])));
        else
          noise_next_[p] = std::numeric_limits<TimeNs>::max();
      }
    tile.noise_next = std::numeric_limits<TimeNs>::max();
    for (int k = 0; k < area; ++k)
      tile.noise_next = std::min(tile.noise_next, noise_next_[tile.offset + k]);
  });
}

void EventCameraSim::plan_chunk(TimeNs t0, TimeNs t1) {
  const auto& ec = config_.event_camera;
  const double dt_s = to_seconds(t1 - t0);
  const Eigen::Matrix3d R_B_E = calib_.T_B_E.linear();
  const Eigen::Vector3d p_B_E = calib_.T_B_E.translation();

  // Camera motion at the plan samples, in E.
  Eigen::Matrix3d R_E_W[kPlanSamples];
  Eigen::Vector3d o_W[kPlanSamples], v_cam_W[kPlanSamples], w_E[kPlanSamples], v_E[kPlanSamples];
  double t_s[kPlanSamples];
  for (int k = 0; k < kPlanSamples; ++k) {
    t_s[k] = to_seconds(t0) + dt_s * k / (kPlanSamples - 1);
    const BodyState s = vehicle_.at(t_s[k]);
    R_E_W[k] = (s.R_W_B * R_B_E).transpose();
    o_W[k] = s.p_W + s.R_W_B * p_B_E;
    v_cam_W[k] = s.v_W + s.R_W_B * s.omega_B.cross(p_B_E);
    w_E[k] = R_B_E.transpose() * s.omega_B;
    v_E[k] = R_E_W[k] * v_cam_W[k];
  }

  // Panels: normalised image bounding box over the chunk, or "everywhere" if a corner is near
  // or behind the camera plane.
  const int np = scene_.panel_count();
  struct Box {
    double x0, x1, y0, y1;
    bool all;
  };
  std::vector<Box> panel_box(np);
  for (int i = 0; i < np; ++i) {
    const auto corners = scene_.panel_corners(i);
    Box box{1e9, -1e9, 1e9, -1e9, false};
    double max_step = 0;
    Eigen::Vector2d prev[4];
    for (int k = 0; k < kPlanSamples; k += (kPlanSamples - 1) / 2) {
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d X = R_E_W[k] * (corners[c] - o_W[k]);
        if (X.z() < 0.05) {
          box.all = true;
          break;
        }
        const Eigen::Vector2d xn = X.head<2>() / X.z();
        if (k > 0) max_step = std::max(max_step, (xn - prev[c]).norm());
        prev[c] = xn;
        box.x0 = std::min(box.x0, xn.x()), box.x1 = std::max(box.x1, xn.x());
        box.y0 = std::min(box.y0, xn.y()), box.y1 = std::max(box.y1, xn.y());
      }
      if (box.all) break;
    }
    const double m = 0.005 + 0.5 * max_step;
    box.x0 -= m, box.x1 += m, box.y0 -= m, box.y1 += m;
    panel_box[i] = box;
  }

  // Balls: swept cone per consecutive sample pair and speed bound.
  const int nb = static_cast<int>(balls_.size());
  struct BallPlan {
    Eigen::Vector3d dir[kPlanSamples];
    double reach[kPlanSamples - 1];  // half-angle of the swept cone for each pair
    double pdot = 0, z_near = 1e9;
    bool everywhere = false;
  };
  std::vector<BallPlan> ball_plan(nb);
  for (int b = 0; b < nb; ++b) {
    BallPlan& bp = ball_plan[b];
    const double r = balls_[b].config().radius_m;
    const double spin = balls_[b].config().spin_W_rad_s.norm();
    double alpha[kPlanSamples];
    for (int k = 0; k < kPlanSamples; ++k) {
      // A ball that does not exist yet is planned at its release position (its state then).
      const BallState bs = balls_[b].at(std::max(t_s[k], balls_[b].config().release_t_s));
      const Eigen::Vector3d c = R_E_W[k] * (bs.p_W - o_W[k]);
      const double dist = c.norm();
      if (dist <= r * 1.05) bp.everywhere = true;
      bp.dir[k] = c / std::max(dist, 1e-9);
      alpha[k] = dist > r ? std::asin(r / dist) : 1.5707963267948966;
      const double rel = (R_E_W[k] * (bs.v_W - v_cam_W[k])).norm();
      bp.pdot =
          std::max(bp.pdot, rel + w_E[k].norm() * (dist + r) + (bs.released ? spin * r : 0.0));
      bp.z_near = std::min(bp.z_near, c.z() - r);
    }
    for (int k = 0; k + 1 < kPlanSamples; ++k)
      bp.reach[k] = std::max(alpha[k], alpha[k + 1]) + angle_between(bp.dir[k], bp.dir[k + 1]);
    bp.pdot = bp.pdot * 1.1 + 1e-3;
  }

  const double margin_rad = 2.0 / calib_.event_camera.fx;
  const int max_steps = ec.max_steps_per_chunk;
  pool_.parallel_for(tiles_.size(), [&](std::size_t ti) {
    const int ty = static_cast<int>(ti) / tiles_x_, tx = static_cast<int>(ti) % tiles_x_;
    Tile& tile = tiles_[ti];
    // Nearest depth seen in this tile or a neighbour at the last sample, +20 %.
    float rho = 0;
    for (int ny = std::max(0, ty - 1); ny <= std::min(tiles_y_ - 1, ty + 1); ++ny)
      for (int nx = std::max(0, tx - 1); nx <= std::min(tiles_x_ - 1, tx + 1); ++nx)
        rho = std::max(rho, tiles_[static_cast<std::size_t>(ny) * tiles_x_ + nx].rho_max);
    const double rb = 1.2 * rho + 1e-3;
    // Image velocity of static points (normalised units/s) on a 3x3 grid over the tile at
    // every plan sample, for inverse depth 0 and rb (|flow| is convex in the inverse depth):
    //   x' = rho (x vz - vx) + x y wx - (1 + x^2) wy + y wz
    //   y' = rho (y vz - vy) + (1 + y^2) wx - x y wy - x wz
    double flow2 = 0;
    const double gx[3] = {tile.xmin, 0.5 * (tile.xmin + tile.xmax), tile.xmax};
    const double gy[3] = {tile.ymin, 0.5 * (tile.ymin + tile.ymax), tile.ymax};
    for (int k = 0; k < kPlanSamples; ++k) {
      const Eigen::Vector3d& w = w_E[k];
      const Eigen::Vector3d& v = v_E[k];
      for (double x : gx)
        for (double y : gy) {
          const double rx = x * y * w.x() - (1 + x * x) * w.y() + y * w.z();
          const double ry = (1 + y * y) * w.x() - x * y * w.y() - x * w.z();
          const double tx_ = x * v.z() - v.x(), ty_ = y * v.z() - v.y();
          flow2 = std::max(flow2, rx * rx + ry * ry);
          const double fx = rx + rb * tx_, fy = ry + rb * ty_;
          flow2 = std::max(flow2, fx * fx + fy * fy);
        }
    }
    double rate = 1.15 * tile.scale_px * std::sqrt(flow2) + 1.0;  // [px/s]
    bool capped = false;

    tile.panels = 0;
    for (int i = 0; i < np; ++i) {
      const Box& b = panel_box[i];
      if (b.all ||
          (b.x1 >= tile.xmin && b.x0 <= tile.xmax && b.y1 >= tile.ymin && b.y0 <= tile.ymax))
        tile.panels |= 1ull << i;
    }
    tile.balls = 0;
    for (int b = 0; b < nb; ++b) {
      const BallPlan& bp = ball_plan[b];
      bool touches = bp.everywhere;
      for (int k = 0; !touches && k + 1 < kPlanSamples; ++k) {
        const double reach = bp.reach[k] + tile.radius_rad + margin_rad;
        touches = reach >= 3.14159 || tile.center_dir.dot(bp.dir[k]) >= std::cos(reach);
      }
      if (!touches) continue;
      tile.balls |= 1u << b;
      if (bp.everywhere || bp.z_near <= 0.05) {
        capped = true;
      } else {
        rate = std::max(
            rate, tile.scale_px * bp.pdot * std::sqrt(1.0 + tile.r_max * tile.r_max) / bp.z_near);
      }
    }
    const double steps = std::ceil(rate * dt_s / ec.max_motion_px);
    tile.capped = capped || steps >= max_steps;
    tile.steps = tile.capped ? max_steps : std::max(1, static_cast<int>(steps));
  });
}

void EventCameraSim::push_event(Tile& tile, double t_ns, int x, int y, bool on, std::int16_t label,
                                TimeNs t0, TimeNs t1) {
  if (jitter_ns_ > 0) {
    t_ns += jitter_ns_ * tile.jitter_rng.normal();
    t_ns = std::clamp(t_ns, static_cast<double>(t0), static_cast<double>(t1));
  }
  const TimeNs t =
      static_cast<TimeNs>(std::floor(t_ns / static_cast<double>(resolution_ns_))) * resolution_ns_;
  tile.events.push_back({t, static_cast<std::uint16_t>(x), static_cast<std::uint16_t>(y),
                         static_cast<std::uint8_t>(on ? 1 : 0), label});
}

void EventCameraSim::process_tile(Tile& tile, TimeNs t0, TimeNs t1) {
  thread_local std::vector<float> li;
  thread_local std::vector<std::int16_t> lab;
  const int w = tile.x1 - tile.x0;
  const auto area = static_cast<std::size_t>(w) * (tile.y1 - tile.y0);
  li.resize(area);
  lab.resize(area);
  tile.events.clear();
  float rho = 0;
  TimeNs prev = t0;
  for (int k = 1; k <= tile.steps; ++k) {
    const TimeNs t = t0 + (t1 - t0) * k / tile.steps;
    if (tile.steps <= kCachedSteps) {
      render_tile(tile, frame_cache_[(tile.steps - 1) * tile.steps / 2 + k - 1], li.data(),
                  lab.data(), rho);
    } else {
      const Frame f = make_frame(t);
      render_tile(tile, f, li.data(), lab.data(), rho);
    }
    std::size_t j = 0;
    for (int y = tile.y0; y < tile.y1; ++y) {
      for (int x = tile.x0; x < tile.x1; ++x, ++j) {
        const std::size_t p = tile.offset + j;
        const std::int16_t event_label = label_[p] > 0 ? label_[p] : lab[j];
        emit_crossings(
            memory_[p], prev, log_i_[p], t, li[j], threshold_[p], refractory_ns_,
            [&](double te, bool on) { push_event(tile, te, x, y, on, event_label, t0, t1); });
        log_i_[p] = li[j];
        label_[p] = lab[j];
      }
    }
    prev = t;
  }
  tile.rho_max = rho;
  add_noise(tile, t0, t1);
}

void EventCameraSim::add_noise(Tile& tile, TimeNs t0, TimeNs t1) {
  if (tile.noise_next > t1) return;  // no pixel of the tile is due in this chunk
  const double on_fraction = config_.event_camera.background_on_fraction;
  TimeNs next = std::numeric_limits<TimeNs>::max();
  std::size_t p = tile.offset;
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; ++x, ++p) {
      while (noise_next_[p] <= t1) {
        const bool on = tile.noise_rng.bernoulli(on_fraction);
        const TimeNs t = std::max(noise_next_[p], t0);
        const TimeNs tq = t / resolution_ns_ * resolution_ns_;
        tile.events.push_back({std::max(tq, t0), static_cast<std::uint16_t>(x),
                               static_cast<std::uint16_t>(y), static_cast<std::uint8_t>(on ? 1 : 0),
                               hot_[p] ? kLabelHotPixel : kLabelNoise});
        noise_next_[p] +=
            std::max<TimeNs>(1, std::llround(tile.noise_rng.exponential(noise_interval_ns_[p])));
      }
      next = std::min(next, noise_next_[p]);
    }
  tile.noise_next = next;
}

void EventCameraSim::run_chunk(TimeNs t0, TimeNs t1, std::vector<Event>& events,
                               std::vector<std::int16_t>& labels) {
  plan_chunk(t0, t1);
  // The frames most tiles sample at (n <= kCachedSteps equal steps), computed once.
  frame_cache_.resize(kCachedSteps * (kCachedSteps + 1) / 2);
  pool_.parallel_for(frame_cache_.size(), [&](std::size_t i) {
    int n = 1;
    while (static_cast<int>(i) >= n * (n + 1) / 2) ++n;
    const int k = static_cast<int>(i) - (n - 1) * n / 2 + 1;
    frame_cache_[i] = make_frame(t0 + (t1 - t0) * k / n);
  });
  // Most expensive tiles first, so that no thread is left with a big one at the end.
  order_.resize(tiles_.size());
  for (std::size_t i = 0; i < order_.size(); ++i) order_[i] = i;
  std::stable_sort(order_.begin(), order_.end(),
                   [&](std::size_t a, std::size_t b) { return tiles_[a].steps > tiles_[b].steps; });
  pool_.parallel_for(order_.size(),
                     [&](std::size_t i) { process_tile(tiles_[order_[i]], t0, t1); });

  std::size_t total = 0;
  for (const Tile& tile : tiles_) {
    total += tile.events.size();
    const auto area = static_cast<std::uint64_t>(tile.x1 - tile.x0) * (tile.y1 - tile.y0);
    stats_.pixel_samples += area * tile.steps;
    stats_.tile_samples += tile.steps;
    stats_.max_tile_steps = std::max(stats_.max_tile_steps, tile.steps);
    stats_.capped_tiles += tile.capped;
  }
  merged_.clear();
  merged_.reserve(total);
  for (const Tile& tile : tiles_)
    merged_.insert(merged_.end(), tile.events.begin(), tile.events.end());
  std::sort(merged_.begin(), merged_.end(), [](const LabeledEvent& a, const LabeledEvent& b) {
    if (a.t != b.t) return a.t < b.t;
    if (a.y != b.y) return a.y < b.y;
    if (a.x != b.x) return a.x < b.x;
    if (a.on != b.on) return a.on < b.on;
    return a.label < b.label;
  });
  for (const LabeledEvent& e : merged_) {
    events.push_back({e.t, e.x, e.y, e.on != 0});
    labels.push_back(e.label);
  }
}

}  // namespace fdv::sim
