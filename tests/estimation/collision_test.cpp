#include "fdv/estimation/collision.h"

#include <gtest/gtest.h>

#include <random>

#include "fdv/core/error.h"

namespace fdv {
namespace {

OdometrySample vehicle_at(TimeNs t, const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                          double yaw = 0) {
  OdometrySample s;
  s.t = t;
  s.p_W_B = p;
  s.v_W = v;
  s.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return s;
}

// Straight line (no gravity): object 10 m ahead, 1 m to the side, closing at 10 m/s.
// Closest approach at 1 s, 1 m; contact with R = 2 m where (10 - 10 s)² + 1 = 4.
TEST(Collision, StraightLineAgainstAnalyticValues) {
  const BallisticTrajectory obj{0, {10, 1, 0}, {-10, 0, 0}, Eigen::Vector3d::Zero()};
  PredictionOptions o;
  o.safety_radius_m = 2.0;
  const CollisionPrediction c =
      predict_collision(obj, vehicle_at(0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), o);
  EXPECT_NEAR(c.closest.time_from_now_s, 1.0, 1e-9);
  EXPECT_EQ(c.closest.t, kNsPerS);
  EXPECT_NEAR(c.closest.miss_distance_m, 1.0, 1e-9);
  ASSERT_TRUE(c.contact.has_value());
  EXPECT_NEAR(c.time_to_contact_s, 1.0 - std::sqrt(3.0) / 10.0, 1e-9);
  EXPECT_FALSE(c.closest.receding);
  EXPECT_FALSE(c.closest.at_horizon_end);
  // Smaller safety radius than the miss distance: no contact.
  o.safety_radius_m = 0.9;
  EXPECT_FALSE(
      predict_collision(obj, vehicle_at(0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), o)
          .contact);
}

// Under gravity: a ball released 5 m above a vehicle moving with it horizontally (same velocity):
// relative motion is a pure fall, h(s) = 5 - ½ g s²: closest (0 m) at sqrt(2h/g), contact with
// R = 0.5 m at sqrt(2 (h - R) / g).
TEST(Collision, FallingBallAgainstAnalyticValues) {
  const double g = 9.81;
  const Eigen::Vector3d v(3, 1, 0);
  const BallisticTrajectory obj{0, {1, 2, 6.5}, v, {0, 0, -g}};
  PredictionOptions o;
  o.safety_radius_m = 0.5;
  const CollisionPrediction c = predict_collision(obj, vehicle_at(0, {1, 2, 1.5}, v), o);
  EXPECT_NEAR(c.closest.time_from_now_s, std::sqrt(2 * 5.0 / g), 1e-7);
  EXPECT_NEAR(c.closest.miss_distance_m, 0.0, 1e-6);
  EXPECT_NEAR(c.time_to_contact_s, std::sqrt(2 * 4.5 / g), 1e-9);
}

// The point of passage in the body frame: vehicle yawed 90° (its x axis along W's y); the object
// passes 1 m along W's +x, which is the body's right side, -y in B.
TEST(Collision, PointOfPassageInBodyFrame) {
  const BallisticTrajectory obj{0, {1, 10, 0}, {0, -10, 0}, Eigen::Vector3d::Zero()};
  const CollisionPrediction c = predict_collision(
      obj, vehicle_at(0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), M_PI / 2), {});
  EXPECT_NEAR((c.closest.offset_B - Eigen::Vector3d(0, -1, 0)).norm(), 0, 1e-9);
  EXPECT_NEAR((c.closest.object_W - Eigen::Vector3d(1, 0, 0)).norm(), 0, 1e-9);
}

TEST(Collision, RecedingAndBeyondHorizon) {
  PredictionOptions o;
  o.horizon_s = 1.0;
  const auto still = vehicle_at(5 * kNsPerS, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  const BallisticTrajectory away{5 * kNsPerS, {3, 0, 0}, {5, 0, 0}, Eigen::Vector3d::Zero()};
  const CollisionPrediction r = predict_collision(away, still, o);
  EXPECT_TRUE(r.closest.receding);
  EXPECT_EQ(r.closest.t, 5 * kNsPerS);
  EXPECT_NEAR(r.closest.miss_distance_m, 3.0, 1e-12);
  EXPECT_FALSE(r.contact);
  const BallisticTrajectory slow{5 * kNsPerS, {30, 0, 0}, {-5, 0, 0}, Eigen::Vector3d::Zero()};
  const CollisionPrediction h = predict_collision(slow, still, o);
  EXPECT_TRUE(h.closest.at_horizon_end);
  EXPECT_NEAR(h.closest.miss_distance_m, 25.0, 1e-9);
  // Already inside the safety sphere: contact now.
  const BallisticTrajectory near{5 * kNsPerS, {0.2, 0, 0}, {5, 0, 0}, Eigen::Vector3d::Zero()};
  const CollisionPrediction n = predict_collision(near, still, o);
  ASSERT_TRUE(n.contact);
  EXPECT_EQ(*n.contact, 5 * kNsPerS);
  o.horizon_s = 0;
  EXPECT_THROW(predict_collision(near, still, o), ConfigError);
}

// Random throws and vehicle motions: the closest approach matches a dense 0.1 ms scan, and the
// contact time is the scan's first sample inside the sphere.
TEST(Collision, MatchesDenseScanOnRandomThrows) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  PredictionOptions o;
  o.safety_radius_m = 0.6;
  int contacts = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const BallisticTrajectory obj{0,
                                  {8 + 2 * u(rng), 2 * u(rng), 1.5 + u(rng)},
                                  {-10 + 2 * u(rng), 2 * u(rng), 3 + 2 * u(rng)},
                                  {0, 0, -9.81}};
    const auto veh = vehicle_at(0, {0, 0, 1.5}, {2 * u(rng), u(rng), 0.5 * u(rng)}, u(rng));
    const CollisionPrediction c = predict_collision(obj, veh, o);
    double best = 1e9, t_best = 0, t_contact = -1;
    for (int i = 0; i <= 20000; ++i) {
      const double s = i * 1e-4;
      const double d = (obj.position(from_seconds(s)) - (veh.p_W_B + s * veh.v_W)).norm();
      if (d < best) best = d, t_best = s;
      if (t_contact < 0 && d <= o.safety_radius_m) t_contact = s;
    }
    EXPECT_NEAR(c.closest.miss_distance_m, best, 1e-5);
    EXPECT_NEAR(c.closest.time_from_now_s, t_best, 2e-3);
    EXPECT_EQ(c.contact.has_value(), t_contact >= 0) << trial;
    if (c.contact && t_contact >= 0) {
      ++contacts;
      EXPECT_NEAR(c.time_to_contact_s, t_contact, 1.5e-4);
    }
  }
  EXPECT_GT(contacts, 5);  // the sample covers both outcomes
}

}  // namespace
}  // namespace fdv
