// The Markdown of Table I: figures and notes come from the table, not from fixed text.
#include <gtest/gtest.h>

#include "fdv/eval/paper_tables.h"

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

}  // namespace
}  // namespace fdv
