// The random throws of the dodge evaluation: the drawn parameters, the geometry of the configured
// throw (checked on the simulator's own trajectories, no rendering), and the round trip through a
// dataset.
#include "fdv/sim/random_throw.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <set>
#include <string>

#include "fdv/core/error.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/geometry.h"
#include "fdv/sim/simulator.h"
#include "fdv/sim/trajectory.h"
#include "test_support.h"

namespace fdv::sim {
namespace {

/// Closest approach of the configured ball to the body origin, by brute force on the
/// simulator's own trajectories: a 1 ms scan over the whole scene, then golden-section search
/// in the bracket around the best sample (the distance is smooth and unimodal there).
struct Approach {
  double t_s = 0, distance_m = 0;
};
/// Scanned to 0.5 s past the scene's end: a scene that ends when the ball hits the camera
/// stops before the closest approach (the trajectories go on).
Approach closest_approach(const ScenarioConfig& c) {
  const double end_s = c.duration_s + 0.5;
  const VehicleTrajectory vehicle(c.vehicle, c.seed, c.gravity_W_m_s2);
  const BallTrajectory ball(c.balls.at(0), vehicle, c.gravity_W_m_s2, end_s);
  const auto distance = [&](double t) { return (ball.at(t).p_W - vehicle.at(t).p_W).norm(); };
  Approach best{0, distance(0)};
  for (double t = 0.001; t <= end_s; t += 0.001)
    if (const double d = distance(t); d < best.distance_m) best = {t, d};
  double a = best.t_s - 0.001, b = best.t_s + 0.001;
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int i = 0; i < 60; ++i) {
    const double x1 = b - r * (b - a), x2 = a + r * (b - a);
    if (distance(x1) < distance(x2))
      b = x2;
    else
      a = x1;
  }
  const double t = 0.5 * (a + b);
  return {t, distance(t)};
}

/// The ball centre's raw pixel at time t (nullopt when behind the camera or outside the lens).
std::optional<Eigen::Vector2d> ball_pixel(const ScenarioConfig& c, double t) {
  const VehicleTrajectory vehicle(c.vehicle, c.seed, c.gravity_W_m_s2);
  const BallTrajectory ball(c.balls.at(0), vehicle, c.gravity_W_m_s2, c.duration_s);
  const Calibration calib = c.calibration();
  const BodyState b = vehicle.at(t);
  const Eigen::Vector3d cam_W = b.p_W + b.R_W_B * calib.T_B_E.translation();
  const Eigen::Vector3d X = (b.R_W_B * calib.T_B_E.linear()).transpose() * (ball.at(t).p_W - cam_W);
  if (X.z() <= 0 || X.head<2>().norm() / X.z() > lens_monotonic_radius(calib.event_camera))
    return std::nullopt;
  return calib.event_camera.project(X);
}

TEST(RandomThrow, ParametersStayInTheirRanges) {
  const std::set<std::string> resolutions{"640x480", "346x260", "1280x720"};
  for (std::uint64_t seed = 1; seed <= 400; ++seed) {
    const RandomThrowParameters p = sample_random_throw(seed);
    SCOPED_TRACE(seed);
    EXPECT_EQ(p.seed, seed);
    EXPECT_GE(p.speed_m_s, 5.0);
    EXPECT_LT(p.speed_m_s, 15.0);
    EXPECT_GE(p.distance_m, 4.0);
    EXPECT_LT(p.distance_m, 12.0);
    EXPECT_GE(p.miss_distance_m, 0.0);
    EXPECT_LT(p.miss_distance_m, 1.5);
    EXPECT_EQ(p.threat, p.miss_distance_m < 0.5);
    EXPECT_GE(p.offset_direction_deg, 0.0);
    EXPECT_LT(p.offset_direction_deg, 360.0);
    EXPECT_GE(p.diameter_m, 0.05);
    EXPECT_LT(p.diameter_m, 0.20);
    if (p.vehicle_motion == "forward") {
      EXPECT_GE(p.vehicle_speed_m_s, 0.0);
      EXPECT_LT(p.vehicle_speed_m_s, 3.0);
    } else {
      EXPECT_EQ(p.vehicle_motion, "hover");
      EXPECT_EQ(p.vehicle_speed_m_s, 0.0);
    }
    if (p.lighting == "dim") {
      EXPECT_GE(p.illuminance_lux, 8.0);
      EXPECT_LT(p.illuminance_lux, 10.0);
    } else {
      EXPECT_EQ(p.lighting, "bright");
      EXPECT_GE(p.illuminance_lux, 240.0);
      EXPECT_LT(p.illuminance_lux, 1100.0);
    }
    EXPECT_TRUE(p.texture == "panels" || p.texture == "bare") << p.texture;
    EXPECT_EQ(resolutions.count(p.resolution), 1u) << p.resolution;
    EXPECT_EQ(p.resolution, std::to_string(p.width) + "x" + std::to_string(p.height));
    EXPECT_DOUBLE_EQ(p.release_t_s, 0.2);
    EXPECT_GE(p.draws, 1);
    if (p.contact_t_s > 0) {  // hits the camera: ends there
      EXPECT_GT(p.contact_t_s, p.release_t_s);
      EXPECT_LE(p.contact_t_s, p.closest_approach_t_s);
      EXPECT_LE(p.duration_s, p.contact_t_s);
      EXPECT_GT(p.duration_s, p.contact_t_s - 0.005);
    } else {
      EXPECT_GE(p.duration_s, p.closest_approach_t_s + 0.3);
      EXPECT_LT(p.duration_s, p.closest_approach_t_s + 0.3 + 0.05 + 1e-9);
    }

    // The configuration carries them: ball size, sensor, light, vehicle, release state.
    const ScenarioConfig c = make_preset("random_throw", seed);
    ASSERT_EQ(c.validate(), "");
    ASSERT_EQ(c.balls.size(), 1u);
    EXPECT_DOUBLE_EQ(2 * c.balls[0].radius_m, p.diameter_m);
    EXPECT_EQ(c.event_camera.width, p.width);
    EXPECT_EQ(c.event_camera.height, p.height);
    EXPECT_DOUBLE_EQ(c.scene.illuminance_lux, p.illuminance_lux);
    EXPECT_EQ(c.scene.panels.empty(), p.texture == "bare");
    EXPECT_EQ(c.vehicle.motion,
              p.vehicle_motion == "forward" ? MotionKind::kForward : MotionKind::kHover);
    EXPECT_DOUBLE_EQ(c.vehicle.speed_m_s, p.vehicle_speed_m_s);
    EXPECT_GT(c.vehicle.vibration_angle_deg, 0.0);  // the presets' vibration
    EXPECT_DOUBLE_EQ(c.duration_s, p.duration_s);

    // Released `distance` from the body origin; chord speed = straight flight / flight time.
    const VehicleTrajectory vehicle(c.vehicle, c.seed, c.gravity_W_m_s2);
    const BallTrajectory ball(c.balls[0], vehicle, c.gravity_W_m_s2, c.duration_s);
    EXPECT_NEAR((ball.at(p.release_t_s).p_W - vehicle.at(p.release_t_s).p_W).norm(), p.distance_m,
                1e-9);
    const double flight_s = p.closest_approach_t_s - p.release_t_s;
    EXPECT_NEAR(
        (ball.at(p.closest_approach_t_s).p_W - ball.at(p.release_t_s).p_W).norm() / flight_s,
        p.speed_m_s, 1e-6);
  }
}

TEST(RandomThrow, HalfTheThrowsAreThreats) {
  // Binomial(400, p): 4σ bands, so a correct sampler fails with probability < 1e-4 per check.
  const int n = 400;
  int threats = 0, forward = 0, dim = 0, panels = 0, hires = 0;
  double threat_miss_sum = 0;
  for (std::uint64_t seed = 1; seed <= n; ++seed) {
    const RandomThrowParameters p = sample_random_throw(seed);
    threats += p.threat;
    if (p.threat) threat_miss_sum += p.miss_distance_m;
    forward += p.vehicle_motion == "forward";
    dim += p.lighting == "dim";
    panels += p.texture == "panels";
    hires += p.resolution == "1280x720";
  }
  const auto band = [&](double p) { return 4.0 * std::sqrt(n * p * (1 - p)); };
  EXPECT_NEAR(threats, n * 0.5, band(0.5));
  EXPECT_NEAR(forward, n * 0.5, band(0.5));
  EXPECT_NEAR(panels, n * 0.5, band(0.5));
  EXPECT_NEAR(dim, n * 0.25, band(0.25));
  EXPECT_NEAR(hires, n * 0.1, band(0.1));
  // Threat misses uniform in [0, 0.5): mean 0.25, σ of the mean 0.144 / sqrt(~200).
  EXPECT_NEAR(threat_miss_sum / threats, 0.25, 4 * 0.144 / std::sqrt(threats));
}

TEST(RandomThrow, RealisedMissIsTheDrawnOne) {
  // The simulator's own ball and vehicle trajectories (vibration and wander included), with no
  // manoeuvre, pass at the drawn miss distance, at the time the sampler says.
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    const RandomThrowParameters p = sample_random_throw(seed);
    const Approach a = closest_approach(make_preset("random_throw", seed));
    EXPECT_NEAR(a.distance_m, p.miss_distance_m, 0.01) << "seed " << seed;
    EXPECT_NEAR(a.distance_m, p.miss_distance_m, 1e-4) << "seed " << seed << ": solver precision";
    EXPECT_NEAR(a.t_s, p.closest_approach_t_s, 1e-3) << "seed " << seed;
  }
}

TEST(RandomThrow, SceneEndsWhenTheBallHitsTheCamera) {
  // contact_t_s: the ball's surface 0.1 m from the camera centre, first reached then; never
  // reached by the others (1 ms scan over the whole flight on the simulator's trajectories).
  int hits = 0;
  for (std::uint64_t seed = 1; seed <= 100; ++seed) {
    SCOPED_TRACE(seed);
    const RandomThrowParameters p = sample_random_throw(seed);
    const ScenarioConfig c = make_preset("random_throw", seed);
    const double end_s = p.closest_approach_t_s + 0.3;
    const VehicleTrajectory vehicle(c.vehicle, c.seed, c.gravity_W_m_s2);
    const BallTrajectory ball(c.balls[0], vehicle, c.gravity_W_m_s2, end_s);
    const auto clearance = [&](double t) {
      const BodyState b = vehicle.at(t);
      return (ball.at(t).p_W - (b.p_W + b.R_W_B * c.event_camera.position_B_m)).norm() -
             c.balls[0].radius_m;
    };
    double first = 0;
    for (double t = p.release_t_s; t <= end_s && first == 0; t += 0.001)
      if (clearance(t) <= 0.1) first = t;
    if (p.contact_t_s > 0) {
      ++hits;
      EXPECT_NEAR(clearance(p.contact_t_s), 0.1, 1e-3);
      EXPECT_NEAR(first, p.contact_t_s, 0.0011);
      EXPECT_LE(c.duration_s, p.contact_t_s);
    } else {
      EXPECT_EQ(first, 0.0) << "reaches the camera at " << first << " s unnoticed";
    }
  }
  EXPECT_GT(hits, 0) << "some threats hit the camera";
}

TEST(RandomThrow, BallStartsInViewAndComesAtTheVehicle) {
  for (std::uint64_t seed = 1; seed <= 100; ++seed) {
    SCOPED_TRACE(seed);
    const RandomThrowParameters p = sample_random_throw(seed);
    const ScenarioConfig c = make_preset("random_throw", seed);
    const auto px = ball_pixel(c, p.release_t_s);
    ASSERT_TRUE(px.has_value());
    EXPECT_TRUE(c.calibration().event_camera.in_image(*px)) << px->transpose();
    // From the front hemisphere, towards the vehicle.
    const VehicleTrajectory vehicle(c.vehicle, c.seed, c.gravity_W_m_s2);
    const BodyState b = vehicle.at(p.release_t_s);
    const Eigen::Vector3d to_ball = p.origin_W_m - b.p_W;
    EXPECT_GT((b.R_W_B.transpose() * to_ball).x(), 0.0);
    EXPECT_LT((p.velocity_W_m_s - b.v_W).dot(to_ball), 0.0);
    // In view for most of the flight (release to closest approach), counted here at 50 instants.
    EXPECT_GE(p.in_view_fraction, 0.5);
    EXPECT_LE(p.in_view_fraction, 1.0);
    int in_view = 0;
    for (int i = 0; i < 50; ++i) {
      const double t = p.release_t_s + (i + 0.5) / 50 * (p.closest_approach_t_s - p.release_t_s);
      const auto at = ball_pixel(c, t);
      in_view += at && c.calibration().event_camera.in_image(*at);
    }
    EXPECT_NEAR(in_view / 50.0, p.in_view_fraction, 0.05);
  }
}

TEST(RandomThrow, SameSeedSameScene) {
  EXPECT_EQ(to_yaml(make_preset("random_throw", 5)), to_yaml(make_preset("random_throw", 5)));
  EXPECT_EQ(to_json(sample_random_throw(5)), to_json(sample_random_throw(5)));
  EXPECT_NE(to_json(sample_random_throw(5)), to_json(sample_random_throw(6)));
  EXPECT_EQ(to_yaml(make_preset("random_throw", 9)),
            to_yaml(random_throw_config(sample_random_throw(9))));
}

TEST(RandomThrow, JsonRoundTripAndErrors) {
  const RandomThrowParameters p = sample_random_throw(11);
  const nlohmann::json j = to_json(p);
  EXPECT_EQ(j.at("miss_distance_m").get<double>(), p.miss_distance_m);
  EXPECT_EQ(to_json(random_throw_from_json(j, "row")), j);
  nlohmann::json bad = j;
  bad["speed_m_s"] = "fast";
  try {
    random_throw_from_json(bad, "rows.json");
    FAIL() << "a string speed must be rejected";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "rows.json");
    EXPECT_EQ(e.where(), "key speed_m_s");
  }
  bad = j;
  bad.erase("seed");
  EXPECT_THROW(random_throw_from_json(bad, "rows.json"), InputError);
}

TEST(RandomThrow, ParametersRoundTripThroughTheDataset) {
  // The dataset writer's path (DatasetSink::finish with the simulator's manifest), no events.
  const std::string dir = fdv::test::scratch_dir("random_throw_dataset");
  const ScenarioConfig c = make_preset("random_throw", 13);
  const Simulator sim(c);
  {
    DatasetSink sink(dir, sim.calibration());
    sink.finish(sim.manifest_yaml());
  }
  const auto read = read_random_throw(dir);
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(to_json(*read), to_json(sample_random_throw(13)));

  // Another scenario, or the throw's scene changed by an override: no section.
  EXPECT_FALSE(random_throw_manifest(make_preset("hover_headon", 1)).has_value());
  ScenarioConfig changed = c;
  changed.duration_s += 0.1;
  EXPECT_FALSE(random_throw_manifest(changed).has_value());
  ScenarioConfig threads = c;
  threads.threads = 1;
  EXPECT_TRUE(random_throw_manifest(threads).has_value());

  // A malformed section names the file and the key.
  {
    std::ifstream in(dir + "/dataset.yaml");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto at = text.find("miss_distance_m:");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, text.find('\n', at) - at, "miss_distance_m: near");
    std::ofstream(dir + "/dataset.yaml") << text;
  }
  try {
    read_random_throw(dir);
    FAIL() << "a malformed section must be rejected";
  } catch (const InputError& e) {
    EXPECT_NE(e.file().find("dataset.yaml"), std::string::npos);
    EXPECT_EQ(e.where(), "key random_throw.miss_distance_m");
  }
}

}  // namespace
}  // namespace fdv::sim
