// The DVS pixel: a known log-brightness change gives the expected events at the interpolated
// times (expectations computed by hand from the model in pixel_model.h).
#include "fdv/sim/pixel_model.h"

#include <gtest/gtest.h>

#include <vector>

namespace fdv::sim {
namespace {

struct Fired {
  double t;
  bool on;
};

std::vector<Fired> ramp(PixelMemory& m, TimeNs t0, float L0, TimeNs t1, float L1, PixelThresholds c,
                        TimeNs refractory) {
  std::vector<Fired> out;
  emit_crossings(m, t0, L0, t1, L1, c, refractory, [&](double t, bool on) {
    out.push_back({t, on});
  });
  return out;
}

TEST(PixelModel, StepUpGivesOneOnEventPerThresholdAtInterpolatedTimes) {
  // Log intensity rises by 1.0 linearly over 1000 ns; C_on = 0.25 -> crossings at 0.25, 0.5,
  // 0.75, 1.0 of the way: 250, 500, 750, 1000 ns.
  PixelMemory m{0.0f};
  const auto ev = ramp(m, 0, 0.0f, 1000, 1.0f, {0.25f, 0.25f}, 0);
  ASSERT_EQ(ev.size(), 4u);
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(ev[k].on);
    EXPECT_NEAR(ev[k].t, 250.0 * (k + 1), 1e-3);
  }
  EXPECT_FLOAT_EQ(m.reference, 1.0f);
}

TEST(PixelModel, StepDownGivesOffEventsWithTheOffThreshold) {
  // -0.6 over [2000, 5000] ns with C_off = 0.2: crossings at -0.2, -0.4, -0.6 -> 3000, 4000, 5000.
  PixelMemory m{0.0f};
  const auto ev = ramp(m, 2000, 0.0f, 5000, -0.6f, {0.5f, 0.2f}, 0);
  ASSERT_EQ(ev.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_FALSE(ev[k].on);
    EXPECT_NEAR(ev[k].t, 3000.0 + 1000.0 * k, 1e-2);
  }
}

TEST(PixelModel, SmallChangesAccumulateAcrossSamples) {
  // Three samples of +0.1 each with C = 0.25: one event, in the third interval, at 0.25 of the
  // total rise: the ramp 0.2 -> 0.3 over [200, 300] crosses 0.25 at 250.
  PixelMemory m{0.0f};
  EXPECT_TRUE(ramp(m, 0, 0.0f, 100, 0.1f, {0.25f, 0.25f}, 0).empty());
  EXPECT_TRUE(ramp(m, 100, 0.1f, 200, 0.2f, {0.25f, 0.25f}, 0).empty());
  const auto ev = ramp(m, 200, 0.2f, 300, 0.3f, {0.25f, 0.25f}, 0);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_NEAR(ev[0].t, 250.0, 1e-3);
}

TEST(PixelModel, RefractoryPeriodHoldsTheReferenceUntilRelease) {
  // Ramp 0 -> 1 over 1000 ns (slope 0.001/ns), C = 0.1, refractory 250 ns:
  //  event at L = 0.1 (t = 100); reset until 350, reference latched at L(350) = 0.35;
  //  event at 0.45 (t = 450); reset until 700, reference 0.70; event at 0.80 (t = 800);
  //  reset until 1050 > 1000: pending.
  PixelMemory m{0.0f};
  const auto ev = ramp(m, 0, 0.0f, 1000, 1.0f, {0.1f, 0.1f}, 250);
  ASSERT_EQ(ev.size(), 3u);
  EXPECT_NEAR(ev[0].t, 100.0, 1e-2);
  EXPECT_NEAR(ev[1].t, 450.0, 1e-2);
  EXPECT_NEAR(ev[2].t, 800.0, 1e-2);
  EXPECT_EQ(m.latch_at, 1050);
  // Next interval: flat at 1.0. The reference is latched at 1050 to 1.0: no event.
  EXPECT_TRUE(ramp(m, 1000, 1.0f, 2000, 1.0f, {0.1f, 0.1f}, 250).empty());
  EXPECT_FLOAT_EQ(m.reference, 1.0f);
  EXPECT_EQ(m.latch_at, PixelMemory::kNoLatch);
}

TEST(PixelModel, NoChangeNoEvent) {
  PixelMemory m{0.5f};
  EXPECT_TRUE(ramp(m, 0, 0.5f, 1000, 0.5f, {0.2f, 0.2f}, 0).empty());
  EXPECT_TRUE(ramp(m, 1000, 0.5f, 2000, 0.69f, {0.2f, 0.2f}, 0).empty());  // below C
}

}  // namespace
}  // namespace fdv::sim
