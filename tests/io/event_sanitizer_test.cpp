// The stream contract every reader applies (recording.h, EventSanitizer): order, sensor bounds,
// and a single time far ahead held until the next event says whether it was corrupt.
#include <gtest/gtest.h>

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "fdv/io/recording.h"
#include "test_support.h"

namespace fdv {
namespace {

using test::dropped;

constexpr TimeNs kMs = 1'000'000;

std::vector<Event> run(EventSanitizer& s, const std::vector<std::vector<Event>>& batches,
                       ReadReport& report) {
  std::vector<Event> out;
  std::size_t first = 0;  // the batch's first event's index in the whole stream
  for (const auto& b : batches) {
    s.append(b.data(), b.data() + b.size(), out, report, [&](std::size_t i) { return "event " + std::to_string(first + i); });
    first += b.size();
  }
  return out;
}

TEST(EventSanitizer, DropsEventsBehindTheStreamOrOutsideTheSensor) {
  EventSanitizer s(10, 10);
  ReadReport r;
  const auto out = run(s,
                       {{{5 * kMs, 1, 1, true},
                         {4 * kMs, 2, 2, true},
                         {6 * kMs, 10, 2, true},
                         {6 * kMs, 3, 3, false}}},
                       r);
  EXPECT_EQ(out, (std::vector<Event>{{5 * kMs, 1, 1, true}, {6 * kMs, 3, 3, false}}));
  EXPECT_EQ(dropped(r, "event timestamp went backwards"), 1u);
  EXPECT_EQ(dropped(r, "event pixel outside the sensor"), 1u);
}

TEST(EventSanitizer, EachDropIsReportedAtItsOwnEventAndACorruptTimeIsDropped) {
  EventSanitizer s(10, 10);
  ReadReport r;
  constexpr TimeNs kMin = std::numeric_limits<TimeNs>::min(), kMax = std::numeric_limits<TimeNs>::max();
  const auto out = run(s,
                       {{{kMin, 1, 1, true},  // event 0: INT64_MIN, a corrupt time (not the stream's start)
                         {5 * kMs, 1, 1, true},
                         {6 * kMs, 1, 1, true}},
                        {{7 * kMs, 1, 1, true},
                         {4 * kMs, 2, 2, true},  // event 4: backwards
                         {8 * kMs, 10, 2, true},  // event 5: outside
                         {kMax, 1, 1, true},      // event 6: corrupt
                         {3 * kMs, 2, 2, true},   // backwards again: counted, the first stays event 4
                         {9 * kMs, 3, 3, false}}},
                       r);
  EXPECT_EQ(out, (std::vector<Event>{{5 * kMs, 1, 1, true}, {6 * kMs, 1, 1, true}, {7 * kMs, 1, 1, true}, {9 * kMs, 3, 3, false}}));
  const std::map<std::string, ReadReport::Entry> expected{
      {"event time out of range (corrupt)", {2, "event 0"}},
      {"event timestamp went backwards", {2, "event 4"}},
      {"event pixel outside the sensor", {1, "event 5"}},
  };
  ASSERT_EQ(r.dropped().size(), expected.size());
  for (const auto& [reason, e] : expected) {
    EXPECT_EQ(r.dropped().at(reason).count, e.count) << reason;
    EXPECT_EQ(r.dropped().at(reason).first_where, e.first_where) << reason;
  }
}

TEST(EventSanitizer, ACorruptTimeFarAheadIsDroppedAndTheStreamGoesOn) {
  // 10 ms, then an event 2 years ahead (one corrupt time), then 11, 12 ms, across batches.
  // Without the hold every event after it would be "behind" it.
  constexpr TimeNs kFar = TimeNs{2} * 365 * 24 * 3600 * 1'000'000'000;
  EventSanitizer s(10, 10);
  ReadReport r;
  const auto out = run(s,
                       {{{10 * kMs, 1, 1, true}, {kFar, 2, 2, true}},
                        {{11 * kMs, 3, 3, true}, {12 * kMs, 4, 4, true}}},
                       r);
  EXPECT_EQ(out, (std::vector<Event>{
                     {10 * kMs, 1, 1, true}, {11 * kMs, 3, 3, true}, {12 * kMs, 4, 4, true}}));
  EXPECT_EQ(dropped(r, "event time far ahead of the stream"), 1u);
  EXPECT_EQ(dropped(r, "event timestamp went backwards"), 0u);
}

TEST(EventSanitizer, TwoCorruptTimesInARowAreBothDropped) {
  // 10 ms, then 2 years, then 4 years ahead (neither follows the other), then 11 ms: the second
  // replaces the first as the held event, and 11 ms shows it corrupt too.
  constexpr TimeNs kYear = TimeNs{365} * 24 * 3600 * 1'000'000'000;
  EventSanitizer s(10, 10);
  ReadReport r;
  const auto out = run(s,
                       {{{10 * kMs, 1, 1, true},
                         {2 * kYear, 2, 2, true},
                         {4 * kYear, 3, 3, true},
                         {11 * kMs, 4, 4, true}}},
                       r);
  EXPECT_EQ(out, (std::vector<Event>{{10 * kMs, 1, 1, true}, {11 * kMs, 4, 4, true}}));
  EXPECT_EQ(dropped(r, "event time far ahead of the stream"), 2u);
  EXPECT_EQ(s.last_time(), 11 * kMs);
}

TEST(EventSanitizer, ARealJumpIsKeptOnceTheNextEventFollowsIt) {
  // A 5 s gap in a recording: the event after it is held, then kept with the one that follows;
  // an event behind the kept time meanwhile is dropped as going backwards.
  EventSanitizer s(10, 10);
  ReadReport r;
  const TimeNs t1 = 10 * kMs, t2 = t1 + 5000 * kMs;
  const auto out = run(
      s, {{{t1, 1, 1, true}, {t2, 2, 2, true}}, {{t1 - kMs, 5, 5, true}, {t2 + kMs, 3, 3, true}}},
      r);
  EXPECT_EQ(out, (std::vector<Event>{{t1, 1, 1, true}, {t2, 2, 2, true}, {t2 + kMs, 3, 3, true}}));
  EXPECT_EQ(dropped(r, "event time far ahead of the stream"), 0u);
  EXPECT_EQ(dropped(r, "event timestamp went backwards"), 1u);
  EXPECT_EQ(s.last_time(), t2 + kMs);
}

TEST(EventSanitizer, TheFirstEventSetsTheTimeWhateverItIs) {
  // Nothing to compare the first event with: it is kept; a jump of exactly the limit is kept too.
  EventSanitizer s(10, 10);
  ReadReport r;
  const TimeNs t0 = 123'456 * kMs;
  const auto out =
      run(s, {{{t0, 1, 1, true}, {t0 + EventSanitizer::kMaxForwardJumpNs, 1, 1, true}}}, r);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_TRUE(r.dropped().empty());
}

}  // namespace
}  // namespace fdv
