// The results folder's one writer and one reader agree: every field of hand-built rows survives a
// write and a read, malformed lines are errors naming the file and line, and summary.json's counts
// come back as the PerceptionCounters they were written from.
#include "fdv/results/writer.h"

#include <gtest/gtest.h>

#include <fstream>
#include <limits>

#include "fdv/core/error.h"
#include "fdv/results/reader.h"
#include "test_support.h"

namespace fdv {
namespace {

// Every field set to a value of its own, off the defaults.
WindowRow sample_window() {
  WindowRow w;
  w.t_start_s = 0.125;
  w.t_end_s = 0.15;
  w.events = 12345;
  w.method = "rotation";
  w.method_requested = "rotation_translation";
  w.status = "detected";
  w.detections.push_back({{10.5, 20.25, 30.75, 40.125},
                          {20.5, 30.25},
                          {11.5, 21.25, 31.75, 41.125},
                          {21.5, 31.25},
                          0.1375,
                          321,
                          0.875,
                          0.4375,
                          true,
                          "region_retrieval",
                          7,
                          true,
                          0.625,
                          Eigen::Vector2d(-3.5, 30.75)});
  return w;
}

DepthRow accepted_depth() {
  DepthRow d;
  d.t_s = 0.2;
  d.track = 3;
  d.roi_pixels = 400;
  d.valid_pixels = 350;
  d.observation = DepthRow::Observation{4.25, 4.125, 0.0625, 120, 0.03125, {100.5, 80.25}};
  return d;
}

DepthRow rejected_depth() {
  DepthRow d;
  d.t_s = 0.233;
  d.track = 4;
  d.roi_pixels = 10;
  d.valid_pixels = 2;
  d.rejection = "too few pixels";
  d.reason = "peak at 3.1 m: 2 pixels";
  return d;
}

TrajectoryRow sample_trajectory() {
  TrajectoryRow t;
  t.t_s = 0.3;
  t.track = 3;
  t.method = "fusion";
  t.fit = "fusion";
  t.usable = true;
  t.converged = true;
  t.t0_s = 0.1;
  t.p0_W = {1.5, -2.25, 3.125};
  t.v0_W = {-8.5, 0.25, 1.75};
  t.gravity_W = {0, 0, -9.81};
  t.t_first_s = 0.1;
  t.t_last_s = 0.29;
  t.event_observations = 8;
  t.depth_observations = 3;
  t.outliers = 1;
  t.cost = 0.015625;
  t.iterations = 12;
  t.message = "no depth yet";
  TrajectoryRow::Uncertainty u;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) u.covariance(r, c) = 0.001 * (6 * r + c + 1);
  u.position_sigma_m = 0.05;
  u.horizon_sigma_m = std::numeric_limits<double>::infinity();  // written null, read back +inf
  t.uncertainty = u;
  return t;
}

PredictionRow sample_prediction(bool contact) {
  PredictionRow p;
  p.t_s = 0.3;
  p.track = 3;
  p.closest_t_s = 0.95;
  p.closest_in_s = 0.65;
  p.miss_distance_m = 0.125;
  p.object_W = {0.5, 0.25, 1.5};
  p.passage_B = {0.0625, -0.125, 0.03125};
  p.receding = !contact;
  if (contact) p.time_to_contact_s = 0.6;
  if (contact) p.miss_distance_sigma_m = 0.0625;
  return p;
}

void expect_equal(const DetectionRow& a, const DetectionRow& b) {
  EXPECT_EQ(a.box.x0, b.box.x0);
  EXPECT_EQ(a.box.y0, b.box.y0);
  EXPECT_EQ(a.box.x1, b.box.x1);
  EXPECT_EQ(a.box.y1, b.box.y1);
  EXPECT_EQ(a.center, b.center);
  EXPECT_EQ(a.box_undistorted.x0, b.box_undistorted.x0);
  EXPECT_EQ(a.box_undistorted.y1, b.box_undistorted.y1);
  EXPECT_EQ(a.center_undistorted, b.center_undistorted);
  EXPECT_EQ(a.t_s, b.t_s);
  EXPECT_EQ(a.events, b.events);
  EXPECT_EQ(a.score, b.score);
  EXPECT_EQ(a.event_density, b.event_density);
  EXPECT_EQ(a.track_aided, b.track_aided);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.track, b.track);
  EXPECT_EQ(a.partial, b.partial);
  EXPECT_EQ(a.visible_fraction, b.visible_fraction);
  EXPECT_EQ(a.center_full, b.center_full);
}

TEST(ResultsWriter, EveryFieldOfEveryRowSurvivesAWriteAndARead) {
  const std::string dir = test::scratch_dir("results_round_trip");
  const WindowRow window = sample_window();
  WindowRow empty_window;  // no detection, no fallback
  empty_window.t_start_s = 0.15;
  empty_window.t_end_s = 0.175;
  empty_window.method = "rotation";
  empty_window.status = "too few events";
  const TrajectoryRow trajectory = sample_trajectory();
  TrajectoryRow mono = trajectory;
  mono.method = "mono";
  mono.uncertainty.reset();
  {
    ResultsWriter out(dir);
    out.write(window);
    out.write(empty_window);
    out.write(accepted_depth());
    out.write(rejected_depth());
    out.write(trajectory);
    out.write(mono);
    out.write(sample_prediction(true));
    out.write(sample_prediction(false));
    out.finish(RunSummary{});
  }

  const std::vector<WindowRow> windows = read_windows(dir);
  ASSERT_EQ(windows.size(), 2u);
  EXPECT_EQ(windows[0].t_start_s, window.t_start_s);
  EXPECT_EQ(windows[0].t_end_s, window.t_end_s);
  EXPECT_EQ(windows[0].events, window.events);
  EXPECT_EQ(windows[0].method, window.method);
  EXPECT_EQ(windows[0].method_requested, window.method_requested);
  EXPECT_EQ(windows[0].status, window.status);
  ASSERT_EQ(windows[0].detections.size(), 1u);
  expect_equal(windows[0].detections[0], window.detections[0]);
  EXPECT_FALSE(windows[1].method_requested);
  EXPECT_TRUE(windows[1].detections.empty());
  EXPECT_EQ(windows[1].status, empty_window.status);

  const std::vector<DepthRow> depth = read_depth(dir);
  ASSERT_EQ(depth.size(), 2u);
  const DepthRow a = accepted_depth(), r = rejected_depth();
  EXPECT_EQ(depth[0].t_s, a.t_s);
  EXPECT_EQ(depth[0].track, a.track);
  EXPECT_EQ(depth[0].roi_pixels, a.roi_pixels);
  EXPECT_EQ(depth[0].valid_pixels, a.valid_pixels);
  ASSERT_TRUE(depth[0].observation);
  EXPECT_EQ(depth[0].observation->depth_m, a.observation->depth_m);
  EXPECT_EQ(depth[0].observation->surface_depth_m, a.observation->surface_depth_m);
  EXPECT_EQ(depth[0].observation->sigma_m, a.observation->sigma_m);
  EXPECT_EQ(depth[0].observation->pixels, a.observation->pixels);
  EXPECT_EQ(depth[0].observation->spread_m, a.observation->spread_m);
  EXPECT_EQ(depth[0].observation->center, a.observation->center);
  EXPECT_FALSE(depth[1].observation);
  EXPECT_EQ(depth[1].rejection, r.rejection);
  EXPECT_EQ(depth[1].reason, r.reason);
  EXPECT_EQ(depth[1].valid_pixels, r.valid_pixels);

  const std::vector<TrajectoryRow> trajectories = read_trajectories(dir);
  ASSERT_EQ(trajectories.size(), 2u);
  const TrajectoryRow& t = trajectories[0];
  EXPECT_EQ(t.t_s, trajectory.t_s);
  EXPECT_EQ(t.track, trajectory.track);
  EXPECT_EQ(t.method, trajectory.method);
  EXPECT_EQ(t.fit, trajectory.fit);
  EXPECT_EQ(t.usable, trajectory.usable);
  EXPECT_EQ(t.converged, trajectory.converged);
  EXPECT_EQ(t.t0_s, trajectory.t0_s);
  EXPECT_EQ(t.p0_W, trajectory.p0_W);
  EXPECT_EQ(t.v0_W, trajectory.v0_W);
  EXPECT_EQ(t.gravity_W, trajectory.gravity_W);
  EXPECT_EQ(t.t_first_s, trajectory.t_first_s);
  EXPECT_EQ(t.t_last_s, trajectory.t_last_s);
  EXPECT_EQ(t.event_observations, trajectory.event_observations);
  EXPECT_EQ(t.depth_observations, trajectory.depth_observations);
  EXPECT_EQ(t.outliers, trajectory.outliers);
  EXPECT_EQ(t.cost, trajectory.cost);
  EXPECT_EQ(t.iterations, trajectory.iterations);
  EXPECT_EQ(t.message, trajectory.message);
  ASSERT_TRUE(t.uncertainty);
  EXPECT_EQ(t.uncertainty->covariance, trajectory.uncertainty->covariance);
  EXPECT_EQ(t.uncertainty->position_sigma_m, trajectory.uncertainty->position_sigma_m);
  EXPECT_EQ(t.uncertainty->horizon_sigma_m, std::numeric_limits<double>::infinity());
  EXPECT_EQ(trajectories[1].method, "mono");
  EXPECT_FALSE(trajectories[1].uncertainty);

  const std::vector<PredictionRow> predictions = read_predictions(dir);
  ASSERT_EQ(predictions.size(), 2u);
  const PredictionRow p = sample_prediction(true);
  EXPECT_EQ(predictions[0].t_s, p.t_s);
  EXPECT_EQ(predictions[0].track, p.track);
  EXPECT_EQ(predictions[0].closest_t_s, p.closest_t_s);
  EXPECT_EQ(predictions[0].closest_in_s, p.closest_in_s);
  EXPECT_EQ(predictions[0].miss_distance_m, p.miss_distance_m);
  EXPECT_EQ(predictions[0].object_W, p.object_W);
  EXPECT_EQ(predictions[0].passage_B, p.passage_B);
  EXPECT_EQ(predictions[0].receding, p.receding);
  EXPECT_EQ(predictions[0].time_to_contact_s, p.time_to_contact_s);
  EXPECT_FALSE(predictions[1].time_to_contact_s);
  EXPECT_TRUE(predictions[1].receding);
  EXPECT_EQ(predictions[0].miss_distance_sigma_m, p.miss_distance_sigma_m);
  EXPECT_FALSE(predictions[1].miss_distance_sigma_m);
}

TEST(ResultsWriter, SummaryCountsAndTimingsSurviveAWriteAndARead) {
  const std::string dir = test::scratch_dir("results_summary");
  RunSummary s;
  s.input = "run.aedat4";
  s.format = "aedat4";
  s.width = 640;
  s.height = 480;
  s.calibration = "from the recording";
  s.method_requested = "rotation_translation";
  s.method = "rotation";
  s.threads = 2;
  s.reader_report = {{"dropped", nlohmann::json::array()}};
  PerceptionCounters& c = s.counts;
  c.events = 1000;
  c.events_in_windows = 900;
  c.windows = 4;
  c.detections = 3;
  c.windows_skipped = 2;
  c.events_dropped = {100, 5, 6, 7, 8};
  c.windows_flagged = {1, 2, 3, 4, 0, 1};
  c.windows_by_status = {{DetectionStatus::kDetected, 3}, {DetectionStatus::kWeakEvidence, 1}};
  c.windows_by_method = {{CompensationMethod::kRotation, 4}};
  c.imu = 50;
  c.imu_out_of_order = 1;
  c.odometry = 20;
  c.odometry_out_of_order = 2;
  c.depth_frames = 3;
  c.depth_rejected_registration = 1;
  c.depth_observations = 2;
  c.estimates = 5;
  s.timing_ms["compensation"] = {4, 0.5, 0.75, 0.625, 0.98, 1.0, 0};
  s.warnings = {"first", "second"};
  ResultsWriter(dir).finish(s);

  const RunSummary b = read_summary(dir);
  EXPECT_EQ(b.input, s.input);
  EXPECT_EQ(b.format, s.format);
  EXPECT_EQ(b.width, s.width);
  EXPECT_EQ(b.height, s.height);
  EXPECT_EQ(b.calibration, s.calibration);
  EXPECT_EQ(b.method_requested, s.method_requested);
  EXPECT_EQ(b.method, s.method);
  EXPECT_EQ(b.threads, s.threads);
  EXPECT_EQ(b.reader_report, s.reader_report);
  EXPECT_EQ(b.warnings, s.warnings);
  const PerceptionCounters& r = b.counts;
  EXPECT_EQ(r.events, c.events);
  EXPECT_EQ(r.events_in_windows, c.events_in_windows);
  EXPECT_EQ(r.windows, c.windows);
  EXPECT_EQ(r.detections, c.detections);
  EXPECT_EQ(r.windows_skipped, c.windows_skipped);
  EXPECT_EQ(r.events_dropped.overload, 100u);
  EXPECT_EQ(r.events_dropped.outside_window, 5u);
  EXPECT_EQ(r.events_dropped.outside_sensor, 6u);
  EXPECT_EQ(r.events_dropped.no_inverse, 7u);
  EXPECT_EQ(r.events_dropped.left_image, 8u);
  EXPECT_EQ(r.windows_flagged.imu_missing, 1u);
  EXPECT_EQ(r.windows_flagged.imu_gap, 2u);
  EXPECT_EQ(r.windows_flagged.odometry_missing, 3u);
  EXPECT_EQ(r.windows_flagged.depth_missing, 4u);
  EXPECT_EQ(r.windows_flagged.depth_stale, 0u);
  EXPECT_EQ(r.windows_flagged.depth_wrong_size, 1u);
  EXPECT_EQ(r.windows_by_status, c.windows_by_status);
  EXPECT_EQ(r.windows_by_method, c.windows_by_method);
  EXPECT_EQ(r.imu, c.imu);
  EXPECT_EQ(r.imu_out_of_order, c.imu_out_of_order);
  EXPECT_EQ(r.odometry, c.odometry);
  EXPECT_EQ(r.odometry_out_of_order, c.odometry_out_of_order);
  EXPECT_EQ(r.depth_frames, c.depth_frames);
  EXPECT_EQ(r.depth_rejected_registration, c.depth_rejected_registration);
  EXPECT_EQ(r.depth_observations, c.depth_observations);
  EXPECT_EQ(r.estimates, c.estimates);
  ASSERT_EQ(b.timing_ms.count("compensation"), 1u);
  const Summary& t = b.timing_ms.at("compensation");
  EXPECT_EQ(t.count, 4u);
  EXPECT_EQ(t.min, 0.5);
  EXPECT_EQ(t.mean, 0.75);
  EXPECT_EQ(t.median, 0.625);
  EXPECT_EQ(t.p99, 0.98);
  EXPECT_EQ(t.max, 1.0);

  // The counts' JSON as summary.json has always spelled it.
  std::ifstream in(dir + "/summary.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["counts"]["events_dropped"], 126);
  EXPECT_EQ(j["counts"]["events_dropped_by_reason"]["decimated (overload policy)"], 100);
  EXPECT_EQ(j["counts"]["windows_with_fallback_flag"]["depth wrong size"], 1);
  EXPECT_EQ(j["counts"]["windows_by_status"]["weak evidence"], 1);
  EXPECT_EQ(j["counts"]["windows_by_method"]["rotation"], 4);
  EXPECT_EQ(j["resolution"], nlohmann::json({640, 480}));
}

TEST(ResultsWriter, BeforeAnyWindowTheByReasonAndByFlagCountsAreEmpty) {
  const PerceptionCounters none;
  EXPECT_TRUE(dropped_by_reason(none).empty());
  EXPECT_TRUE(windows_by_fallback_flag(none).empty());
  PerceptionCounters one;
  one.windows = 1;
  EXPECT_EQ(dropped_by_reason(one).size(), 6u);  // overload, outside window, outside sensor, no inverse, left image, hot pixel
  EXPECT_EQ(windows_by_fallback_flag(one).size(), 6u);
}

TEST(ResultsWriter, TumFilesHoldTheFinalUsableEstimateOfEachTrackEvery5Ms) {
  const std::string dir = test::scratch_dir("results_tum");
  TrajectoryEstimate est;
  est.usable = true;
  est.converged = true;
  est.trajectory = {100 * kNsPerMs, {1, 2, 3}, {4, 0, 0}, {0, 0, -9.81}};
  est.t_first = 100 * kNsPerMs;
  est.t_last = 120 * kNsPerMs;
  TrajectoryEstimate unusable = est;
  unusable.usable = false;
  {
    ResultsWriter out(dir);
    Looming looming;
    looming.size_px = 12.5;
    looming.size_sigma_px = 1.25;
    looming.tau_s = 0.375;
    looming.tau_sigma_s = 0.0625;
    out.estimate({110 * kNsPerMs, 5, EstimatorMode::kFusion, &est, 1.0, looming});
    looming.tau_s = looming.tau_sigma_s = std::nullopt;  // a size that does not visibly change
    out.estimate({120 * kNsPerMs, 5, EstimatorMode::kFusion, &unusable, 1.0, looming});  // not final: unusable
    out.finish(RunSummary{});
    EXPECT_EQ(out.timing_ms().at("estimation_fusion").count, 2u);
  }
  const std::vector<TumPose> poses = read_tum(dir + "/track_5_fusion.tum");
  ASSERT_EQ(poses.size(), 5u);  // 100, 105, ..., 120 ms
  EXPECT_DOUBLE_EQ(poses[0].t_s, 0.1);
  EXPECT_EQ(poses[0].p_W, Eigen::Vector3d(1, 2, 3));
  EXPECT_NEAR(poses[4].p_W.x(), 1 + 4 * 0.02, 1e-6);
  EXPECT_NEAR(poses[4].p_W.z(), 3 - 0.5 * 9.81 * 0.02 * 0.02, 1e-6);
  EXPECT_FALSE(std::ifstream(dir + "/track_5_mono.tum"));
  const std::vector<TrajectoryRow> rows = read_trajectories(dir);
  ASSERT_EQ(rows.size(), 2u);
  // The looming keys round-trip; τ null when the size does not visibly change.
  ASSERT_TRUE(rows[0].looming && rows[1].looming);
  EXPECT_EQ(rows[0].looming->size_px, 12.5);
  EXPECT_EQ(rows[0].looming->size_sigma_px, 1.25);
  EXPECT_EQ(rows[0].looming->tau_s, 0.375);
  EXPECT_EQ(rows[0].looming->tau_sigma_s, 0.0625);
  EXPECT_FALSE(rows[1].looming->tau_s);
  EXPECT_FALSE(rows[1].looming->tau_sigma_s);
}

TEST(ResultsWriter, TimingCsvHoldsEachWindowsStageTimesAsWritten) {
  const std::string dir = test::scratch_dir("results_timing");
  // Three windows (index 4 after two skipped ones) with times of their own, a third of a ms apart so
  // the text must round-trip; the count-contrast source was tried only in the second.
  std::vector<WindowResult> windows(3);
  const std::uint64_t indices[] = {0, 1, 4};
  for (std::size_t i = 0; i < windows.size(); ++i) {
    WindowResult& w = windows[i];
    const double k = static_cast<double>(i);
    w.index = indices[i];
    w.t_start = 1'000'000'007 + static_cast<TimeNs>(w.index) * 25 * kNsPerMs;
    w.t_end = w.t_start + 25 * kNsPerMs;
    WindowTimings& t = w.timings;
    t.compensation_ms = (k + 1) / 3.0;
    t.detection.time_images_ms = 0.5 + k;
    t.detection.segmentation_ms = 0.25;
    t.detection.preprocess_ms = 0.125;
    t.detection.add_source_ms("gaussian_fit", 2.0 / 3.0);
    t.detection.total_ms = 4.0 + k;
    t.tracking_ms = 0.0625;
    t.total_ms = 5.0 + k / 7.0;
  }
  windows[1].timings.detection.add_source_ms("count_contrast", 1.75);
  windows[2].timings.detection.refine_ms = 0.375;
  {
    ResultsWriter out(dir);
    for (const WindowResult& w : windows) out.window(w);
    out.finish(RunSummary{});
  }
  const std::vector<WindowTimingRow> rows = read_timing(dir);
  ASSERT_EQ(rows.size(), read_windows(dir).size());
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const WindowTimings& t = windows[i].timings;
    const double k = static_cast<double>(i);
    EXPECT_EQ(rows[i].window, indices[i]);
    EXPECT_EQ(rows[i].t_start_s, to_seconds(windows[i].t_start));  // exactly: the shortest round-trip text
    EXPECT_EQ(rows[i].stage_ms.at("compensation"), (k + 1) / 3.0);
    EXPECT_EQ(rows[i].stage_ms.at("time_images"), 0.5 + k);
    EXPECT_EQ(rows[i].stage_ms.at("segmentation"), 0.25);
    EXPECT_EQ(rows[i].stage_ms.at("preprocess"), 0.125);
    EXPECT_EQ(rows[i].stage_ms.at("gaussian_fit"), 2.0 / 3.0);
    EXPECT_EQ(rows[i].stage_ms.at("detection_total"), 4.0 + k);
    EXPECT_EQ(rows[i].stage_ms.at("tracking"), 0.0625);
    EXPECT_EQ(rows[i].stage_ms.at("window_total"), t.total_ms);
    EXPECT_EQ(rows[i].stage_ms.count("dense_motion"), 0u);  // tried in no window: an empty cell
    EXPECT_EQ(rows[i].stage_ms.count("count_contrast"), i == 1 ? 1u : 0u);
  }
  EXPECT_EQ(rows[1].stage_ms.at("count_contrast"), 1.75);
  EXPECT_EQ(rows[2].stage_ms.at("refine"), 0.375);  // a window whose candidate was refined
  EXPECT_EQ(rows[0].stage_ms.count("refine"), 0u);
  std::ifstream in(dir + "/timing.csv");
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "window,t_start,compensation,time_images,segmentation,preprocess,gaussian_fit,track_aided,"
                    "dense_motion,count_contrast,evidence,refine,detection_total,tracking,window_total");
}

TEST(ResultsReader, MalformedLinesAreErrorsNamingFileAndLine) {
  const std::string dir = test::scratch_dir("results_malformed");
  const std::string good_window = R"({"t_start":0,"t_end":0.025,"detections":[]})";
  test::write_text(dir + "/detections.jsonl", good_window + "\n" + good_window + "\n{\"t_start\":0.05,\"t_end\":\n");
  EXPECT_EQ(test::input_error_of(dir + "/detections.jsonl", [&] { read_windows(dir); }).substr(0, 8), "line 3 |");
  test::write_text(dir + "/depth.jsonl", R"({"t":0.1,"track":1,"accepted":"yes"})" "\n");
  EXPECT_EQ(test::input_error_of(dir + "/depth.jsonl", [&] { read_depth(dir); }).substr(0, 8), "line 1 |");
  test::write_text(dir + "/predictions.jsonl", R"({"t":0.1,"track":1,"closest_t":0.5})" "\n");  // no miss_distance
  EXPECT_EQ(test::input_error_of(dir + "/predictions.jsonl", [&] { read_predictions(dir); }).substr(0, 8),
            "line 1 |");
  const std::string fields =
      R"("t0":0.05,"p0":[1,2,3],"v0":[4,5,6],"gravity":[0,0,-9.81],"t_first":0.05,"t_last":0.2)";
  test::write_text(dir + "/trajectories.jsonl", R"({"t":0.1,"track":2,"method":"fusion","usable":true,)" + fields + "}\n" +
                                         R"({"t":0.1,"track":2,"method":"fusion","usable":true,"covariance":[1,2],)" +
                                         fields + "}\n");
  EXPECT_EQ(test::input_error_of(dir + "/trajectories.jsonl", [&] { read_trajectories(dir); }).substr(0, 8),
            "line 2 |");
  test::write_text(dir + "/track_1_fusion.tum", "0.1 1 2 3 0 0 0 1\n0.105 1 2\n");
  EXPECT_EQ(test::input_error_of(dir + "/track_1_fusion.tum", [&] { read_tum(dir + "/track_1_fusion.tum"); })
                .substr(0, 8),
            "line 2 |");
  test::write_text(dir + "/summary.json", R"({"input":"x"})");
  EXPECT_NE(test::input_error_of(dir + "/summary.json", [&] { read_summary(dir); }), "no error");
  test::write_text(dir + "/timing.csv", "window,t_start,compensation\n0,0.1,0.5\n1,0.125\n");
  EXPECT_EQ(test::input_error_of(dir + "/timing.csv", [&] { read_timing(dir); }).substr(0, 8), "line 3 |");
  test::write_text(dir + "/timing.csv", "window,t_start,compensation\n0,0.1,fast\n");
  EXPECT_EQ(test::input_error_of(dir + "/timing.csv", [&] { read_timing(dir); }).substr(0, 8), "line 2 |");
  // Files a run always writes are required; the others may be absent (no 3D estimation).
  const std::string empty = test::scratch_dir("results_missing");
  EXPECT_THROW(read_windows(empty), InputError);
  EXPECT_THROW(read_summary(empty), InputError);
  EXPECT_TRUE(read_trajectories(empty).empty());
  EXPECT_TRUE(read_predictions(empty).empty());
  EXPECT_TRUE(read_depth(empty).empty());
  EXPECT_TRUE(read_timing(empty).empty());  // results of an fdv before timing.csv
}

// dodge.jsonl: a decision with a manoeuvre and a cancel without one survive the writer and come
// back as the decisions they were (times to the nanosecond the JSON's seconds allow); an unknown
// action is an error naming the line.
TEST(ResultsWriter, DodgeDecisionsRoundTrip) {
  const std::string dir = test::scratch_dir("results_dodge");
  DodgeDecision dodge;
  dodge.t = 450 * kNsPerMs;
  dodge.effective_t = 500 * kNsPerMs;
  dodge.track_id = 3;
  dodge.action = DodgeAction::kDodge;
  dodge.probability = 0.625;
  dodge.time_to_contact_s = 0.5;
  dodge.miss_distance_m = 0.25;
  dodge.reason = "p 0.625 >= act 0.50";
  dodge.maneuver = DodgeManeuver{{1.5, -2.25, 9.5}, 500 * kNsPerMs, 0.75, 1.125, 0.0625};
  DodgeDecision cancel = dodge;
  cancel.t = 475 * kNsPerMs;
  cancel.effective_t = 525 * kNsPerMs;
  cancel.action = DodgeAction::kCancel;
  cancel.time_to_contact_s = std::numeric_limits<double>::infinity();  // the mean misses
  cancel.maneuver.reset();
  cancel.committed = false;
  {
    ResultsWriter out(dir);
    out.dodge(dodge);
    out.dodge(cancel);
    out.finish(RunSummary{});
  }
  const std::vector<DodgeRow> rows = read_dodge(dir);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].action, "dodge");
  EXPECT_FALSE(rows[1].time_to_contact_s.has_value());
  const std::vector<DodgeDecision> back = dodge_decisions(rows);
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const DodgeDecision& want = i == 0 ? dodge : cancel;
    EXPECT_EQ(back[i].t, want.t);
    EXPECT_EQ(back[i].effective_t, want.effective_t);
    EXPECT_EQ(back[i].track_id, want.track_id);
    EXPECT_EQ(back[i].action, want.action);
    EXPECT_EQ(back[i].probability, want.probability);
    EXPECT_EQ(back[i].time_to_contact_s, want.time_to_contact_s);
    EXPECT_EQ(back[i].miss_distance_m, want.miss_distance_m);
    EXPECT_EQ(back[i].reason, want.reason);
    ASSERT_EQ(back[i].maneuver.has_value(), want.maneuver.has_value());
  }
  const DodgeManeuver& m = *back[0].maneuver;
  EXPECT_EQ(m.acceleration_W, dodge.maneuver->acceleration_W);
  EXPECT_EQ(m.start_t, dodge.maneuver->start_t);
  EXPECT_EQ(m.duration_s, 0.75);
  EXPECT_EQ(m.expected_clearance_m, 1.125);
  EXPECT_EQ(m.probability_after, 0.0625);

  test::write_text(dir + "/dodge.jsonl", R"({"t":0.1,"action":"dodge"})" "\n" R"({"t":0.2,"action":"jump"})" "\n");
  try {
    dodge_decisions(read_dodge(dir));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fdv
