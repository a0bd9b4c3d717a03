// The experiment helpers that do not need a full run: the dataset cache (on a tiny scene), the
// relative contrast restricted to windows with a ball in flight, and the seed list.
#include "fdv/sim/dataset_cache.h"
#include "fdv/tables/experiment.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "eval/handmade_truth.h"
#include "fdv/core/error.h"
#include "fdv/sim/simulator.h"
#include "test_support.h"

namespace fdv {
namespace {
namespace fs = std::filesystem;

/// A still camera, no ball, no depth, no noise, 64x48 for 50 ms: simulates in well under a second.
sim::ScenarioConfig tiny_scene() {
  sim::ScenarioConfig c;
  c.name = "tiny";
  c.duration_s = 0.05;
  c.vehicle.motion = sim::MotionKind::kConstant;
  c.vehicle.start_W_m = {0.0, 0.0, 1.5};
  c.depth_camera.enabled = false;
  c.event_camera.background_rate_hz = 0;
  c.event_camera.hot_pixel_fraction = 0;
  sim::set_event_resolution(c, 64, 48);
  return c;
}

TEST(EnsureSimulated, SimulatesOnceThenReusesUntilIncompleteOrChanged) {
  const std::string dir = test::scratch_dir("ensure_simulated") + "/tiny";
  const fs::path sentinel = fs::path(dir) / "sentinel";  // disappears when the folder is re-made
  EXPECT_EQ(sim::ensure_simulated(tiny_scene(), dir), dir);
  ASSERT_TRUE(fs::exists(fs::path(dir) / sim::kSimulationMarker));
  EXPECT_NO_THROW(load_dataset_truth(dir));  // a complete dataset with truth

  std::ofstream(sentinel) << "x";
  sim::ensure_simulated(tiny_scene(), dir);
  EXPECT_TRUE(fs::exists(sentinel)) << "a complete folder must be reused";

  fs::remove(fs::path(dir) / sim::kSimulationMarker);  // as after an interrupted simulation
  sim::ensure_simulated(tiny_scene(), dir);
  EXPECT_FALSE(fs::exists(sentinel)) << "a folder without the marker must be simulated again";
  EXPECT_TRUE(fs::exists(fs::path(dir) / sim::kSimulationMarker));

  // The vehicle model's response acts on commands only: a dataset without any is the same.
  std::ofstream(sentinel) << "x";
  sim::ScenarioConfig slower = tiny_scene();
  slower.vehicle.response.attitude_time_constant_s *= 2;
  slower.vehicle.response.wall_margin_m = 1;
  sim::ensure_simulated(slower, dir);
  EXPECT_TRUE(fs::exists(sentinel)) << "the vehicle's response does not change an uncommanded dataset";

  std::ofstream(sentinel) << "x";
  sim::ScenarioConfig other = tiny_scene();
  other.seed = 2;
  sim::ensure_simulated(other, dir);
  EXPECT_FALSE(fs::exists(sentinel)) << "another configuration must be simulated again";

  // The same configuration from an earlier simulator revision (its marker says so): made again.
  std::ofstream(sentinel) << "x";
  const fs::path marker = fs::path(dir) / sim::kSimulationMarker;
  std::string text;
  {
    std::ifstream in(marker);
    std::getline(in, text, '\0');
  }
  const std::string now = fmt::format("revision {}\n", sim::kSimulatorRevision);
  const auto at = text.find(now);
  ASSERT_NE(at, std::string::npos) << "the marker names the simulator revision";
  text.replace(at, now.size(), fmt::format("revision {}\n", sim::kSimulatorRevision - 1));
  std::ofstream(marker, std::ios::trunc) << text;
  sim::ensure_simulated(other, dir);
  EXPECT_FALSE(fs::exists(sentinel))
      << "a dataset from another simulator revision must be simulated again";
}

TEST(EnsureSimulated, PresetFolderNameAndUnknownPreset) {
  EXPECT_THROW(sim::ensure_simulated("no_such_preset", 1, test::scratch_dir("ensure_simulated_bad")),
               ConfigError);
}

TEST(WindowRelativeContrast, BallInFlightOnlyAfterTheSharedDenoising) {
  // Ball 5 m ahead on the axis (box around the image centre), 0.25 m radius: ~50 px across.
  const Eigen::Vector3d p(0, 0, 5);
  cv::Mat T(480, 640, CV_32F, cv::Scalar(0));
  T(cv::Rect(318, 238, 5, 5)).setTo(0.020f);  // the ball's late events: max over M
  T(cv::Rect(100, 100, 5, 5)).setTo(0.005f);  // the background's pattern: max over B
  T.at<float>(400, 600) = 0.025f;  // an isolated noise event: removed by the shared denoising
  const TimeNs t0 = 10 * kNsPerMs, t1 = 20 * kNsPerMs;

  const auto in_flight = window_relative_contrast(test::straight_flight(p, {2, 0, 0}), T, t0, t1,
                                                  CompensationMethod::kRotationTranslation, {});
  ASSERT_EQ(in_flight.size(), 1u);
  EXPECT_NEAR(in_flight[0], (0.020 - 0.005) / 0.020, 1e-6);  // η = (max_M − max_B) / max_M

  // The same ball held still: η is not defined (no moving object).
  EXPECT_TRUE(window_relative_contrast(test::straight_flight(p, Eigen::Vector3d::Zero()), T, t0, t1,
                                       CompensationMethod::kRotationTranslation, {})
                  .empty());
  // Behind the camera: no box in the image.
  EXPECT_TRUE(window_relative_contrast(test::straight_flight({0, 0, -5}, {2, 0, 0}), T, t0, t1,
                                       CompensationMethod::kRotationTranslation, {})
                  .empty());
}

TEST(CompensatedImageFrame, EachMethodHoldsWhatItsWarpUndoes) {
  const TimeNs t0 = 7 * kNsPerMs;
  const auto none = compensated_image_frame(CompensationMethod::kNone, t0);
  EXPECT_FALSE(none.rotation_time || none.position_time);
  const auto rotation = compensated_image_frame(CompensationMethod::kRotation, t0);
  EXPECT_EQ(rotation.rotation_time, t0);
  EXPECT_FALSE(rotation.position_time);
  for (auto m : {CompensationMethod::kRotationTranslation, CompensationMethod::kContrastMax}) {
    const auto full = compensated_image_frame(m, t0);
    EXPECT_EQ(full.rotation_time, t0);
    EXPECT_EQ(full.position_time, t0);
  }
}

TEST(ParseSeedList, RangesAndLists) {
  EXPECT_EQ(parse_seed_list("101-105"), (std::vector<std::uint64_t>{101, 102, 103, 104, 105}));
  EXPECT_EQ(parse_seed_list("7"), (std::vector<std::uint64_t>{7}));
  EXPECT_EQ(parse_seed_list("1,3,10-11"), (std::vector<std::uint64_t>{1, 3, 10, 11}));
  for (const char* bad : {"", "5-3", "a", "1,,2", "1-", "-1", "3x"})
    EXPECT_THROW(parse_seed_list(bad), ConfigError) << bad;
}

}  // namespace
}  // namespace fdv
