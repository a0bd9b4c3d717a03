// Prophesee RAW reader on hostile input: the in-memory entry point, time counters
// wrapped until the time leaves int64 nanoseconds, header bytes that are not UTF-8. Inputs are
// built in memory word by word, or are the fuzzer's findings in ../shared/fuzz-findings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/prophesee/evt_decoder.h"
#include "fdv/io/prophesee/prophesee_raw_reader.h"
#include "fdv/io/recording.h"
#include "evt_words.h"
#include "test_support.h"

namespace fdv {
namespace {

using test::dropped;
using test::repaired;
using test::th2;

struct Result {
  std::vector<Event> events;
  ReadReport report;
  RecordingInfo info;
};

Result read_all(std::unique_ptr<RecordingReader> reader) {
  Result r;
  SensorChunk chunk;
  while (reader->read(chunk))
    r.events.insert(r.events.end(), chunk.events.begin(), chunk.events.end());
  r.report = reader->report();
  r.info = reader->info();
  return r;
}

Result read_bytes(const std::string& bytes, const std::string& name = "memory.raw") {
  return read_all(open_prophesee_raw(std::make_unique<std::istringstream>(bytes), name));
}

void put16(std::string& s, std::uint32_t w) {
  s.push_back(static_cast<char>(w & 0xFF));
  s.push_back(static_cast<char>((w >> 8) & 0xFF));
}
void put32(std::string& s, std::uint32_t w) {
  put16(s, w & 0xFFFF);
  put16(s, w >> 16);
}
// EVT 2.0 words.
std::uint32_t cd2(std::uint32_t t_low, std::uint32_t x, std::uint32_t y) {
  return 1u << 28 | t_low << 22 | x << 11 | y;
}

const std::string kEvt2Header = "% evt 2.0\n% geometry 640x480\n% end\n";
const std::string kEvt3Header = "% evt 3.0\n% geometry 1280x720\n% end\n";

// ---- in-memory entry point ------------------------------------------------------------------

TEST(PropheseeBadInput, StreamEntryPointReadsLikeThePath) {
  for (const char* name : {"gen3_sparks_evt2.raw", "gen41_street_evt3.raw"}) {
    const std::string path = test::real_data(name);
    FDV_REQUIRE_REAL_FILE(path);
    const Result by_path = read_all(open_prophesee_raw(path));
    std::ifstream in(path, std::ios::binary);
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    const Result by_stream = read_bytes(bytes, "in-memory copy");
    ASSERT_EQ(by_stream.events.size(), by_path.events.size()) << name;
    EXPECT_EQ(by_stream.events, by_path.events) << name;
    EXPECT_EQ(by_stream.info.notes, by_path.info.notes) << name;
    EXPECT_EQ(by_stream.info.path, "in-memory copy");
  }
}

TEST(PropheseeBadInput, StreamErrorsNameTheGivenName) {
  try {
    read_bytes("% evt 2.1\n% geometry 640x480\n% end\n", "fuzz-input-7");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "fuzz-input-7");
    EXPECT_EQ(e.where(), "key evt");
  }
}

TEST(PropheseeBadInput, FolderIsAnInputError) {
  const std::string dir = test::scratch_dir("prophesee_folder");
  try {
    open_prophesee_raw(dir);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir);
  }
}

// ---- f6: the time counter wrapped until the time leaves int64 ns -------------------------------

// Time counter periods whose every time fits int64 ns, after the first: the largest k with
// (k + 1) * period - 1 <= INT64_MAX / 1000 (period in us).
constexpr std::int64_t last_epoch(std::int64_t period_us) {
  return (std::numeric_limits<std::int64_t>::max() / kNsPerUs + 1) / period_us - 1;
}

TEST(PropheseeBadInput, Evt2EpochOverflowIsACountedDrop) {
  constexpr std::int64_t kPeriodUs = std::int64_t{1} << 34;
  constexpr std::int64_t kWraps = last_epoch(kPeriodUs);
  static_assert(kWraps == 536'869);
  constexpr std::uint32_t kMaxHigh = (1u << 28) - 1;
  std::string s = kEvt2Header;
  put32(s, th2(0));
  put32(s, cd2(5, 10, 20));
  // A wrap in three words: the jump to the top of the range is held (far ahead) until the second
  // word confirms it; the step back to 0 is then a wrap.
  for (std::int64_t k = 0; k < kWraps; ++k) {
    put32(s, th2(kMaxHigh));
    put32(s, th2(kMaxHigh));
    put32(s, th2(0));
  }
  // The last period that fits: two events at its very end (the second confirms the first's jump
  // to the EventSanitizer), then one more wrap, after which no time can be represented.
  put32(s, th2(kMaxHigh));
  put32(s, th2(kMaxHigh));
  put32(s, cd2(63, 11, 21));
  put32(s, cd2(63, 12, 22));
  put32(s, th2(0));
  put32(s, cd2(1, 13, 23));
  put32(s, cd2(2, 14, 24));

  const Result r = read_bytes(s);
  // The two at the end of the last period (9223372036854775000 ns) fit in int64 but are beyond
  // valid_time()'s 2^62 ns: corrupt times, dropped by the sanitizer.
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_EQ(r.events[0].t, 5 * kNsPerUs);
  EXPECT_EQ(dropped(r.report, "event time out of range (corrupt)"), 2u);
  EXPECT_EQ(repaired(r.report, "time counter wrapped"), static_cast<std::uint64_t>(kWraps));
  const std::string reason =
      "event time beyond the int64 nanosecond range (time counter wrapped too often)";
  EXPECT_EQ(dropped(r.report, reason), 2u);
  // The first event after the refused wrap: header, 2 words, 3 per wrap, 5 words.
  const std::size_t first = kEvt2Header.size() + 4 * (2 + 3 * kWraps + 5);
  EXPECT_EQ(r.report.dropped().at(reason).first_where, "byte " + std::to_string(first));
}

// EVT 3.0 needs about 550 million wraps (3.3 GB of words) to overflow: the decoder starts two
// wraps short of the last period that fits, and the words make the rest.
TEST(PropheseeBadInput, Evt3EpochOverflowIsACountedDrop) {
  constexpr std::int64_t kPeriodUs = std::int64_t{1} << 24;
  constexpr std::int64_t kWraps = last_epoch(kPeriodUs);
  static_assert(kWraps == 549'755'812);
  constexpr std::uint16_t kTop = 0x8FFF, kZero = 0x8000;  // TIME_HIGH 4095, 0
  Evt3Decoder decoder;
  EXPECT_FALSE(decoder.start_after_wraps(kWraps + 1));
  EXPECT_FALSE(decoder.start_after_wraps(std::numeric_limits<std::uint64_t>::max()));
  ASSERT_TRUE(decoder.start_after_wraps(kWraps - 2));
  std::vector<Event> out(64 + Evt3Decoder::kMaxEventsPerWord);
  DecodeCounts counts;
  std::size_t consumed = 0;
  // Time base at period kWraps - 2, row 7, an event at x = 3; two wraps in three words each
  // (the jump to 4095 is held until the second word confirms it); TIME_HIGH 4095, TIME_LOW
  // 4095: the last microsecond that fits; an event; a wrap that is refused; an event and a
  // vector of 3 events, which have no representable time.
  const std::uint16_t words[] = {kZero, 0x0007, 0x2003, kTop,   kTop,   kZero,  kTop,
                                 kTop,  kZero,  kTop,   kTop,   0x6FFF, 0x2004, kZero,
                                 0x2005, 0x3010, 0x4007};
  const std::size_t n = decoder.decode(words, std::size(words), out.data(), 64, consumed, counts);
  EXPECT_EQ(consumed, std::size(words));
  ASSERT_EQ(n, 2u);
  EXPECT_EQ(out[0].t, (kWraps - 2) * kPeriodUs * kNsPerUs);
  EXPECT_EQ(out[1].t, (kWraps * kPeriodUs + kPeriodUs - 1) * kNsPerUs);
  EXPECT_EQ(counts.wraps, 2u);
  EXPECT_EQ(counts.time_overflow, 4u);
  EXPECT_EQ(counts.first_time_overflow, 14u);
  // Later TIME_HIGH and TIME_LOW words do not bring the time back.
  const std::uint16_t more[] = {kTop, kTop, 0x6001, 0x2006};
  EXPECT_EQ(decoder.decode(more, std::size(more), out.data(), 64, consumed, counts), 0u);
  EXPECT_EQ(counts.time_overflow, 5u);
}

TEST(PropheseeBadInput, Evt2StartAfterWrapsIsChecked) {
  Evt2Decoder decoder;
  EXPECT_FALSE(decoder.start_after_wraps(536'870));
  EXPECT_TRUE(decoder.start_after_wraps(536'869));
}

// ---- f8: header bytes that are not UTF-8 ------------------------------------------------------

void expect_utf8_notes(const RecordingInfo& info) {
  std::string dumped;
  EXPECT_NO_THROW(dumped = nlohmann::json(info.notes).dump());
  for (const auto& note : info.notes)
    EXPECT_NO_THROW((void)nlohmann::json(note).dump()) << note;
}

TEST(PropheseeBadInput, NonUtf8HeaderValuesAreEscapedInNotes) {
  std::string s =
      "% serial_number \xFF\n% plugin_name hal_plugin_gen3\xC3(\n% date 2020\x80\n" + kEvt2Header;
  put32(s, th2(1));
  put32(s, cd2(0, 1, 1));
  const Result r = read_bytes(s);
  EXPECT_EQ(r.events.size(), 1u);
  expect_utf8_notes(r.info);
  const auto has = [&](const std::string& note) {
    return std::find(r.info.notes.begin(), r.info.notes.end(), note) != r.info.notes.end();
  };
  EXPECT_TRUE(has("serial_number: \\xFF"));
  EXPECT_TRUE(has("plugin_name: hal_plugin_gen3\\xC3("));
  EXPECT_TRUE(has("date: 2020\\x80"));
}

TEST(PropheseeBadInput, NonUtf8PluginNameAsTheSourceOfEncodingAndSize) {
  // No evt / geometry line: the plugin name decides both, and is quoted in two notes.
  std::string s = "% plugin_name gen3\xFE\n% end\n";
  put32(s, th2(1));
  const Result r = read_bytes(s);
  expect_utf8_notes(r.info);
  EXPECT_EQ(r.info.notes.at(0), "EVT 2.0 encoding, from the plugin_name 'gen3\\xFE' (no `evt` header line)");
}

TEST(PropheseeBadInput, NonUtf8ValueInAnErrorIsEscaped) {
  try {
    read_bytes("% evt \xFF\xFE\n% geometry 640x480\n% end\n");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.reason(), "EVT \\xFF\\xFE is not supported (only EVT 2.0 and 3.0)");
  }
}

TEST(PropheseeBadInput, NonUtf8HeaderFindings) {
  for (const char* name : {"evt2/f8-non-utf8-header-1.raw", "evt2/f8-non-utf8-header-2.raw"}) {
    const std::string path = test::fuzz_finding(name);
    FDV_REQUIRE_REAL_FILE(path);
    const Result r = read_all(open_prophesee_raw(path));
    expect_utf8_notes(r.info);
  }
  const Result r = read_all(open_prophesee_raw(test::fuzz_finding("evt2/f8-non-utf8-header-2.raw")));
  EXPECT_NE(std::find(r.info.notes.begin(), r.info.notes.end(), "serial_number: \\xFF"),
            r.info.notes.end());
}

}  // namespace
}  // namespace fdv
