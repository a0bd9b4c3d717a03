// EVT 3.0 writer: what it writes decodes to the same events with the RAW reader, across counter
// wraps (gaps longer than the 24-bit µs range) and with an epoch time restored from the header.
#include <gtest/gtest.h>

#include <random>

#include "fdv/core/error.h"
#include "fdv/io/prophesee/evt3_writer.h"
#include "fdv/io/recording.h"
#include "test_support.h"

namespace fdv {
namespace {

std::vector<Event> read_all(const std::string& path, std::size_t chunk = 4096) {
  ReaderOptions o;
  o.chunk_events = chunk;
  auto r = open_recording(path, o);
  EXPECT_EQ(r->info().format, "evt3");
  std::vector<Event> out;
  SensorChunk c;
  while (r->read(c)) out.insert(out.end(), c.events.begin(), c.events.end());
  EXPECT_EQ(r->report().total_dropped(), 0u);
  return out;
}

TEST(Evt3Writer, DecodesToTheSameEventsAcrossWrapsWithTheEpochRestored) {
  const std::string path = test::scratch_dir("evt3_writer") + "/out.raw";
  std::mt19937 rng(3);
  std::vector<Event> events;
  TimeNs t = 1'700'000'000'123'456'000;  // an epoch time, whole µs
  for (int i = 0; i < 50000; ++i) {
    if (i == 20000) t += 40'000'000'000;  // 40 s without events: more than two wraps of 16.8 s
    if (i == 30000) t += 16'777'216'000;  // exactly one wrap
    t += static_cast<TimeNs>(rng() % 50) * 1000;
    events.push_back({t, static_cast<std::uint16_t>(rng() % 1280), static_cast<std::uint16_t>(rng() % 720),
                      (rng() & 1) != 0});
  }
  Evt3Writer w(path, 1280, 720);
  w.add(std::span(events).first(777));
  w.add(std::span(events).subspan(777));
  w.close();
  EXPECT_EQ(w.events(), events.size());
  EXPECT_EQ(w.floored_events(), 0u);
  EXPECT_EQ(read_all(path), events);
  EXPECT_EQ(read_all(path, 1), events);
}

TEST(Evt3Writer, SensorBeyondElevenBitsAndBackwardsTimeAreErrors) {
  const std::string path = test::scratch_dir("evt3_writer_bad") + "/out.raw";
  EXPECT_THROW(Evt3Writer(path, 4096, 720), ConfigError);
  Evt3Writer w(path, 64, 64);
  const std::vector<Event> events{{5000, 1, 1, true}, {4000, 1, 1, true}, {6000, 64, 1, true}};
  EXPECT_EQ(test::input_error_of(path, [&] { w.add(std::span(events).first(2)); }),
            "event 1 | time goes backwards (4 µs after 5 µs)");
  EXPECT_EQ(test::input_error_of(path, [&] { w.add(std::span(events).subspan(2)); }),
            "event 1 | pixel (64, 1) outside the 64x64 sensor");
}

}  // namespace
}  // namespace fdv
