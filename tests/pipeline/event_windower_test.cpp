#include "fdv/pipeline/event_windower.h"

#include <gtest/gtest.h>

namespace fdv {
namespace {

struct Seen {
  TimeNs t_start, t_end;
  std::size_t n;
  std::uint64_t decimated, index;
};

std::vector<Seen> run(EventWindower& w, const std::vector<Event>& events, std::size_t run_size) {
  std::vector<Seen> seen;
  auto cb = [&](const EventWindow& win) {
    for (const auto& e : win.events) {
      EXPECT_GE(e.t, win.t_start);
      EXPECT_LT(e.t, win.t_end);
    }
    seen.push_back({win.t_start, win.t_end, win.events.size(), win.decimated, win.index});
  };
  for (std::size_t i = 0; i < events.size(); i += run_size)
    w.push(std::span(events).subspan(i, std::min(run_size, events.size() - i)), cb);
  w.flush(cb);
  return seen;
}

TEST(EventWindower, CutsConsecutiveWindowsAlignedToTheFirstEvent) {
  // Events every 1 ms from t = 3 ms to 99 ms: windows of 25 ms start at 3, 28, 53, 78 ms.
  std::vector<Event> events;
  for (int ms = 3; ms < 100; ++ms) events.push_back({ms * kNsPerMs, 1, 1, true});
  EventWindower w({.window_ns = 25 * kNsPerMs});
  const auto seen = run(w, events, 7);  // runs that straddle window ends
  ASSERT_EQ(seen.size(), 4u);
  EXPECT_EQ(seen[0].t_start, 3 * kNsPerMs);
  EXPECT_EQ(seen[1].t_start, 28 * kNsPerMs);
  EXPECT_EQ(seen[0].n, 25u);
  EXPECT_EQ(seen[3].n, 22u);  // 78..99 ms
  EXPECT_EQ(seen[3].index, 3u);
}

TEST(EventWindower, AGapYieldsEmptyWindows) {
  const std::vector<Event> events{{0, 1, 1, true}, {100 * kNsPerMs, 1, 1, true}};
  EventWindower w({.window_ns = 25 * kNsPerMs});
  const auto seen = run(w, events, 1);
  ASSERT_EQ(seen.size(), 5u);  // [0,25) has one event, [25,50) [50,75) [75,100) empty, [100,125)
  EXPECT_EQ(seen[0].n, 1u);
  EXPECT_EQ(seen[1].n, 0u);
  EXPECT_EQ(seen[3].n, 0u);
  EXPECT_EQ(seen[4].n, 1u);
}

TEST(EventWindower, ABurstIsDecimatedAndCounted) {
  std::vector<Event> events;
  for (int i = 0; i < 1000; ++i) events.push_back({i, 1, 1, true});  // 1000 events in 1 µs
  EventWindower w({.window_ns = 25 * kNsPerMs, .max_events_per_window = 300});
  const auto seen = run(w, events, 1000);
  ASSERT_EQ(seen.size(), 1u);
  // k = ceil(1000 / 300) = 4 -> 250 kept, 750 dropped.
  EXPECT_EQ(seen[0].n, 250u);
  EXPECT_EQ(seen[0].decimated, 750u);
}

TEST(EventWindower, OptionsAreValidated) {
  EXPECT_NE(EventWindowerOptions{.window_ns = 0}.validate(), "");
  EXPECT_EQ(EventWindowerOptions{}.validate(), "");
}

}  // namespace
}  // namespace fdv
