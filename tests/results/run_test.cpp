// The one run of a recording into a results folder (fdv/results/run.h): the warnings of every
// origin in the order raised, the summary it writes, and its errors.
#include "fdv/results/run.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "fdv/core/error.h"
#include "fdv/results/reader.h"
#include "test_support.h"

namespace fdv {
namespace {

using test::real_data;
using test::scratch_dir;

RunRequest request_for(const std::string& path) {
  RunRequest request;
  request.input = path;
  return request;
}

// evt3_trigger_ros2.db3 has no calibration (the sensor policy's first rule) and its reader drops
// records (docs/FORMATS.md, ROS 2 bags): a policy warning first, the reader's drops last.
TEST(RecordingRun, WarnsPolicyPipelineAndReaderDropsInOrderAndWritesThemIntoTheSummary) {
  const std::string path = real_data("evt3_trigger_ros2.db3");
  FDV_REQUIRE_REAL_FILE(path);
  const std::string out = scratch_dir("recording_run_real") + "/results";
  std::vector<std::string> heard;
  PerceptionCallbacks also;
  int windows = 0;
  also.on_window = [&](const WindowResult&) { ++windows; };
  also.on_warning = [&](const std::string& w) { heard.push_back(w); };
  RecordingRun run(request_for(path));
  EXPECT_TRUE(run.policy().pixel_only);
  EXPECT_EQ(run.calibration_source(), "none (pixel coordinates, no compensation)");
  const RunOutcome outcome = run.into(out, also);

  ASSERT_GE(heard.size(), 2u);
  EXPECT_EQ(outcome.warnings, heard);
  EXPECT_EQ(heard.front().rfind("no calibration", 0), 0u) << heard.front();
  EXPECT_EQ(heard.back().rfind("the reader dropped", 0), 0u) << heard.back();
  EXPECT_GT(outcome.reader_report.total_dropped(), 0u);
  EXPECT_EQ(static_cast<std::uint64_t>(windows), outcome.counts.windows);

  const RunSummary summary = read_summary(out);
  EXPECT_EQ(summary.warnings, heard);
  EXPECT_EQ(summary.input, path);
  EXPECT_EQ(summary.calibration, "none (pixel coordinates, no compensation)");
  EXPECT_EQ(summary.method, "none");
  EXPECT_EQ(summary.counts.windows, outcome.counts.windows);
  EXPECT_EQ(summary.reader_report, outcome.reader_report.to_json());
  EXPECT_TRUE(summary.timing_ms.count("window_total"));
  EXPECT_THROW(run.into(out), std::logic_error);  // a recording is run once
}

TEST(RecordingRun, WithoutAFolderWritesNothingAndStillSummarises) {
  const std::string path = real_data("evt3_trigger_ros2.db3");
  FDV_REQUIRE_REAL_FILE(path);
  const std::string dir = scratch_dir("recording_run_no_folder");
  const RunOutcome outcome = RecordingRun(request_for(path)).into("");
  EXPECT_TRUE(std::filesystem::is_empty(dir));
  EXPECT_EQ(outcome.summary.warnings, outcome.warnings);
  EXPECT_EQ(outcome.summary.counts.windows, outcome.counts.windows);
  EXPECT_TRUE(outcome.summary.timing_ms.empty());  // timing is the writer's
}

TEST(RecordingRun, ACalibrationOfAnotherSizeIsAnErrorNamingTheCalibrationFile) {
  const std::string path = real_data("evt3_trigger_ros2.db3");
  FDV_REQUIRE_REAL_FILE(path);
  RunRequest request = request_for(path);
  request.calibration_source = "my_camera.yaml";
  request.calibration = pixel_only_calibration(17, 11);
  try {
    RecordingRun run(std::move(request));
    FAIL() << "a 17x11 calibration was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("my_camera.yaml"), std::string::npos) << e.what();
  }
}

TEST(RunRecorder, AfterTheRunWarnsOverloadDecimationAndFallbackFlagsOfASensorMethod) {
  PerceptionCounters counts;
  counts.windows = 10;
  counts.events = 1000;
  counts.events_dropped.overload = 40;
  counts.windows_flagged.imu_missing = 3;
  RunSummary summary;
  summary.counts = counts;
  summary.method = "rotation";
  std::vector<std::string> heard;
  PerceptionCallbacks also;
  also.on_warning = [&](const std::string& w) { heard.push_back(w); };
  RunRecorder recorder("", also);
  recorder.warn("before");
  const RunSummary written = recorder.finish(summary);
  const std::vector<std::string> expected = {
      "before", "3 of 10 windows flagged 'imu missing' by the compensation (windows_with_fallback_flag)",
      "40 of 1000 events decimated by the overload policy"};
  EXPECT_EQ(heard, expected);
  EXPECT_EQ(written.warnings, expected);

  // With no compensation the flags say nothing of the results: not warned.
  summary.method = "none";
  RunRecorder no_sensors("");
  EXPECT_EQ(no_sensors.finish(summary).warnings,
            std::vector<std::string>{"40 of 1000 events decimated by the overload policy"});
}

/// The hidden partial folders beside `dir` (run.h: ".NAME.partial-PID").
std::vector<std::string> partial_folders_beside(const std::filesystem::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir.parent_path()))
    if (e.path().filename().string().rfind("." + dir.filename().string() + ".partial-", 0) == 0)
      out.push_back(e.path().filename().string());
  return out;
}

std::string text_of(const std::filesystem::path& file) {
  std::ifstream in(file);
  return {std::istreambuf_iterator<char>(in), {}};
}

TEST(RecordingRun, ARunStoppedByACallbackLeavesTheEarlierFolderAsItWas) {
  const std::string path = real_data("evt3_trigger_ros2.db3");
  FDV_REQUIRE_REAL_FILE(path);
  const std::filesystem::path out = scratch_dir("recording_run_stopped") + "/results";
  std::filesystem::create_directories(out);
  std::ofstream(out / "summary.json") << "the earlier run's";
  PerceptionCallbacks also;
  int windows = 0;
  also.on_window = [&](const WindowResult&) {
    if (++windows == 2) throw std::runtime_error("stop");
  };
  EXPECT_THROW(RecordingRun(request_for(path)).into(out, also), std::runtime_error);
  EXPECT_EQ(windows, 2);
  EXPECT_EQ(text_of(out / "summary.json"), "the earlier run's");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(out), {}), 1);
  EXPECT_TRUE(partial_folders_beside(out).empty());
}

TEST(RunRecorder, ReplacesAResultsFolderWholeAndRefusesAnyOtherFolder) {
  const std::filesystem::path root = scratch_dir("run_recorder_replace");
  const std::filesystem::path results = root / "results";
  std::filesystem::create_directories(results / "windows");
  std::ofstream(results / "detections.jsonl") << "{}\n";
  std::ofstream(results / "track_7_fusion.tum") << "stale\n";
  {
    RunRecorder recorder(results.string() + "/");  // a trailing slash names the same folder
    EXPECT_EQ(recorder.folder().parent_path(), std::filesystem::absolute(root).lexically_normal());
    EXPECT_TRUE(std::filesystem::exists(results / "track_7_fusion.tum"));  // untouched until finish
    RunSummary summary;
    summary.method = "none";
    recorder.finish(summary);
  }
  EXPECT_FALSE(std::filesystem::exists(results / "track_7_fusion.tum"));
  EXPECT_FALSE(std::filesystem::exists(results / "windows"));
  EXPECT_TRUE(std::filesystem::exists(results / "summary.json"));
  EXPECT_TRUE(partial_folders_beside(results).empty());

  const std::filesystem::path users = root / "users";
  std::filesystem::create_directories(users);
  std::ofstream(users / "notes.txt") << "mine";
  EXPECT_THROW(RunRecorder{users}, InputError);
  EXPECT_TRUE(std::filesystem::exists(users / "notes.txt"));
  EXPECT_TRUE(partial_folders_beside(users).empty());
}

}  // namespace
}  // namespace fdv
