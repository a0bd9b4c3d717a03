// The Markdown of Table I: figures and notes come from the table, not from fixed text.
#include <gtest/gtest.h>

#include <cmath>

#include "fdv/tables/paper_tables.h"

namespace fdv {
namespace {

TEST(Table1Markdown, RowsAndNotesFollowTheTable) {
  Table1 t;
  t.seeds = {7, 8};
  t.step_ns = 20'000'000;
  t.denoise_mean_filter_px = 5;
  t.denoise_opening_px = 3;
  CompensationRow r;
  r.scene = "scene2_ball";
  r.method = "rotation_translation";
  r.compensation_ms = {1.0, 2.0, 3.0};
  r.front_end_ms = {2.0, 4.0, 21.0};  // one window over Δt = 20 ms: not real-time
  r.relative_contrast = {0.1, 0.3};
  t.rows.push_back(r);
  const std::string md = to_markdown(t, Provenance{"fdv table1 --seeds 7,8", "2026-11-21", "abc1234"});
  EXPECT_NE(md.find("| scene2_ball | rotation_translation | 1.00 / 2.00 / 3.00 | yes | 2.00 / 9.00 / 21.00 | no | "
                    "10.0 / 20.0 / 30.0 | 2 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("Δt = 20 ms windows"), std::string::npos);
  EXPECT_NE(md.find("the detector's 5x5 mean filter and 3x3 opening"), std::string::npos);
  EXPECT_NE(md.find("abc1234"), std::string::npos);
}

// The any-size table from hand-made metrics: the bin cells, the cut-ball and fills-view
// columns, the per-ball table of a scene with two balls, and the targets read off them.
TEST(Table1Markdown, AnySizeRowsPerBinAndPerBall) {
  Table1 t;
  t.seeds = {7};
  t.step_ns = 20'000'000;
  AnySizeRow close;
  close.scene = {"close_pass", 1280, 720, ""};
  close.balls = 1;
  DetectionMetrics& c = close.detection;
  c.windows = 50;
  c.size_bins[1] = {10, 9, {1.0, 2.0, 3.0}, {20, 20, 20}};  // 90 % of 10, median 2 px
  c.size_bins[3] = {4, 4, {6.0}, {150}};                    // 6 px ≤ 5 % of 150 px = 7.5 px
  c.any_size = c.size_bins[1];
  c.any_size.merge(c.size_bins[3]);
  c.partial = {5, 4, {2.5}, {120}};
  c.center_full_errors_px = {4.0, 5.0};
  c.fills_view_windows = 6;
  c.fills_view_reported = 5;
  AnySizeRow two;
  two.scene = {"two_balls", 0, 0, ""};
  two.balls = 2;
  two.detection.windows = 20;
  two.detection.objects[1] = {{10, 10, {1.0}, {30}}, 3, 1};
  two.detection.objects[2] = {{10, 8, {2.0}, {30}}, 4, 2};
  t.any_size_rows = {close, two};
  t.any_size_seeds = {7};

  const std::string md = to_markdown(t, Provenance{"fdv table1 --seeds 7", "2026-11-26", "abc1234"});
  EXPECT_NE(md.find("| close_pass | 1280x720 | 50 | 92.9 % of 14, 2.50 px | – | 90.0 % of 10, 2.00 px | – | "
                    "100.0 % of 4, 6.00 px | 80.0 % of 5, 2.50 px | 4.50 (2) | 5 / 6 | 0.0 % | – / – |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("(rotation_translation; seeds 7)"), std::string::npos) << md;
  EXPECT_NE(md.find("| two_balls | preset's own | 1 | 10 | 100.0 % | 1.00 | 3; 1 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| two_balls | preset's own | 2 | 10 | 80.0 % | 2.00 | 4; 2 |"), std::string::npos) << md;

  auto target = [&](const std::string& what) {
    for (const TableTarget& x : table1_targets(t))
      if (x.what.find(what) != std::string::npos) return x;
    ADD_FAILURE() << "no target " << what;
    return TableTarget{};
  };
  EXPECT_FALSE(target("recall, 10-40 px bin").met);  // 90 % < 95 %
  EXPECT_TRUE(target("recall, > 100 px bin").met);
  EXPECT_TRUE(target("median centre error, > 100 px bin").met);  // 6 px ≤ 7.5 px
  EXPECT_FALSE(target("recall, < 10 px bin").met);               // nothing eligible
  EXPECT_TRUE(target("cut by the border").met);                  // 80 % ≥ 80 %
  EXPECT_FALSE(target("recall, ball 2, two_balls").met);         // 80 % < 90 %
  EXPECT_TRUE(target("identity switches in one seed (most), ball 1").met);
  EXPECT_FALSE(target("identity switches in one seed (most), ball 2").met);
}

DetectionMetrics seed_metrics(std::size_t windows, std::size_t eligible, std::size_t found,
                              std::size_t false_detections, std::vector<double> errors_px) {
  DetectionMetrics m;
  m.windows = windows;
  m.eligible = eligible;
  m.found = found;
  m.false_detections = false_detections;
  m.center_errors_px = std::move(errors_px);
  m.any_size = {eligible, found, m.center_errors_px, std::vector<double>(m.center_errors_px.size(), 20)};
  return m;
}

// The seed-to-seed spread is the sample SD of each seed's own figure, over the seeds where the
// figure is defined; the Markdown shows it beside the pooled figures, "–" where undefined.
TEST(Table1Markdown, SeedToSeedSpreadOfEachDetectionRow) {
  // Recall 0.5 and 1.0 (SD 0.3536), median errors 2 and 4 px (SD 1.414), false detections per
  // window 0.1, 0.0, 0.2 (SD 0.1); the third seed has no eligible window.
  const std::vector<DetectionMetrics> per_seed{seed_metrics(10, 4, 2, 1, {1.0, 2.0, 3.0}),
                                               seed_metrics(10, 2, 2, 0, {4.0}),
                                               seed_metrics(10, 0, 0, 2, {})};
  const SeedSpread sd = seed_spread(per_seed);
  EXPECT_NEAR(sd.recall, std::sqrt(0.125), 1e-12);
  EXPECT_NEAR(sd.any_size_recall, std::sqrt(0.125), 1e-12);
  EXPECT_NEAR(sd.median_center_error_px, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(sd.false_per_window, 0.1, 1e-12);
  EXPECT_TRUE(std::isnan(seed_spread({per_seed[0]}).recall));

  Table1 t;
  t.seeds = {1, 2, 3};
  t.step_ns = 25'000'000;
  CompensationRow r;
  r.scene = "hover_headon";
  r.method = "rotation_translation";
  for (const DetectionMetrics& m : per_seed) {
    r.per_seed.push_back(m);
    r.detection.merge(m);
  }
  t.rows.push_back(r);
  AnySizeRow a;
  a.scene = {"hover_headon", 346, 260, ""};
  a.balls = 1;
  a.detection = r.detection;
  a.per_seed = r.per_seed;
  t.any_size_rows = {a};
  t.any_size_seeds = t.seeds;
  const std::string md = to_markdown(t, Provenance{"fdv table1 --seeds 1-3", "2026-11-27", "abc1234"});
  // Pooled: 4 of 6 eligible windows, median of 1, 2, 3, 4 px, 3 false detections in 30 windows.
  EXPECT_NE(md.find("| hover_headon | rotation_translation | 30 | 6 | 66.7 % | 2.50 | 10.0 % | "
                    "35.4 % / 1.41 / 10.0 % |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| 10.0 % | 35.4 % / 10.0 % |"), std::string::npos) << md;
}

TEST(Table1Scenes, VariantsNameTheirCameraAndCacheFolder) {
  PaperTableOptions o;
  o.davis346_calibration = "cal/davis346_00000133_calibration.xml";
  const std::vector<SceneVariant> scenes = table1_any_size_scenes(o);
  ASSERT_EQ(scenes.size(), 4u * 3 + 4);
  EXPECT_EQ(scenes[1].cache_name(101), "fast_forward_seed101_346x260");
  EXPECT_EQ(scenes[0].cache_name(101), "fast_forward_seed101");  // the paper rows' own dataset
  EXPECT_EQ(scenes[2].camera_label(), "1280x720");
  const SceneVariant& davis = scenes[12];
  EXPECT_EQ(davis.preset, "close_pass");
  EXPECT_EQ(davis.camera_label(), "davis346_00000133_calibration");
  EXPECT_EQ(davis.cache_name(3), "close_pass_seed3_davis346_00000133_calibration");
  EXPECT_EQ(scenes.back().preset, "two_balls");
}

// Table II from hand-made rows: the pooled APE figures, the per-seed column with a seed that had no
// estimate, the head-on latency, and the targets read off those figures.
TEST(Table2Markdown, RowsLatenciesAndTargetsFollowTheTable) {
  Table2 t;
  t.seeds = {7, 8};
  ApeRow fusion;
  fusion.scene = "fast_forward";
  fusion.samples = {0.03, 0.04};  // RMSE sqrt((0.03² + 0.04²) / 2) = 0.0354 m
  fusion.rmse_per_seed = {0.05, std::nullopt};
  fusion.usable_final_seeds = 1;
  t.ape.push_back(fusion);
  HeadOnRun fast, none;
  fast.seed = 7;
  fast.timing.in_flight_from = 200 * kNsPerMs;
  fast.timing.first = EstimateRecord{};
  fast.timing.first->t = 250 * kNsPerMs;  // 50 ms after release
  none.seed = 8;
  none.timing.in_flight_from = 200 * kNsPerMs;
  t.head_on = {fast, none};

  const std::string md = to_markdown(t, Provenance{"fdv table2 --seeds 7,8", "2026-11-25", "abc1234"});
  EXPECT_NE(md.find("| fast_forward | Fusion | 0.035 | 0.030 | 0.040 | 0.035 | 1 of 2 | 1 | 0.050, – | 0.050 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| 7 | 0.200 | – | 0.250 | 50 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 8 | 0.200 | – | – | – |"), std::string::npos) << md;

  const std::vector<TableTarget> targets = table2_targets(t);
  ASSERT_EQ(targets.size(), 2u);  // swing has no row, so no target
  EXPECT_EQ(targets[0].figure, "0.035 m");
  EXPECT_TRUE(targets[0].met);
  EXPECT_EQ(targets[1].figure, "1 of 2 seeds without an estimate");
  EXPECT_FALSE(targets[1].met);
  t.head_on.pop_back();  // every seed 50 ms: met
  EXPECT_EQ(table2_targets(t)[1].figure, "50 ms");
  EXPECT_TRUE(table2_targets(t)[1].met);
}

}  // namespace
}  // namespace fdv
