// The adapter from a compensated window to the detector's input gives the detector what
// Perception::process_window gave it before the adapter existed, field by field.
#include "fdv/pipeline/detector_input.h"

#include <gtest/gtest.h>

#include "compensation/synthetic_motion.h"

namespace fdv {
namespace {

// Perception::process_window's view, as written out by hand before detector_input.
CompensatedEventsView pipeline_view_before(const CompensatedWindow& cw, const Compensator& compensator, int threads) {
  CompensatedEventsView view;
  view.t_start = cw.t_start;
  view.t_end = cw.t_end;
  view.width = cw.width;
  view.height = cw.height;
  view.pixel = cw.pixel();
  view.t_s = cw.t_s();
  view.time_sorted = cw.report.events_out_of_order == 0;
  view.omega_rad_s = cw.report.has_omega ? cw.report.omega_E.norm() : 0.0;
  view.speed_m_s = cw.report.has_velocity ? cw.report.v_E.norm() : 0.0;
  view.threads = threads;
  view.observed_at = [&](const Eigen::Vector2d& px, double t_s) { return compensator.observed_position(px, t_s); };
  return view;
}

void expect_same_input(const CompensatedEventsView& a, const CompensatedEventsView& b) {
  EXPECT_EQ(a.t_start, b.t_start);
  EXPECT_EQ(a.t_end, b.t_end);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  // The same arrays, not copies.
  EXPECT_EQ(a.pixel.data(), b.pixel.data());
  EXPECT_EQ(a.pixel.size(), b.pixel.size());
  EXPECT_EQ(a.t_s.data(), b.t_s.data());
  EXPECT_EQ(a.t_s.size(), b.t_s.size());
  EXPECT_EQ(a.time_sorted, b.time_sorted);
  EXPECT_EQ(a.omega_rad_s, b.omega_rad_s);  // bit-identical, not near
  EXPECT_EQ(a.speed_m_s, b.speed_m_s);
  EXPECT_EQ(a.threads, b.threads);
  ASSERT_EQ(static_cast<bool>(a.observed_at), static_cast<bool>(b.observed_at));
  if (!a.observed_at) return;
  for (const Eigen::Vector2d& px : {Eigen::Vector2d(10, 20), Eigen::Vector2d(160.5, 120.25), Eigen::Vector2d(300, 7)})
    for (double t_s : {0.0, 0.004, 0.0099}) EXPECT_EQ(a.observed_at(px, t_s), b.observed_at(px, t_s));
}

struct Window {
  Calibration calib;
  test::SyntheticWindow scene;
  std::vector<ImuSample> imu;
  OdometrySample odometry;
};

Window small_window() {
  Window w;
  w.calib.event_camera = {320, 240, 200.0, 201.0, 159.0, 121.0, {-0.05, 0.01, 0.0, 0.0, 0.0}};
  const Eigen::Vector3d omega(0.3, -0.6, 0.2), v(0.8, -0.2, 1.2);
  w.scene = test::make_window(w.calib.event_camera, omega, v, 0, 10 * kNsPerMs, kNsPerMs);
  w.imu = test::constant_imu(omega, -2 * kNsPerMs, 12 * kNsPerMs, kNsPerMs);  // identity extrinsics: I = E
  w.odometry.v_W = v;  // identity attitude and extrinsics: W = B = E0 axes
  return w;
}

TEST(DetectorInput, GivesTheDetectorWhatThePipelineGaveIt) {
  const Window w = small_window();
  ASSERT_FALSE(w.scene.events.empty());
  for (const CompensationMethod method : all_values(CompensationMethod{})) {
    CompensationOptions o;
    o.method = method;
    const auto compensator = make_compensator(w.calib, o);
    const CompensatedWindow& cw =
        compensator->compensate({w.scene.events, 0, 10 * kNsPerMs, w.imu, w.odometry, &w.scene.depth});
    SCOPED_TRACE(std::string(to_string(method)));
    for (int threads : {1, 2}) expect_same_input(detector_input(cw, *compensator, threads),
                                                 pipeline_view_before(cw, *compensator, threads));
  }
}

TEST(DetectorInput, MotionIsZeroWhereTheCompensationHadNone) {
  const Window w = small_window();
  CompensationOptions o;
  o.method = CompensationMethod::kRotationTranslation;
  const auto compensator = make_compensator(w.calib, o);
  // No IMU and no odometry: no ω, no v; the view says 0 (the threshold's "unknown").
  const CompensatedWindow& cw = compensator->compensate({.events = w.scene.events, .t_start = 0, .t_end = 10 * kNsPerMs});
  ASSERT_FALSE(cw.report.has_omega);
  ASSERT_FALSE(cw.report.has_velocity);
  const CompensatedEventsView view = detector_input(cw);
  EXPECT_EQ(view.omega_rad_s, 0.0);
  EXPECT_EQ(view.speed_m_s, 0.0);
  EXPECT_TRUE(view.time_sorted);
  EXPECT_EQ(view.threads, 1);
  EXPECT_FALSE(view.observed_at);  // without the compensator: the compensated grid itself
  EXPECT_EQ(view.pixel.size(), cw.size());
}

}  // namespace
}  // namespace fdv
