// Same seed => byte-identical dataset folder, for any number of threads; another seed differs.
// The folder is readable by the project's dataset reader, and the label file lines up with it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "fdv/io/read_report.h"
#include "fdv/io/recording.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/event_labels.h"
#include "test_support.h"

namespace fdv::sim {
namespace {
namespace fs = std::filesystem;

std::string simulate_to(const std::string& name, std::uint64_t seed, int threads) {
  ScenarioConfig c = make_preset("fast_forward", seed);
  c.duration_s = 0.6;
  c.threads = threads;
  set_event_resolution(c, 96, 72);
  c.depth_camera.width = 80, c.depth_camera.height = 60;
  c.depth_camera.fx = c.depth_camera.fy = 385.7 / 8;
  c.depth_camera.cx = 39.5, c.depth_camera.cy = 29.5;
  const std::string dir = fdv::test::scratch_dir(name);
  Simulator sim(c);
  DatasetSink sink(dir, sim.calibration());
  sim.run(sink);
  sink.finish(sim.manifest_yaml());
  return dir;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(SimDeterminism, SameSeedSameBytesWhateverTheThreadCount) {
  const std::string a = simulate_to("sim_det_a", 7, 2);
  const std::string b = simulate_to("sim_det_b", 7, 1);
  std::size_t files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(a)) {
    if (!entry.is_regular_file()) continue;
    const fs::path rel = fs::relative(entry.path(), a);
    ASSERT_TRUE(fs::exists(fs::path(b) / rel)) << rel;
    EXPECT_TRUE(slurp(entry.path()) == slurp(fs::path(b) / rel)) << rel << " differs";
    ++files;
  }
  EXPECT_GE(files, 10u);  // manifest, calibration, events, labels, csv streams, depth PNGs
  const std::string c = simulate_to("sim_det_c", 8, 2);
  EXPECT_FALSE(slurp(fs::path(a) / "events.bin") == slurp(fs::path(c) / "events.bin"));
}

TEST(SimDeterminism, DatasetIsReadableAndLabelsLineUp) {
  const std::string dir = simulate_to("sim_det_read", 3, 2);
  auto reader = open_recording(dir);
  EXPECT_EQ(reader->info().format, "fdv_dataset");
  EXPECT_EQ(reader->info().width, 96);
  ASSERT_TRUE(reader->info().calibration.has_value());
  std::size_t events = 0, imu = 0, depth = 0, odometry = 0, truth = 0;
  SensorChunk chunk;
  while (reader->read(chunk)) {
    events += chunk.events.size(), imu += chunk.imu.size(), depth += chunk.depth.size();
    odometry += chunk.odometry.size(), truth += chunk.ground_truth.size();
  }
  EXPECT_EQ(reader->report().total_dropped(), 0u)
      << "dropped: " << reader->report().dropped().size();
  EXPECT_GT(events, 1000u);
  EXPECT_EQ(imu, 601u);      // 1 kHz over 0.6 s, both ends
  EXPECT_EQ(odometry, 61u);  // 100 Hz
  EXPECT_EQ(depth, 19u);     // 30 Hz: k / 30 s for k = 0 .. 18 (0.6 s included)
  // 1 kHz truth of the one ball, which exists from its release on (thrown from out of view).
  const double release = make_preset("fast_forward", 3).balls[0].release_t_s;
  std::size_t expected_truth = 0;
  for (int k = 0; k <= 600; ++k) expected_truth += k * 1e-3 >= release;
  EXPECT_EQ(truth, expected_truth);
  EXPECT_EQ(read_event_labels(dir).size(), events);
}

}  // namespace
}  // namespace fdv::sim
