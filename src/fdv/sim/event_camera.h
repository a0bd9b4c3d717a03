#pragma once
/// The event-camera engine: renders the scene per tile at a per-tile adaptive rate and turns
/// log-intensity changes into events, adds background activity and hot pixels.
///
///   EventCameraSim cam(config, calib, scene, vehicle, balls);
///   cam.initialize(0);                          // first render: references = current image
///   cam.run_chunk(t0, t1, events, labels);      // events in (t0, t1], sorted, with labels
///
/// Adaptive sampling: every chunk, each tile gets its own number of equally spaced samples so
/// that no point of the scene moves more than `max_motion_px` in the image between two
/// samples. The bound for a tile combines the camera's largest angular and linear velocity over
/// the chunk (from the exact trajectory), the tile's field-of-view extent, the nearest depth
/// seen in the tile and its neighbours at the last sample (+20 %), the lens's largest local
/// magnification, and, for tiles the swept silhouette of a ball may touch, the ball's speed
/// relative to the camera, its spin and its nearest depth.
///
/// Determinism: tiles are independent (per-pixel state, per-tile random streams seeded from
/// (seed, tile)), the output of a chunk is sorted by (t, y, x, polarity, label), so the result
/// is byte-identical for any thread count. Not thread-safe itself (it uses the pool's threads).
///
/// Forking (Simulator's fork): a copy of an engine's whole state, pixel memories and random streams
/// included, reading its own copies of the scene, the vehicle and the balls, renders on exactly as
/// the original would.
#include <cstdint>
#include <span>
#include <vector>

#include "fdv/core/calibration.h"
#include "fdv/core/sensor_data.h"
#include "fdv/core/thread_pool.h"
#include "fdv/sim/event_labels.h"
#include "fdv/sim/pixel_model.h"
#include "fdv/sim/random.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/scene.h"
#include "fdv/sim/trajectory.h"
#include "fdv/sim/vehicle_dynamics.h"

namespace fdv::sim {

/// Counters of the engine's work, for the summary and the benchmark.
struct EventCameraStats {
  std::uint64_t pixel_samples = 0;  ///< pixels rendered (all tiles, all samples)
  std::uint64_t tile_samples = 0;   ///< tile renders
  int max_tile_steps = 0;           ///< largest number of samples of one tile in one chunk
  std::uint64_t capped_tiles = 0;   ///< tile-chunks that hit max_steps_per_chunk
};

class EventCameraSim {
 public:
  EventCameraSim(const ScenarioConfig& config, const Calibration& calib, const Scene& scene,
                 const FlownVehicle& vehicle, const std::vector<BallTrajectory>& balls,
                 ThreadPool& pool);

  /// `state`'s engine as it is now, reading `config`, `scene`, `vehicle`, `balls` (equal to the
  /// ones `state` reads) and rendering on `pool` instead.
  EventCameraSim(const EventCameraSim& state, const ScenarioConfig& config, const Scene& scene,
                 const FlownVehicle& vehicle, const std::vector<BallTrajectory>& balls,
                 ThreadPool& pool);

  /// Renders every pixel at t0 and sets the references (no events).
  void initialize(TimeNs t0);
  /// Simulates (t0, t1] and appends its events, sorted, with one label each.
  void run_chunk(TimeNs t0, TimeNs t1, std::vector<Event>& events,
                 std::vector<std::int16_t>& labels);
  const EventCameraStats& stats() const { return stats_; }

 private:
  EventCameraSim(const EventCameraSim&) = default;  // only through the fork above

  struct LabeledEvent {
    TimeNs t;
    std::uint16_t x, y;
    std::uint8_t on;
    std::int16_t label;
  };
  static constexpr int kMaxBalls = 8;
  struct BallFrame {
    float oc[3];     ///< centre relative to the camera centre, in W
    float oc_len;    ///< |oc|
    float r;         ///< radius [m]
    float alpha;     ///< angular radius of the silhouette [rad]
    float R_O_W[9];  ///< W -> ball frame, row-major
    int index;       ///< into balls / scene looks
    bool exists;     ///< false before release for a hidden ball
  };
  struct Frame {
    float R[9];  ///< R_W_E row-major
    float o[3];  ///< camera centre in W
    int ball_count = 0;
    BallFrame ball[kMaxBalls];
  };
  struct alignas(64) Tile {
    int x0, y0, x1, y1;
    std::size_t offset = 0;  ///< first pixel of the tile in the per-pixel arrays
    float r_max = 0;         ///< largest normalised radius (+ margin)
    float xmin = 0, xmax = 0, ymin = 0, ymax = 0;  ///< normalised bounds (+ margin)
    float scale_px = 0;          ///< largest pixels per normalised unit in the tile
    Eigen::Vector3d center_dir;  ///< unit ray of the tile centre (E)
    double radius_rad = 0;       ///< largest angle between center_dir and a pixel ray (+1.5 px)
    float rho_max = 0;           ///< largest inverse depth at the last sample [1/m]
    TimeNs noise_next = 0;       ///< earliest noise event of the tile's pixels
    Rng noise_rng, jitter_rng;
    std::vector<LabeledEvent> events;
    // per chunk plan
    int steps = 1;
    bool capped = false;
    std::uint64_t panels = 0;
    std::uint32_t balls = 0;
  };

  /// Index of pixel (x, y) of `tile` in the per-pixel arrays (tile-major, row-major inside).
  static std::size_t pixel(const Tile& tile, int x, int y) {
    return tile.offset + static_cast<std::size_t>(y - tile.y0) * (tile.x1 - tile.x0) +
           (x - tile.x0);
  }

  // Construction: the steps of the constructor, in this order.
  struct LensGrid;
  void lay_out_tiles();
  LensGrid trace_pixel_rays() const;
  void measure_lens_scale(LensGrid& lens) const;
  void store_pixel_geometry(const Tile& tile, const LensGrid& lens);
  void bound_tile(Tile& tile, const LensGrid& lens) const;
  void aim_tile(Tile& tile) const;
  void draw_pixel_constants(const Tile& tile, std::size_t tile_index);

  /// Each tile's number of samples for the chunk (t0, t1]: the steps of plan_chunk, in this order.
  void plan_chunk(TimeNs t0, TimeNs t1);
  struct CameraMotion;
  struct PanelBox;
  struct BallSweep;
  CameraMotion sample_camera_motion(TimeNs t0, TimeNs t1) const;
  std::vector<PanelBox> bound_panels(const CameraMotion& motion) const;
  std::vector<BallSweep> sweep_balls(const CameraMotion& motion) const;
  void plan_tile(std::size_t tile_index, const CameraMotion& motion,
                 const std::vector<PanelBox>& panel_boxes, const std::vector<BallSweep>& sweeps,
                 double dt_s);
  double nearest_inverse_depth(std::size_t tile_index) const;
  static double static_scene_rate(const Tile& tile, const CameraMotion& motion, double rho_max);
  static std::uint64_t panels_in_view(const Tile& tile, const std::vector<PanelBox>& panel_boxes);
  bool may_touch(const Tile& tile, const BallSweep& sweep) const;
  static double ball_rate(const Tile& tile, const BallSweep& sweep);

  Frame make_frame(TimeNs t) const;
  void process_tile(Tile& tile, TimeNs t0, TimeNs t1);
  /// Renders `tile` at frame `f` into (log intensity, label) per pixel, tile row-major, and
  /// raises `rho_max` to the largest inverse depth seen: the steps of render_tile, in this order.
  void render_tile(const Tile& tile, const Frame& f, float* log_i, std::int16_t* label,
                   float& rho_max) const;
  struct PixelGroup;
  struct GroupShading;
  PixelGroup pixel_group(const Tile& tile, const Frame& f, int x, int y) const;
  GroupShading shade_static_scene(const Tile& tile, const Frame& f, const PixelGroup& g) const;
  void shade_balls(const Tile& tile, const Frame& f, const PixelGroup& g, GroupShading& s) const;
  void shade_ball(const BallFrame& ball, const float* dir, float norm, float pixel_angle,
                  float& intensity, float& z, std::int16_t& label) const;

  void push_event(Tile& tile, double t_ns, int x, int y, bool on, std::int16_t label, TimeNs t0,
                  TimeNs t1);
  void add_noise(Tile& tile, TimeNs t0, TimeNs t1);

  // What the engine reads, not owns (pointers, so that a fork can read its own copies).
  const ScenarioConfig* config_;
  const Scene* scene_;
  const FlownVehicle* vehicle_;
  const std::vector<BallTrajectory>* balls_;
  Calibration calib_;
  int width_, height_;
  TimeNs refractory_ns_, resolution_ns_;
  double jitter_ns_;
  float dark_;
  ThreadPool* pool_;
  // per pixel, tile-major (see pixel())
  std::vector<float> ray_x_, ray_y_;  ///< normalised undistorted coordinates of the pixel centre
  std::vector<float> footprint_;      ///< pixel angle · |d| (see Scene::static_radiance)
  std::vector<float> pixel_angle_;    ///< angular size of the pixel [rad]
  std::vector<float> log_i_;
  std::vector<std::int16_t> label_;
  std::vector<PixelMemory> memory_;
  std::vector<PixelThresholds> threshold_;
  std::vector<TimeNs> noise_next_;
  std::vector<float> noise_interval_ns_;  ///< mean time between noise events (0 = never)
  std::vector<std::uint8_t> hot_;
  std::vector<Tile> tiles_;
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<LabeledEvent> merged_;
  std::vector<std::size_t> order_;  ///< tiles, most samples first (for load balance)
  /// Frames at t0 + (t1 - t0) k / n of the current chunk, for n <= kCachedSteps (most tiles).
  static constexpr int kCachedSteps = 8;
  std::vector<Frame> frame_cache_;  ///< index n (n - 1) / 2 + k - 1
  EventCameraStats stats_;
};

}  // namespace fdv::sim
