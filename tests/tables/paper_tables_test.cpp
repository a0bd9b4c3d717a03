// The Markdown of Table I: figures and notes come from the table, not from fixed text.
#include <gtest/gtest.h>

#include "fdv/tables/paper_tables.h"

namespace fdv {
namespace {

TEST(Table1Markdown, RowsAndNotesFollowTheTable) {
  Table1 t;
  t.seeds = {7, 8};
  t.window_ns = 20'000'000;
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
