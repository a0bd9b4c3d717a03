// The renderer's event statistics against those recorded from the renderer of 2026-12-02
// (max_motion_px 0.5) on fixed throws: a faster renderer must give the same events per window,
// per pixel, the same noise share, the same ball events and the same timing (from the truth),
// within the tolerances below.
// Re-record (only when a change of the statistics is intended and explained in
// docs/SIMULATOR.md): FDV_WRITE_RENDERER_STATISTICS=1 sim_test
// --gtest_filter='RendererStatistics.*'
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fdv/core/sensor_data.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/simulator.h"

namespace fdv::sim {
namespace {

// Not from __FILE__: ccache's base_dir makes it relative to the build directory.
const std::filesystem::path kRecorded =
    std::filesystem::path(FDV_SOURCE_DIR) / "tests" / "sim" / "data" / "renderer_statistics.json";

constexpr TimeNs kWindowNs = 25'000'000;

/// The fixed throws: random_throw seeds of each kind of flight and texture (forward over panels,
/// forward over bare walls, hover), at one small resolution so that the test takes seconds; no
/// depth camera (it does not touch the events). Each throw's whole flight; the ball is released at
/// 0.2 s.
struct Case {
  const char* name;
  unsigned seed;
};
constexpr Case kCases[] = {{"forward_panels", 3}, {"forward_bare", 1}, {"hover_bare", 6}};

ScenarioConfig case_config(const Case& c, double max_motion_px) {
  ScenarioConfig config = make_preset("random_throw", c.seed);
  config.depth_camera.enabled = false;
  config.event_camera.max_motion_px = max_motion_px;
  set_event_resolution(config, 320, 240);
  return config;
}

struct Statistics {
  double events = 0, scene_events = 0, ball_events = 0;
  double on_share = 0, noise_share = 0;
  double pixels_with_events_share = 0;  ///< of the sensor's pixels
  /// The timing of the ball's events: the share of them whose pixel, at the event's own time, lies
  /// more than 0.5 px outside the ball's true silhouette, beyond its anti-aliased edge (a renderer
  /// that samples too coarsely in time puts the ball's events where it was or will be).
  double ball_events_misplaced_share = 0;
  double scene_sharpness = 0;                             ///< see scene_sharpness()
  std::vector<double> window_events, window_ball_events;  ///< per 25 ms window from t = 0
};

/// Each pixel's viewing ray (x, y, 1) in E, undistorted, row-major: made once per throw.
std::vector<Eigen::Vector3d> pixel_rays(const PinholeCamera& cam) {
  std::vector<Eigen::Vector3d> rays;
  rays.reserve(static_cast<std::size_t>(cam.width) * cam.height);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const Eigen::Vector2d xn = cam.pixel_to_normalized({x, y});
      rays.emplace_back(xn.x(), xn.y(), 1.0);
    }
  return rays;
}

const Eigen::Vector3d& ray_of(const std::vector<Eigen::Vector3d>& rays, int width, const Event& e) {
  return rays[static_cast<std::size_t>(e.y) * width + e.x];
}

/// How far [px] the ray of event e's pixel passes outside the silhouette of the ball `ball` at the
/// event's time (≤ 0 inside), from the truth: the ball's centre and the body's pose then.
double outside_silhouette_px(const Calibration& calib, const std::vector<Eigen::Vector3d>& rays,
                             const MemorySink& sink, const BallConfig& ball, const Event& e) {
  const PinholeCamera& cam = calib.event_camera;
  // The ball's centre at e.t, linear between the 1 kHz truth samples.
  auto after = std::lower_bound(sink.objects.begin(), sink.objects.end(), e.t,
                                [&](const ObjectState& o, TimeNs t) {
                                  return o.id < ball.id || (o.id == ball.id && o.t < t);
                                });
  if (after == sink.objects.end() || after->id != ball.id || after == sink.objects.begin() ||
      std::prev(after)->id != ball.id)
    return 0;
  const ObjectState& b = *after;
  const ObjectState& a = *std::prev(after);
  const double f =
      b.t > a.t ? static_cast<double>(e.t - a.t) / static_cast<double>(b.t - a.t) : 0.0;
  const Eigen::Vector3d p_W = a.p_W + f * (b.p_W - a.p_W);
  const OdometrySample body = interpolate_odometry(sink.body, e.t);
  const Eigen::Isometry3d T_W_E = Eigen::Translation3d(body.p_W_B) * body.q_W_B * calib.T_B_E;
  const Eigen::Vector3d centre_E = T_W_E.inverse() * p_W;
  const Eigen::Vector3d ray = ray_of(rays, cam.width, e).normalized();
  const double alpha = std::asin(std::min(1.0, ball.radius_m / centre_E.norm()));
  const double beta = std::acos(std::clamp(ray.dot(centre_E.normalized()), -1.0, 1.0));
  return (beta - alpha) * cam.fx;
}

/// The timing of the scene's events: each window's scene events moved by the camera's true
/// rotation to the window's start (the image of warped events; translation is left, the same for
/// any renderer) and counted per pixel; the sharpness is Σ c² / Σ c, the mean count of an event's
/// pixel, averaged over windows with ≥ 1000 scene events. Timing errors blur it.
double scene_sharpness(const Calibration& calib, const std::vector<Eigen::Vector3d>& rays,
                       const MemorySink& sink) {
  const PinholeCamera& cam = calib.event_camera;
  const int width = cam.width, height = cam.height;
  const Eigen::Matrix3d R_B_E = calib.T_B_E.linear();
  std::vector<float> image(static_cast<std::size_t>(width) * height);
  double sum = 0;
  int windows = 0;
  std::size_t i = 0;
  while (i < sink.events.size()) {
    const TimeNs start = sink.events[i].t / kWindowNs * kWindowNs;
    const Eigen::Matrix3d R_E0_W =
        (interpolate_odometry(sink.body, start).q_W_B.toRotationMatrix() * R_B_E).transpose();
    std::fill(image.begin(), image.end(), 0.0f);
    double events = 0;
    for (; i < sink.events.size() && sink.events[i].t < start + kWindowNs; ++i) {
      const Event& e = sink.events[i];
      if (sink.labels[i] != 0) continue;
      const Eigen::Matrix3d R_W_E =
          interpolate_odometry(sink.body, e.t).q_W_B.toRotationMatrix() * R_B_E;
      const Eigen::Vector3d b = R_E0_W * R_W_E * ray_of(rays, width, e);
      if (b.z() <= 0) continue;
      const long u = std::lround(cam.fx * b.x() / b.z() + cam.cx);
      const long v = std::lround(cam.fy * b.y() / b.z() + cam.cy);
      if (u < 0 || v < 0 || u >= width || v >= height) continue;
      image[static_cast<std::size_t>(v) * width + u] += 1.0f;
      events += 1;
    }
    if (events < 1000) continue;
    double squares = 0;
    for (float c : image) squares += static_cast<double>(c) * c;
    sum += squares / events;
    ++windows;
  }
  return windows > 0 ? sum / windows : 0.0;
}

Statistics measure(const ScenarioConfig& config) {
  Simulator sim(config);
  MemorySink sink;
  sim.run(sink);
  // The truth by ball, then time (lower_bound above).
  std::sort(sink.objects.begin(), sink.objects.end(),
            [](const ObjectState& a, const ObjectState& b) {
              return a.id != b.id ? a.id < b.id : a.t < b.t;
            });
  const Calibration& calib = sim.calibration();
  const std::vector<Eigen::Vector3d> rays = pixel_rays(calib.event_camera);
  const int width = config.event_camera.width, height = config.event_camera.height;
  Statistics s;
  std::vector<char> fired(static_cast<std::size_t>(width) * height, 0);
  const auto windows = static_cast<std::size_t>(std::ceil(config.duration_s * 1e9 / kWindowNs));
  s.window_events.assign(windows, 0);
  s.window_ball_events.assign(windows, 0);
  double on = 0, noise = 0, misplaced = 0;
  for (std::size_t i = 0; i < sink.events.size(); ++i) {
    const Event& e = sink.events[i];
    const std::int16_t label = sink.labels[i];
    const auto w = std::min(windows - 1, static_cast<std::size_t>(e.t / kWindowNs));
    s.window_events[w] += 1;
    if (label > 0) {
      s.window_ball_events[w] += 1, s.ball_events += 1;
      for (const BallConfig& ball : config.balls)
        if (ball.id == label) misplaced += outside_silhouette_px(calib, rays, sink, ball, e) > 0.5;
    }
    if (label == 0) s.scene_events += 1;
    noise += label < 0;
    on += e.polarity;
    fired[static_cast<std::size_t>(e.y) * width + e.x] = 1;
  }
  s.events = static_cast<double>(sink.events.size());
  s.on_share = on / std::max(1.0, s.events);
  s.noise_share = noise / std::max(1.0, s.events);
  s.ball_events_misplaced_share = misplaced / std::max(1.0, s.ball_events);
  s.scene_sharpness = scene_sharpness(calib, rays, sink);
  s.pixels_with_events_share = static_cast<double>(std::count(fired.begin(), fired.end(), 1)) /
                               static_cast<double>(fired.size());
  return s;
}

nlohmann::json to_json(const Statistics& s) {
  return {{"events", s.events},
          {"scene_events", s.scene_events},
          {"ball_events", s.ball_events},
          {"on_share", s.on_share},
          {"noise_share", s.noise_share},
          {"pixels_with_events_share", s.pixels_with_events_share},
          {"ball_events_misplaced_share", s.ball_events_misplaced_share},
          {"scene_sharpness", s.scene_sharpness},
          {"window_events", s.window_events},
          {"window_ball_events", s.window_ball_events}};
}

/// What differs beyond the tolerances, one line each (empty: the same statistics). Measured on
/// these throws against the record: sampling every 1 px instead of 0.5 moves the totals by < 2.3 %
/// and single windows by < 4.1 %, but the scene's sharpness by +4.4 % (forward_panels), and that
/// step raised the pipeline's false detections on hovering 1280x720 throws (docs/SIMULATOR.md,
/// "The sampling step"): it fails here. At 4 px, 0.96 % of the ball's events are misplaced
/// (0.05 % recorded).
std::vector<std::string> differences(const Statistics& now, const nlohmann::json& recorded) {
  std::vector<std::string> out;
  auto relative = [&](const char* key, double value, double tolerance) {
    const double ref = recorded.at(key).get<double>();
    if (std::abs(value - ref) > tolerance * std::max(ref, 1.0))
      out.push_back(std::string(key) + ": " + std::to_string(value) + " against " +
                    std::to_string(ref));
  };
  auto absolute = [&](const char* key, double value, double tolerance) {
    const double ref = recorded.at(key).get<double>();
    if (std::abs(value - ref) > tolerance)
      out.push_back(std::string(key) + ": " + std::to_string(value) + " against " +
                    std::to_string(ref));
  };
  absolute("ball_events_misplaced_share", now.ball_events_misplaced_share, 0.002);
  relative("scene_sharpness", now.scene_sharpness, 0.03);
  relative("events", now.events, 0.03);
  relative("scene_events", now.scene_events, 0.03);
  relative("ball_events", now.ball_events, 0.03);
  absolute("on_share", now.on_share, 0.01);
  absolute("noise_share", now.noise_share, 0.005);
  absolute("pixels_with_events_share", now.pixels_with_events_share, 0.01);
  // Per window: within 6 % of the recorded count, or of a floor where the count is small.
  auto per_window = [&](const char* key, const std::vector<double>& values, double floor) {
    const auto ref = recorded.at(key).get<std::vector<double>>();
    if (ref.size() != values.size()) {
      out.push_back(std::string(key) + ": " + std::to_string(values.size()) + " windows against " +
                    std::to_string(ref.size()));
      return;
    }
    for (std::size_t w = 0; w < ref.size(); ++w)
      if (std::abs(values[w] - ref[w]) > 0.06 * std::max(ref[w], floor))
        out.push_back(std::string(key) + "[" + std::to_string(w) +
                      "]: " + std::to_string(values[w]) + " against " + std::to_string(ref[w]));
  };
  per_window("window_events", now.window_events, 1000);
  per_window("window_ball_events", now.window_ball_events, 300);
  return out;
}

nlohmann::json read_recorded() {
  std::ifstream in(kRecorded);
  EXPECT_TRUE(in.good()) << kRecorded;
  return nlohmann::json::parse(in);
}

std::string joined(const std::vector<std::string>& lines) {
  std::ostringstream s;
  for (const std::string& l : lines) s << l << "\n";
  return s.str();
}

TEST(RendererStatistics, TheDefaultRendererKeepsTheRecordedStatistics) {
#ifdef FDV_TEST_SANITIZED
  GTEST_SKIP() << "three throws rendered: too slow instrumented";
#endif
  const double max_motion_px = ScenarioConfig{}.event_camera.max_motion_px;
  if (std::getenv("FDV_WRITE_RENDERER_STATISTICS") != nullptr) {
    nlohmann::json all;
    for (const Case& c : kCases) all[c.name] = to_json(measure(case_config(c, max_motion_px)));
    std::filesystem::create_directories(kRecorded.parent_path());
    std::ofstream(kRecorded) << all.dump(1) << "\n";
    GTEST_SKIP() << "recorded " << kRecorded;
  }
  const nlohmann::json recorded = read_recorded();
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.name);
    const Statistics now = measure(case_config(c, max_motion_px));
    EXPECT_GT(now.ball_events, 1000) << "the ball must be in flight and in view";
    EXPECT_EQ(joined(differences(now, recorded.at(c.name))), "");
  }
}

TEST(RendererStatistics, ARendererThatMissesMotionIsCaught) {
#ifdef FDV_TEST_SANITIZED
  GTEST_SKIP() << "a throw rendered: too slow instrumented";
#endif
  // Sampling every 8 px of motion: the ball's and the scene's fast edges are undersampled.
  const nlohmann::json recorded = read_recorded();
  const Case& c = kCases[0];
  EXPECT_NE(joined(differences(measure(case_config(c, 8.0)), recorded.at(c.name))), "");
}

}  // namespace
}  // namespace fdv::sim
