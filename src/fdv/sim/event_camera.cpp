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

/// The lens's per-pixel geometry in image row-major order, before it is stored tile-major.
struct EventCameraSim::LensGrid {
  std::vector<double> ray_x, ray_y;  ///< normalised undistorted coordinates of the pixel centre
  std::vector<float> footprint;      ///< see footprint_
  std::vector<float> pixel_angle;    ///< see pixel_angle_
  std::vector<float> scale_px;       ///< largest pixels per normalised unit
};

EventCameraSim::EventCameraSim(const ScenarioConfig& config, const Calibration& calib,
                               const Scene& scene, const FlownVehicle& vehicle,
                               const std::vector<BallTrajectory>& balls, ThreadPool& pool)
    : config_(&config),
      scene_(&scene),
      vehicle_(&vehicle),
      balls_(&balls),
      calib_(calib),
      width_(calib.event_camera.width),
      height_(calib.event_camera.height),
      refractory_ns_(from_seconds(config.event_camera.refractory_s)),
      resolution_ns_(std::max<TimeNs>(1, from_seconds(config.event_camera.timestamp_resolution_s))),
      jitter_ns_(config.event_camera.timestamp_jitter_s * 1e9),
      dark_(static_cast<float>(config.event_camera.dark_current_lux)),
      pool_(&pool) {
  if (balls.size() > kMaxBalls) throw ConfigError("at most 8 balls");
  lay_out_tiles();
  LensGrid lens = trace_pixel_rays();
  measure_lens_scale(lens);
  for (std::size_t i = 0; i < tiles_.size(); ++i) {
    Tile& tile = tiles_[i];
    store_pixel_geometry(tile, lens);
    bound_tile(tile, lens);
    aim_tile(tile);
    draw_pixel_constants(tile, i);
    tile.noise_rng = Rng::stream(config.seed, RngStream::kPixelNoise, i);
    tile.jitter_rng = Rng::stream(config.seed, RngStream::kJitter, i);
  }
}

EventCameraSim::EventCameraSim(const EventCameraSim& state, const ScenarioConfig& config,
                               const Scene& scene, const FlownVehicle& vehicle,
                               const std::vector<BallTrajectory>& balls, ThreadPool& pool)
    : EventCameraSim(state) {
  config_ = &config, scene_ = &scene, vehicle_ = &vehicle, balls_ = &balls, pool_ = &pool;
}

// Tiles, and the per-pixel arrays in tile-major order: each tile's pixels are contiguous (blocks
// padded to 32 pixels), so threads working on neighbouring tiles share at most the cache line at
// a block boundary instead of one per image row.
void EventCameraSim::lay_out_tiles() {
  const int ts = config_->event_camera.tile_px;
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
}

// Viewing ray of every pixel centre: Newton's method on the lens map started from the left
// neighbour's solution (2-3 steps instead of a cold start per pixel); the camera model's own
// inverse where that fails, and beyond the lens model's fold its radial extension.
EventCameraSim::LensGrid EventCameraSim::trace_pixel_rays() const {
  const PinholeCamera& cam = calib_.event_camera;
  const auto n = static_cast<std::size_t>(width_) * height_;
  LensGrid lens;
  lens.ray_x.resize(n), lens.ray_y.resize(n);
  pool_->parallel_for(static_cast<std::size_t>(height_), [&](std::size_t row) {
    const int v = static_cast<int>(row);
    Eigen::Vector2d guess((0 - cam.cx) / cam.fx, (v - cam.cy) / cam.fy);
    for (int u = 0; u < width_; ++u) {
      const Eigen::Vector2d xd((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy);
      Eigen::Vector2d xn = cam.undistort_near(xd, guess);
      if (!xn.allFinite()) xn = radial_extension(cam, xd);
      guess = xn;
      lens.ray_x[row * width_ + u] = xn.x(), lens.ray_y[row * width_ + u] = xn.y();
    }
  });
  return lens;
}

// The local lens Jacobian (normalised units per pixel), by differences with a neighbour: a
// pixel's footprint and angular size, and how many pixels a normalised unit spans at most.
void EventCameraSim::measure_lens_scale(LensGrid& lens) const {
  const auto n = static_cast<std::size_t>(width_) * height_;
  lens.footprint.resize(n), lens.pixel_angle.resize(n), lens.scale_px.resize(n);
  const std::vector<double>& rx = lens.ray_x;
  const std::vector<double>& ry = lens.ray_y;
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
      lens.footprint[p] = static_cast<float>(sv2[0] * norm);
      lens.pixel_angle[p] = static_cast<float>(sv2[0] / norm);
      lens.scale_px[p] = static_cast<float>(1.0 / std::max(sv2[1], 1e-12));
    }
}

// The renderer reads a tile's rays from one contiguous block (see lay_out_tiles).
void EventCameraSim::store_pixel_geometry(const Tile& tile, const LensGrid& lens) {
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; ++x) {
      const auto q = static_cast<std::size_t>(y) * width_ + x, p = pixel(tile, x, y);
      ray_x_[p] = static_cast<float>(lens.ray_x[q]), ray_y_[p] = static_cast<float>(lens.ray_y[q]);
      footprint_[p] = lens.footprint[q], pixel_angle_[p] = lens.pixel_angle[q];
    }
}

// The tile's extent in normalised coordinates (+ one pixel) and its largest magnification: what
// the planner needs to bound the image motion of points seen through the tile.
void EventCameraSim::bound_tile(Tile& tile, const LensGrid& lens) const {
  tile.xmin = tile.ymin = 1e9f, tile.xmax = tile.ymax = -1e9f;
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; ++x) {
      const auto p = pixel(tile, x, y);
      const float margin = footprint_[p];  // ≥ one pixel in normalised units
      const float px = ray_x_[p], py = ray_y_[p];
      tile.r_max = std::max(tile.r_max, std::sqrt(px * px + py * py) + margin);
      tile.xmin = std::min(tile.xmin, px - margin), tile.xmax = std::max(tile.xmax, px + margin);
      tile.ymin = std::min(tile.ymin, py - margin), tile.ymax = std::max(tile.ymax, py + margin);
      tile.scale_px =
          std::max(tile.scale_px, lens.scale_px[static_cast<std::size_t>(y) * width_ + x] * 1.02f);
    }
}

// The cone of viewing directions the tile covers (+1.5 px), for the planner's test whether a
// ball's swept silhouette may reach the tile.
void EventCameraSim::aim_tile(Tile& tile) const {
  Eigen::Vector3d mean_dir = Eigen::Vector3d::Zero();
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; ++x) {
      const auto p = pixel(tile, x, y);
      mean_dir += Eigen::Vector3d(ray_x_[p], ray_y_[p], 1).normalized();
    }
  tile.center_dir = mean_dir.normalized();
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; ++x) {
      const auto p = pixel(tile, x, y);
      const double a = angle_between(tile.center_dir, Eigen::Vector3d(ray_x_[p], ray_y_[p], 1));
      tile.radius_rad = std::max(tile.radius_rad, a + 1.5 * pixel_angle_[p]);
    }
}

// Each pixel's own contrast thresholds, background-activity rate and hot-pixel state, drawn from
// the tile's stream in pixel order: the same pixels for any thread count.
void EventCameraSim::draw_pixel_constants(const Tile& tile, std::size_t tile_index) {
  const auto& ec = config_->event_camera;
  Rng setup = Rng::stream(config_->seed, RngStream::kPixelSetup, tile_index);
  auto draw_threshold = [&] {
    const double c = ec.contrast_threshold_mean + ec.contrast_threshold_spread * setup.normal();
    return static_cast<float>(std::max(c, ec.contrast_threshold_min));
  };
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; ++x) {
      const auto p = pixel(tile, x, y);
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
}

void EventCameraSim::initialize(TimeNs t0) {
  const Frame f = make_frame(t0);
  pool_->parallel_for(tiles_.size(), [&](std::size_t i) {
    Tile& tile = tiles_[i];
    tile.panels = scene_->all_panels();
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

void EventCameraSim::run_chunk(TimeNs t0, TimeNs t1, std::vector<Event>& events,
                               std::vector<std::int16_t>& labels) {
  plan_chunk(t0, t1);
  // The frames most tiles sample at (n <= kCachedSteps equal steps), computed once.
  frame_cache_.resize(kCachedSteps * (kCachedSteps + 1) / 2);
  pool_->parallel_for(frame_cache_.size(), [&](std::size_t i) {
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
  pool_->parallel_for(order_.size(),
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

/// The camera's motion at kPlanSamples equally spaced times over a chunk (from the exact
/// trajectory), the input of every motion bound below.
struct EventCameraSim::CameraMotion {
  double t_s[kPlanSamples];
  Eigen::Matrix3d R_E_W[kPlanSamples];
  Eigen::Vector3d o_W[kPlanSamples];      ///< camera centre
  Eigen::Vector3d v_cam_W[kPlanSamples];  ///< camera centre's velocity
  Eigen::Vector3d w_E[kPlanSamples];      ///< angular velocity, in E
  Eigen::Vector3d v_E[kPlanSamples];      ///< camera centre's velocity, in E
};

/// A panel's normalised image bounding box over a chunk, or everywhere (`all`).
struct EventCameraSim::PanelBox {
  double x0, x1, y0, y1;
  bool all;
};

/// Where a ball's silhouette goes over a chunk, and how fast its surface moves.
struct EventCameraSim::BallSweep {
  Eigen::Vector3d dir[kPlanSamples];  ///< unit direction of the centre at each plan sample (E)
  double reach[kPlanSamples - 1];     ///< half-angle of the cone swept between two samples
  double pdot = 0;                    ///< bound on a surface point's speed relative to the camera
  double z_near = 1e9;                ///< nearest depth of the ball over the chunk
  bool everywhere = false;            ///< the camera is (nearly) inside the ball
  /// Too near for the speed bound: the tile gets the most samples.
  bool too_near() const { return everywhere || z_near <= 0.05; }
};

// Each tile gets its own number of equally spaced samples, so that no point of the scene moves
// more than max_motion_px in the image between two of them (see event_camera.h).
void EventCameraSim::plan_chunk(TimeNs t0, TimeNs t1) {
  const CameraMotion motion = sample_camera_motion(t0, t1);
  const std::vector<PanelBox> panel_boxes = bound_panels(motion);
  const std::vector<BallSweep> sweeps = sweep_balls(motion);
  const double dt_s = to_seconds(t1 - t0);
  pool_->parallel_for(tiles_.size(),
                      [&](std::size_t i) { plan_tile(i, motion, panel_boxes, sweeps, dt_s); });
}

// Every motion bound below starts from the camera's exact motion at the plan samples.
EventCameraSim::CameraMotion EventCameraSim::sample_camera_motion(TimeNs t0, TimeNs t1) const {
  const double dt_s = to_seconds(t1 - t0);
  const Eigen::Matrix3d R_B_E = calib_.T_B_E.linear();
  const Eigen::Vector3d p_B_E = calib_.T_B_E.translation();
  CameraMotion m;
  for (int k = 0; k < kPlanSamples; ++k) {
    m.t_s[k] = to_seconds(t0) + dt_s * k / (kPlanSamples - 1);
    const BodyState s = vehicle_->at(m.t_s[k]);
    m.R_E_W[k] = (s.R_W_B * R_B_E).transpose();
    m.o_W[k] = s.p_W + s.R_W_B * p_B_E;
    m.v_cam_W[k] = s.v_W + s.R_W_B * s.omega_B.cross(p_B_E);
    m.w_E[k] = R_B_E.transpose() * s.omega_B;
    m.v_E[k] = m.R_E_W[k] * m.v_cam_W[k];
  }
  return m;
}

// A tile renders only the panels whose box meets it: the box of each panel's corners at the
// chunk's start, middle and end, grown by half the largest corner step between them; "everywhere"
// if a corner is near or behind the camera plane.
std::vector<EventCameraSim::PanelBox> EventCameraSim::bound_panels(
    const CameraMotion& motion) const {
  std::vector<PanelBox> boxes(scene_->panel_count());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const auto corners = scene_->panel_corners(static_cast<int>(i));
    PanelBox box{1e9, -1e9, 1e9, -1e9, false};
    double max_step = 0;
    Eigen::Vector2d prev[4];
    for (int k = 0; k < kPlanSamples; k += (kPlanSamples - 1) / 2) {
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d X = motion.R_E_W[k] * (corners[c] - motion.o_W[k]);
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
    boxes[i] = box;
  }
  return boxes;
}

// A tile renders only the balls whose swept silhouette may touch it, and samples at their speed.
std::vector<EventCameraSim::BallSweep> EventCameraSim::sweep_balls(
    const CameraMotion& motion) const {
  std::vector<BallSweep> sweeps(balls_->size());
  for (std::size_t b = 0; b < balls_->size(); ++b) {
    BallSweep& bp = sweeps[b];
    const double r = (*balls_)[b].config().radius_m;
    const double spin = (*balls_)[b].config().spin_W_rad_s.norm();
    double alpha[kPlanSamples];
    for (int k = 0; k < kPlanSamples; ++k) {
      // A ball that does not exist yet is planned at its release position (its state then).
      const BallState bs =
          (*balls_)[b].at(std::max(motion.t_s[k], (*balls_)[b].config().release_t_s));
      const Eigen::Vector3d c = motion.R_E_W[k] * (bs.p_W - motion.o_W[k]);
      const double dist = c.norm();
      if (dist <= r * 1.05) bp.everywhere = true;
      bp.dir[k] = c / std::max(dist, 1e-9);
      alpha[k] = dist > r ? std::asin(r / dist) : 1.5707963267948966;
      const double rel = (motion.R_E_W[k] * (bs.v_W - motion.v_cam_W[k])).norm();
      bp.pdot = std::max(bp.pdot,
                         rel + motion.w_E[k].norm() * (dist + r) + (bs.released ? spin * r : 0.0));
      bp.z_near = std::min(bp.z_near, c.z() - r);
    }
    for (int k = 0; k + 1 < kPlanSamples; ++k)
      bp.reach[k] = std::max(alpha[k], alpha[k + 1]) + angle_between(bp.dir[k], bp.dir[k + 1]);
    bp.pdot = bp.pdot * 1.1 + 1e-3;
  }
  return sweeps;
}

// One tile's samples: the static scene's image speed, raised by each ball that may touch the
// tile; capped at max_steps_per_chunk (always where a ball is too near to bound).
void EventCameraSim::plan_tile(std::size_t tile_index, const CameraMotion& motion,
                               const std::vector<PanelBox>& panel_boxes,
                               const std::vector<BallSweep>& sweeps, double dt_s) {
  Tile& tile = tiles_[tile_index];
  double rate = static_scene_rate(tile, motion, nearest_inverse_depth(tile_index));  // [px/s]
  tile.panels = panels_in_view(tile, panel_boxes);
  bool capped = false;
  tile.balls = 0;
  for (int b = 0; b < static_cast<int>(sweeps.size()); ++b) {
    if (!may_touch(tile, sweeps[b])) continue;
    tile.balls |= 1u << b;
    if (sweeps[b].too_near())
      capped = true;
    else
      rate = std::max(rate, ball_rate(tile, sweeps[b]));
  }
  const auto& ec = config_->event_camera;
  const double steps = std::ceil(rate * dt_s / ec.max_motion_px);
  tile.capped = capped || steps >= ec.max_steps_per_chunk;
  tile.steps = tile.capped ? ec.max_steps_per_chunk : std::max(1, static_cast<int>(steps));
}

// The largest inverse depth the tile may see in this chunk: that of the nearest point seen in the
// tile or a neighbour at the last sample, +20 %.
double EventCameraSim::nearest_inverse_depth(std::size_t tile_index) const {
  const int ty = static_cast<int>(tile_index) / tiles_x_;
  const int tx = static_cast<int>(tile_index) % tiles_x_;
  float rho = 0;
  for (int ny = std::max(0, ty - 1); ny <= std::min(tiles_y_ - 1, ty + 1); ++ny)
    for (int nx = std::max(0, tx - 1); nx <= std::min(tiles_x_ - 1, tx + 1); ++nx)
      rho = std::max(rho, tiles_[static_cast<std::size_t>(ny) * tiles_x_ + nx].rho_max);
  return 1.2 * rho + 1e-3;
}

// Image speed [px/s] of static points seen through the tile with inverse depth up to rho_max:
// normalised image velocity on a 3x3 grid over the tile at every plan sample, for inverse depth 0
// and rho_max (|flow| is convex in the inverse depth), times the tile's magnification:
//   x' = rho (x vz - vx) + x y wx - (1 + x^2) wy + y wz
//   y' = rho (y vz - vy) + (1 + y^2) wx - x y wy - x wz
double EventCameraSim::static_scene_rate(const Tile& tile, const CameraMotion& motion,
                                         double rho_max) {
  double flow2 = 0;
  const double gx[3] = {tile.xmin, 0.5 * (tile.xmin + tile.xmax), tile.xmax};
  const double gy[3] = {tile.ymin, 0.5 * (tile.ymin + tile.ymax), tile.ymax};
  for (int k = 0; k < kPlanSamples; ++k) {
    const Eigen::Vector3d& w = motion.w_E[k];
    const Eigen::Vector3d& v = motion.v_E[k];
    for (double x : gx)
      for (double y : gy) {
        const double rx = x * y * w.x() - (1 + x * x) * w.y() + y * w.z();
        const double ry = (1 + y * y) * w.x() - x * y * w.y() - x * w.z();
        const double tx = x * v.z() - v.x(), ty = y * v.z() - v.y();
        flow2 = std::max(flow2, rx * rx + ry * ry);
        const double fx = rx + rho_max * tx, fy = ry + rho_max * ty;
        flow2 = std::max(flow2, fx * fx + fy * fy);
      }
  }
  return 1.15 * tile.scale_px * std::sqrt(flow2) + 1.0;
}

// The panels the tile renders: those whose box over the chunk meets the tile's bounds.
std::uint64_t EventCameraSim::panels_in_view(const Tile& tile,
                                             const std::vector<PanelBox>& panel_boxes) {
  std::uint64_t panels = 0;
  for (std::size_t i = 0; i < panel_boxes.size(); ++i) {
    const PanelBox& b = panel_boxes[i];
    if (b.all || (b.x1 >= tile.xmin && b.x0 <= tile.xmax && b.y1 >= tile.ymin && b.y0 <= tile.ymax))
      panels |= 1ull << i;
  }
  return panels;
}

// Whether the ball's silhouette, swept between two plan samples, may reach the tile's cone of
// directions (+2 px).
bool EventCameraSim::may_touch(const Tile& tile, const BallSweep& sweep) const {
  const double margin_rad = 2.0 / calib_.event_camera.fx;
  bool touches = sweep.everywhere;
  for (int k = 0; !touches && k + 1 < kPlanSamples; ++k) {
    const double reach = sweep.reach[k] + tile.radius_rad + margin_rad;
    touches = reach >= 3.14159 || tile.center_dir.dot(sweep.dir[k]) >= std::cos(reach);
  }
  return touches;
}

// Image speed [px/s] of the ball's surface seen through the tile.
double EventCameraSim::ball_rate(const Tile& tile, const BallSweep& sweep) {
  return tile.scale_px * sweep.pdot * std::sqrt(1.0 + tile.r_max * tile.r_max) / sweep.z_near;
}

EventCameraSim::Frame EventCameraSim::make_frame(TimeNs t) const {
  Frame f;
  const BodyState s = vehicle_->at(to_seconds(t));
  const Eigen::Matrix3d R_W_E = s.R_W_B * calib_.T_B_E.linear();
  const Eigen::Vector3d o = s.p_W + s.R_W_B * calib_.T_B_E.translation();
  for (int r = 0; r < 3; ++r) {
    f.o[r] = static_cast<float>(o[r]);
    for (int c = 0; c < 3; ++c) f.R[3 * r + c] = static_cast<float>(R_W_E(r, c));
  }
  f.ball_count = static_cast<int>(balls_->size());
  for (int b = 0; b < f.ball_count; ++b) {
    const BallState bs = (*balls_)[b].at(to_seconds(t));
    BallFrame& bf = f.ball[b];
    float len2 = 0;
    for (int r = 0; r < 3; ++r) {
      bf.oc[r] = static_cast<float>(bs.p_W[r]) - f.o[r];
      len2 += bf.oc[r] * bf.oc[r];
      for (int c = 0; c < 3; ++c) bf.R_O_W[3 * r + c] = static_cast<float>(bs.R_W_O(c, r));
    }
    bf.oc_len = std::sqrt(len2);
    bf.r = static_cast<float>((*balls_)[b].config().radius_m);
    bf.alpha = bf.oc_len > bf.r ? std::asin(bf.r / bf.oc_len) : 1.5707963f;
    bf.index = b;
    bf.exists = bs.exists;
  }
  return f;
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

/// kLanes neighbouring pixels of a tile row and their viewing rays in W (a short last group
/// repeats its last pixel).
struct EventCameraSim::PixelGroup {
  std::size_t p0;               ///< the first pixel in the per-pixel arrays
  int n;                        ///< pixels in the group (the rest repeat the last)
  lanes::vf px, py, footprint;  ///< see ray_x_, ray_y_, footprint_
  lanes::vf d[3];               ///< ray direction R_W_E (px, py, 1), in W
  lanes::vf inv_d[3];           ///< 1 / d, finite
};

/// What each pixel of a group sees: irradiance, depth and label (0 the static scene, else a ball).
struct EventCameraSim::GroupShading {
  lanes::vf intensity;
  lanes::vf z;
  std::int16_t label[lanes::kLanes] = {};
};

// The static scene first, kLanes pixels at a time, then the balls over it, pixel by pixel.
void EventCameraSim::render_tile(const Tile& tile, const Frame& f, float* log_i,
                                 std::int16_t* label, float& rho_max) const {
  float z_min = 1e30f;
  int j = 0;
  for (int y = tile.y0; y < tile.y1; ++y)
    for (int x = tile.x0; x < tile.x1; x += lanes::kLanes) {
      const PixelGroup g = pixel_group(tile, f, x, y);
      GroupShading s = shade_static_scene(tile, f, g);
      if (tile.balls) shade_balls(tile, f, g, s);
      const lanes::vf L = fast_log(s.intensity + dark_);
      for (int k = 0; k < g.n; ++k, ++j) {
        log_i[j] = L[k];
        label[j] = s.label[k];
        z_min = std::min(z_min, s.z[k]);
      }
    }
  rho_max = std::max(rho_max, 1.0f / z_min);
}

// The group's rays in W, with their finite inverses, for the scene's lane-parallel ray casts.
EventCameraSim::PixelGroup EventCameraSim::pixel_group(const Tile& tile, const Frame& f, int x,
                                                       int y) const {
  using namespace lanes;
  PixelGroup g;
  g.n = std::min(kLanes, tile.x1 - x);
  g.p0 = pixel(tile, x, y);
  if (g.n == kLanes) {
    g.px = load(&ray_x_[g.p0]), g.py = load(&ray_y_[g.p0]), g.footprint = load(&footprint_[g.p0]);
  } else {
    for (int k = 0; k < kLanes; ++k) {
      const std::size_t p = g.p0 + std::min(k, g.n - 1);
      g.px[k] = ray_x_[p], g.py[k] = ray_y_[p], g.footprint[k] = footprint_[p];
    }
  }
  const float* R = f.R;
  g.d[0] = R[0] * g.px + R[1] * g.py + R[2];
  g.d[1] = R[3] * g.px + R[4] * g.py + R[5];
  g.d[2] = R[6] * g.px + R[7] * g.py + R[8];
  for (int a = 0; a < 3; ++a) {
    const vf tiny = select(g.d[a] < 0, splat(-1e-20f), splat(1e-20f));
    g.inv_d[a] = 1.0f / select(abs(g.d[a]) < 1e-20f, tiny, g.d[a]);
  }
  return g;
}

// The nearest panel or room surface along each ray and its irradiance: lane-parallel where the
// whole group sees one surface.
EventCameraSim::GroupShading EventCameraSim::shade_static_scene(const Tile& tile, const Frame& f,
                                                                const PixelGroup& g) const {
  using namespace lanes;
  vf t;
  vi surf;
  scene_->cast_static_v(f.o, g.d, g.inv_d, tile.panels, t, surf);
  GroupShading s;
  if (all_equal(surf)) {
    s.intensity = scene_->static_radiance_v(surf[0], t, f.o, g.d, g.footprint);
  } else {  // the group straddles a surface boundary: shade lane by lane
    for (int k = 0; k < kLanes; ++k) {
      const float dk[3] = {g.d[0][k], g.d[1][k], g.d[2][k]};
      s.intensity[k] = scene_->static_radiance(RayHit{t[k], surf[k]}, f.o, dk, g.footprint[k]);
    }
  }
  s.z = t;
  return s;
}

// The tile's balls over the static scene, pixel by pixel, each along the pixel's unit ray.
void EventCameraSim::shade_balls(const Tile& tile, const Frame& f, const PixelGroup& g,
                                 GroupShading& s) const {
  for (int k = 0; k < g.n; ++k) {
    const float norm = std::sqrt(g.px[k] * g.px[k] + g.py[k] * g.py[k] + 1.0f);
    const float dir[3] = {g.d[0][k] / norm, g.d[1][k] / norm, g.d[2][k] / norm};
    float intensity = s.intensity[k], z = s.z[k];
    for (int b = 0; b < f.ball_count; ++b) {
      if (!(tile.balls & (1u << b)) || !f.ball[b].exists) continue;
      shade_ball(f.ball[b], dir, norm, pixel_angle_[g.p0 + k], intensity, z, s.label[k]);
    }
    s.intensity[k] = intensity, s.z[k] = z;
  }
}

// One ball seen along the unit ray `dir` of a pixel (|(x, y, 1)| = norm): where it is nearer than
// depth z, it covers the pixel by the share of the pixel inside its silhouette (anti-aliased over
// one pixel), shaded at the point the ray meets it.
void EventCameraSim::shade_ball(const BallFrame& ball, const float* dir, float norm,
                                float pixel_angle, float& intensity, float& z,
                                std::int16_t& label) const {
  const float along = dir[0] * ball.oc[0] + dir[1] * ball.oc[1] + dir[2] * ball.oc[2];
  if (along <= 0) return;
  const float perp2 = std::max(ball.oc_len * ball.oc_len - along * along, 0.0f);
  const float beta = std::atan2(std::sqrt(perp2), along);
  const float s = (beta - ball.alpha) / pixel_angle;  // signed distance to the silhouette [px]
  if (s >= 0.5f) return;
  const float coverage = std::min(1.0f, 0.5f - s);
  const float r2 = ball.r * ball.r;
  const float t_unit = perp2 < r2 ? along - std::sqrt(r2 - perp2) : along;
  const float z_ball = t_unit / norm;
  if (z_ball >= z) return;  // behind the static scene or a nearer ball
  float nrm[3];
  float nlen2 = 0;
  for (int a = 0; a < 3; ++a) {
    nrm[a] = t_unit * dir[a] - ball.oc[a];
    nlen2 += nrm[a] * nrm[a];
  }
  const float inv_nlen = 1.0f / std::sqrt(std::max(nlen2, 1e-20f));
  for (float& v : nrm) v *= inv_nlen;
  const float* Ro = ball.R_O_W;
  const float n_o[3] = {Ro[0] * nrm[0] + Ro[1] * nrm[1] + Ro[2] * nrm[2],
                        Ro[3] * nrm[0] + Ro[4] * nrm[1] + Ro[5] * nrm[2],
                        Ro[6] * nrm[0] + Ro[7] * nrm[1] + Ro[8] * nrm[2]};
  const float cos_inc = -(dir[0] * nrm[0] + dir[1] * nrm[1] + dir[2] * nrm[2]);
  const float ball_i = scene_->ball_radiance(ball.index, nrm, n_o, t_unit, pixel_angle, cos_inc);
  intensity = coverage * ball_i + (1 - coverage) * intensity;
  label = static_cast<std::int16_t>(scene_->ball_look(ball.index).id);
  z = z_ball;
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

void EventCameraSim::add_noise(Tile& tile, TimeNs t0, TimeNs t1) {
  if (tile.noise_next > t1) return;  // no pixel of the tile is due in this chunk
  const double on_fraction = config_->event_camera.background_on_fraction;
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

}  // namespace fdv::sim
