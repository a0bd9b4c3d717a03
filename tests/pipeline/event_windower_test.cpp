#include "fdv/pipeline/event_windower.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

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

TEST(EventWindower, ALongGapIsSkippedAfterTheAllowedEmptyWindowsAndCounted) {
  // Events at 0 and 1 s, then one two years on (a corrupt time): 3 empty windows are emitted,
  // the rest of each gap is skipped in one step, alignment to the first event kept.
  constexpr TimeNs kTwoYears = TimeNs{2} * 365 * 24 * 3600 * kNsPerS;
  const std::vector<Event> events{{0, 1, 1, true}, {kNsPerS, 1, 1, true}, {kTwoYears + 7 * kNsPerMs, 1, 1, true}};
  EventWindower w({.window_ns = 25 * kNsPerMs, .max_empty_windows = 3});
  std::vector<EventWindow> seen;  // their spans are valid during the call only: sizes kept aside
  std::vector<std::size_t> sizes;
  const auto cb = [&](const EventWindow& win) {
    seen.push_back(win);
    sizes.push_back(win.events.size());
  };
  w.push(events, cb);
  w.flush(cb);
  ASSERT_EQ(seen.size(), 1u + 3u + 1u + 3u + 1u);
  EXPECT_EQ(sizes, (std::vector<std::size_t>{1, 0, 0, 0, 1, 0, 0, 0, 1}));
  for (int i : {1, 2, 3}) EXPECT_EQ(seen[static_cast<std::size_t>(i)].t_start, i * 25 * kNsPerMs);
  // [100 ms, 1 s) holds 36 windows: 36 skipped; the window [1 s, 1.025 s) comes next, index 40.
  EXPECT_EQ(seen[4].t_start, kNsPerS);
  EXPECT_EQ(seen[4].skipped_before, 36u);
  EXPECT_EQ(seen[4].index, 40u);
  // Two years = 2 522 880 000 windows from 1 s + 25 ms on, 3 of them emitted.
  const std::uint64_t windows_to_event = static_cast<std::uint64_t>(kTwoYears / (25 * kNsPerMs)) - 41;
  EXPECT_EQ(seen[8].t_start, kTwoYears);
  EXPECT_EQ(seen[8].skipped_before, windows_to_event - 3);
  EXPECT_EQ(seen[8].index, 41 + windows_to_event);
  EXPECT_EQ(w.windows_skipped(), 36u + windows_to_event - 3);
  EXPECT_EQ(w.windows_passed(), seen[8].index + 1);
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

TEST(EventWindower, SlicesOfAnyLengthGiveTheEventByEventWindows) {
  // The rule, one event at a time: an event at or past the current window's end closes it (and
  // any empty windows up to the event's); an event before it, even before the window's start (a
  // slightly late event), joins the current window. The windower appends runs of events as blocks:
  // the same windows, event for event, whatever the slicing.
  std::mt19937 rng(11);
  std::uniform_int_distribution<TimeNs> step(0, 40 * kNsPerUs), jitter(-300 * kNsPerUs, 0);
  std::bernoulli_distribution late(0.05), gap(0.002);
  std::vector<Event> events;
  TimeNs t = 5 * kNsPerMs;
  for (int i = 0; i < 20'000; ++i) {
    t += step(rng) + (gap(rng) ? 60 * kNsPerMs : 0);
    events.push_back({late(rng) ? t + jitter(rng) : t, static_cast<std::uint16_t>(i % 640),
                      static_cast<std::uint16_t>(i % 480), i % 2 == 0});
  }
  const TimeNs window = 25 * kNsPerMs;
  std::vector<std::vector<Event>> expected(1);
  TimeNs start = events.front().t;
  for (const Event& e : events) {
    while (e.t >= start + window) {
      expected.emplace_back();
      start += window;
    }
    expected.back().push_back(e);
  }
  for (const std::size_t slice : {std::size_t{1}, std::size_t{3}, std::size_t{1000}, events.size()}) {
    EventWindower w({.window_ns = window});
    std::vector<std::vector<Event>> seen;
    std::vector<TimeNs> starts;
    const EventWindower::Callback cb = [&](const EventWindow& win) {
      seen.emplace_back(win.events.begin(), win.events.end());
      starts.push_back(win.t_start);
    };
    for (std::size_t i = 0; i < events.size(); i += slice)
      w.push(std::span(events).subspan(i, std::min(slice, events.size() - i)), cb);
    w.flush(cb);
    SCOPED_TRACE("slices of " + std::to_string(slice));
    ASSERT_EQ(seen.size(), expected.size());
    for (std::size_t k = 0; k < seen.size(); ++k) {
      EXPECT_EQ(starts[k], events.front().t + static_cast<TimeNs>(k) * window);
      ASSERT_EQ(seen[k].size(), expected[k].size()) << "window " << k;
      for (std::size_t i = 0; i < seen[k].size(); ++i)
        ASSERT_TRUE(seen[k][i].t == expected[k][i].t && seen[k][i].x == expected[k][i].x) << k << ":" << i;
    }
  }
}

/// Each window's events, once copied by the consumer and once taken (the consumer swaps each
/// window's storage with an empty vector of its own, as Perception does), in runs of 700 events.
std::pair<std::vector<std::vector<Event>>, std::vector<std::vector<Event>>> copied_and_taken(
    const EventWindowerOptions& options, const std::vector<Event>& events) {
  auto windows = [&](bool take) {
    EventWindower w(options);
    std::vector<std::vector<Event>> seen;
    std::vector<Event> spare;
    const EventWindower::Callback cb = [&](const EventWindow& win) {
      if (take) {
        ASSERT_NE(win.storage, nullptr);
        ASSERT_EQ(win.storage->data(), win.events.data());
        spare.clear();
        spare.swap(*win.storage);
        seen.push_back(std::move(spare));
        spare = {};
      } else {
        seen.emplace_back(win.events.begin(), win.events.end());
      }
    };
    for (std::size_t i = 0; i < events.size(); i += 700)
      w.push(std::span(events).subspan(i, std::min<std::size_t>(700, events.size() - i)), cb);
    w.flush(cb);
    return seen;
  };
  return {windows(false), windows(true)};
}

void expect_same_windows(const std::vector<std::vector<Event>>& a, const std::vector<std::vector<Event>>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].size(), b[k].size()) << k;
    for (std::size_t i = 0; i < a[k].size(); ++i) ASSERT_EQ(a[k][i].t, b[k][i].t) << k << ":" << i;
  }
}

/// 3000 events over 60 ms, a burst of 2000 at 61 ms, 500 more from 80 ms.
std::vector<Event> events_with_a_burst() {
  std::vector<Event> events;
  for (int i = 0; i < 3000; ++i) events.push_back({i * 20 * kNsPerUs, static_cast<std::uint16_t>(i % 640), 7, true});
  for (int i = 0; i < 2000; ++i) events.push_back({61 * kNsPerMs + i, 3, static_cast<std::uint16_t>(i % 480), false});
  for (int i = 0; i < 500; ++i) events.push_back({80 * kNsPerMs + i * 50 * kNsPerUs, 5, 5, true});
  return events;
}

TEST(EventWindower, AConsumerMayTakeTheEventsInsteadOfCopyingThem) {
  // The consumer gets the window's events, and the windower goes on with the vector it was given;
  // also through a decimated window (its own storage).
  const auto [copied, taken] =
      copied_and_taken({.window_ns = 25 * kNsPerMs, .max_events_per_window = 1500}, events_with_a_burst());
  ASSERT_EQ(copied.size(), 5u);  // [0, 25) [25, 50) [50, 75) (decimated: 2000 events) [75, 100)
  EXPECT_LT(copied[2].size(), 2000u);
  expect_same_windows(copied, taken);
}

TEST(EventWindower, OverlappingWindowsHoldEveryEventOfTheirSpan) {
  // 25 ms windows every 5 ms over an in-order stream with gaps, in slices of any length: window k
  // holds exactly the events in [t0 + 5k ms, t0 + 5k ms + 25 ms) (counted directly), each event
  // lies in five windows, and the last, partial window is the first one still open at the end.
  std::mt19937 rng(5);
  std::uniform_int_distribution<TimeNs> gap(0, 60 * kNsPerUs);
  std::bernoulli_distribution pause(0.003);
  std::vector<Event> events;
  TimeNs t = 2 * kNsPerMs;
  for (int i = 0; i < 8000; ++i) {
    t += gap(rng) + (pause(rng) ? 40 * kNsPerMs : 0);
    events.push_back({t, static_cast<std::uint16_t>(i % 320), static_cast<std::uint16_t>(i % 240), i % 3 == 0});
  }
  const TimeNs window = 25 * kNsPerMs, step = 5 * kNsPerMs, t0 = events.front().t;
  const auto in = [&](TimeNs start) {
    return std::count_if(events.begin(), events.end(), [&](const Event& e) { return e.t >= start && e.t < start + window; });
  };
  for (const std::size_t slice : {std::size_t{1}, std::size_t{97}, events.size()}) {
    SCOPED_TRACE("slices of " + std::to_string(slice));
    EventWindower w({.window_ns = window, .step_ns = step});
    const auto seen = run(w, events, slice);
    const auto full = static_cast<std::size_t>((events.back().t - t0 - window) / step + 1);  // windows ending by the last event
    ASSERT_EQ(seen.size(), full + 1);
    for (std::size_t k = 0; k < seen.size(); ++k) {
      EXPECT_EQ(seen[k].index, k);
      EXPECT_EQ(seen[k].t_start, t0 + static_cast<TimeNs>(k) * step);
      EXPECT_EQ(seen[k].t_end, seen[k].t_start + window);
      EXPECT_EQ(static_cast<std::ptrdiff_t>(seen[k].n), in(seen[k].t_start)) << "window " << k;
    }
  }
}

TEST(EventWindower, OverlappingWindowsSkipALongGapToTheFirstWindowThatHoldsTheNextEvent) {
  // Events at 0 and 1 s, 25 ms windows every 5 ms, 3 empty windows allowed: [0, 25) holds the first
  // event, [5, 30) [10, 35) [15, 40) are empty, and the windows that end by 1 s, those starting
  // from 20 to 975 ms (192), are skipped: [980, 1005) holds the second event, index 196.
  const std::vector<Event> events{{0, 1, 1, true}, {kNsPerS, 1, 1, true}};
  EventWindower w({.window_ns = 25 * kNsPerMs, .step_ns = 5 * kNsPerMs, .max_empty_windows = 3});
  const auto seen = run(w, events, 1);
  ASSERT_EQ(seen.size(), 5u);
  EXPECT_EQ(seen[0].n, 1u);
  for (int i : {1, 2, 3}) EXPECT_EQ(seen[static_cast<std::size_t>(i)].n, 0u);
  EXPECT_EQ(seen[4].t_start, 980 * kNsPerMs);
  EXPECT_EQ(seen[4].index, 196u);
  EXPECT_EQ(seen[4].n, 1u);
  EXPECT_EQ(w.windows_skipped(), 192u);
}

TEST(EventWindower, AConsumerMayTakeTheEventsOfOverlappingWindows) {
  // The windower keeps the events later windows need: taking each window's storage gives the same
  // windows as copying them, decimated ones included.
  const auto [copied, taken] = copied_and_taken(
      {.window_ns = 25 * kNsPerMs, .step_ns = 5 * kNsPerMs, .max_events_per_window = 1500}, events_with_a_burst());
  ASSERT_EQ(copied.size(), 17u);  // starts 0, 5, ..., 75 ms end by the last event (104.95 ms); [80, 105) is flushed
  EXPECT_EQ(copied[0].size(), 1250u);  // [0, 25) ms at one event per 20 µs
  EXPECT_EQ(copied[8].size(), 1500u);  // [40, 65) ms holds 1000 + 2000 events: every 2nd kept
  expect_same_windows(copied, taken);
}

TEST(EventWindower, OptionsAreValidated) {
  EXPECT_NE(EventWindowerOptions{.window_ns = 0}.validate(), "");
  EXPECT_EQ(EventWindowerOptions{}.validate(), "");
  EXPECT_EQ((EventWindowerOptions{.window_ns = 25 * kNsPerMs, .step_ns = 5 * kNsPerMs}.validate()), "");
  EXPECT_NE((EventWindowerOptions{.window_ns = 25 * kNsPerMs, .step_ns = 30 * kNsPerMs}.validate()), "");
  EXPECT_NE((EventWindowerOptions{.window_ns = 25 * kNsPerMs, .step_ns = 10 * kNsPerMs}.validate()), "");
  EXPECT_NE((EventWindowerOptions{.window_ns = 25 * kNsPerMs, .step_ns = -1}.validate()), "");
}

}  // namespace
}  // namespace fdv
