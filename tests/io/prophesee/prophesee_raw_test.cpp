// Prophesee RAW (EVT 2.0 / EVT 3.0) reader. Expectations come from (a) a deliberately simple,
// separate decoder written below (one word at a time, no shared code), (b) values decoded by hand
// from the files' bytes (xxd), (c) the independent figures in shared/data/README.md, and
// (d) small synthetic byte streams whose every event is known.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/prophesee/prophesee_raw_reader.h"
#include "fdv/io/recording.h"
#include "evt_words.h"
#include "test_support.h"

namespace fdv {
namespace {

using test::dropped;
using test::th2;

ReaderOptions chunked(std::size_t chunk_events) {
  ReaderOptions o;
  o.chunk_events = chunk_events;
  return o;
}
PropheseeRawOptions buffered(std::size_t read_buffer_bytes) {
  PropheseeRawOptions o;
  o.read_buffer_bytes = read_buffer_bytes;
  return o;
}

// ---------------------------------------------------------------------------------------------
// Independent reference decoder: reads the whole file, skips "% " lines, assembles each
// little-endian word from its bytes and applies the format page's bit layout literally.

std::vector<unsigned char> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::size_t skip_header(const std::vector<unsigned char>& b) {
  std::size_t p = 0;
  while (p + 1 < b.size() && b[p] == '%' && b[p + 1] == ' ') {
    while (b[p] != '\n') ++p;
    ++p;
  }
  return p;
}

std::vector<Event> reference_evt2(const std::string& path) {
  const auto b = file_bytes(path);
  std::vector<Event> out;
  std::uint64_t high = 0;
  bool have_high = false;
  for (std::size_t p = skip_header(b); p + 4 <= b.size(); p += 4) {
    const std::uint32_t w = std::uint32_t{b[p]} | std::uint32_t{b[p + 1]} << 8 |
                            std::uint32_t{b[p + 2]} << 16 | std::uint32_t{b[p + 3]} << 24;
    const std::uint32_t type = w >> 28;
    if (type == 8) {
      high = w & 0x0FFFFFFF;
      have_high = true;
    } else if ((type == 0 || type == 1) && have_high) {
      const std::uint64_t t_us = high * 64 + ((w >> 22) & 63);
      out.push_back({static_cast<TimeNs>(t_us * 1000), static_cast<std::uint16_t>((w >> 11) & 2047),
                     static_cast<std::uint16_t>(w & 2047), type == 1});
    }
  }
  return out;
}

std::vector<Event> reference_evt3(const std::string& path) {
  const auto b = file_bytes(path);
  std::vector<Event> out;
  std::uint64_t high = 0, low = 0;
  bool have_high = false;
  int y = 0, base = 0;
  bool pol = false;
  for (std::size_t p = skip_header(b); p + 2 <= b.size(); p += 2) {
    const unsigned w = b[p] | (b[p + 1] << 8);
    const unsigned type = w >> 12;
    const TimeNs t = static_cast<TimeNs>(((high << 12) | low) * 1000);
    if (type == 0x8) {
      high = w & 0xFFF;
      have_high = true;
    } else if (type == 0x6) {
      low = w & 0xFFF;
    } else if (type == 0x0) {
      y = w & 0x7FF;
    } else if (type == 0x2) {
      if (have_high)
        out.push_back({t, static_cast<std::uint16_t>(w & 0x7FF), static_cast<std::uint16_t>(y),
                       ((w >> 11) & 1) == 1});
    } else if (type == 0x3) {
      base = w & 0x7FF;
      pol = ((w >> 11) & 1) == 1;
    } else if (type == 0x4 || type == 0x5) {
      const int n = type == 0x4 ? 12 : 8;
      for (int i = 0; i < n; ++i)
        if (((w >> i) & 1) && have_high)
          out.push_back(
              {t, static_cast<std::uint16_t>(base + i), static_cast<std::uint16_t>(y), pol});
      base += n;
    }
  }
  return out;
}

struct ReadAll {
  std::vector<Event> events;
  std::vector<std::size_t> chunk_sizes;
};

ReadAll read_all(RecordingReader& r) {
  ReadAll all;
  SensorChunk c;
  while (r.read(c)) {
    all.chunk_sizes.push_back(c.events.size());
    all.events.insert(all.events.end(), c.events.begin(), c.events.end());
  }
  return all;
}

bool has_note(const RecordingInfo& info, const std::string& text) {
  for (const auto& n : info.notes)
    if (n.find(text) != std::string::npos) return true;
  return false;
}

// ---------------------------------------------------------------------------------------------
// Real recordings.

TEST(PropheseeRaw, RealEvt2MatchesReferenceDecoderAndHandDecodedBytes) {
  const std::string path = test::real_data("gen3_sparks_evt2.raw");
  FDV_REQUIRE_REAL_FILE(path);
  auto reader = open_recording(path, chunked(50'000));
  EXPECT_EQ(reader->info().format, "evt2");
  EXPECT_EQ(reader->info().width, 640);  // old header: size from plugin_name hal_plugin_gen3_fx3
  EXPECT_EQ(reader->info().height, 480);
  const ReadAll all = read_all(*reader);
  const std::vector<Event> ref = reference_evt2(path);

  EXPECT_EQ(all.events.size(), 521'252u);  // shared/data/README.md
  EXPECT_EQ(all.events, ref);
  // Hand-decoded with `xxd -s 150 -l 48`: the header ends at byte 166 ("% evt 2.0\n"); then
  //   d0 d8 d9 80 -> 0x80D9D8D0: TIME_HIGH, payload 0x0D9D8D0 = 14276816 -> 14276816*64 us
  //   bb 19 01 10 -> 0x100119BB: CD_ON, ts low (bits 27..22) 0, x (21..11) 0x023 = 35,
  //                               y (10..0) 0x1BB = 443
  ASSERT_FALSE(all.events.empty());
  EXPECT_EQ(all.events.front(), (Event{913'716'224'000, 35, 443, true}));
  // Last TIME_HIGH at byte 2109018: a9 de d9 80 -> 0x0D9DEA9 = 14278313 -> 913812032 us;
  // last word d7 61 c0 0f -> 0x0FC061D7: CD_OFF, ts low 63, x 12, y 471.
  EXPECT_EQ(all.events.back(), (Event{913'812'095'000, 12, 471, false}));
  EXPECT_NEAR(to_seconds(all.events.back().t - all.events.front().t), 0.096, 0.001);
  EXPECT_EQ(reader->report().total_dropped(), 0u);
  EXPECT_TRUE(reader->report().repaired().empty());
  // EVT 2.0 yields at most one event per word: every chunk but the last is exactly the request.
  for (std::size_t i = 0; i + 1 < all.chunk_sizes.size(); ++i)
    EXPECT_EQ(all.chunk_sizes[i], 50'000u);
}

TEST(PropheseeRaw, RealEvt3MatchesReferenceDecoderAndHandDecodedBytes) {
  const std::string path = test::real_data("gen41_street_evt3.raw");
  FDV_REQUIRE_REAL_FILE(path);
  auto reader = open_recording(path, chunked(20'000));
  EXPECT_EQ(reader->info().format, "evt3");
  EXPECT_EQ(reader->info().width, 1280);  // size from plugin_name hal_plugin_gen41_evk3
  EXPECT_EQ(reader->info().height, 720);
  const ReadAll all = read_all(*reader);
  const std::vector<Event> ref = reference_evt3(path);

  EXPECT_EQ(all.events.size(), 219'596u);  // shared/data/README.md
  EXPECT_EQ(all.events, ref);
  // Hand-decoded with `xxd -s 150 -l 32`: the header ends at byte 166; then
  //   2d 8b -> 0x8B2D TIME_HIGH 0xB2D = 2861;  00 60 -> 0x6000 TIME_LOW 0
  //   c8 00 -> 0x00C8 ADDR_Y 200;              6a 23 -> 0x236A ADDR_X, pol bit 11 = 0, x 0x36A =
  //   874 t = 2861 * 4096 + 0 = 11718656 us
  ASSERT_FALSE(all.events.empty());
  EXPECT_EQ(all.events.front(), (Event{11'718'656'000, 874, 200, false}));
  // Tail: 2f 8b at byte 617922 TIME_HIGH 0xB2F = 2863; 61 62 at 617988 TIME_LOW 0x261 = 609;
  // ... 3c 02 ADDR_Y 572, aa 20 ADDR_X 170, e1 24 ADDR_X 1249, c2 2c -> 0x2CC2 ADDR_X pol 1 x 1218,
  // 62 62 TIME_LOW (no event follows). t = 2863 * 4096 + 609 = 11727457 us.
  EXPECT_EQ(all.events.back(), (Event{11'727'457'000, 1218, 572, true}));
  EXPECT_NEAR(to_seconds(all.events.back().t - all.events.front().t), 0.0088, 0.0001);
  EXPECT_EQ(reader->report().total_dropped(), 0u);
  // A vector word can add up to 11 events beyond the request.
  for (std::size_t i = 0; i + 1 < all.chunk_sizes.size(); ++i) {
    EXPECT_GE(all.chunk_sizes[i], 20'000u);
    EXPECT_LE(all.chunk_sizes[i], 20'011u);
  }
}

TEST(PropheseeRaw, DecoderStateSurvivesAnyBufferSplit) {
  for (const char* name : {"gen3_sparks_evt2.raw", "gen41_street_evt3.raw"}) {
    const std::string path = test::real_data(name);
    FDV_REQUIRE_REAL_FILE(path);
    const bool evt2 = std::string(name).find("evt2") != std::string::npos;
    const auto ref = evt2 ? reference_evt2(path) : reference_evt3(path);
    for (std::size_t buffer :
         {4u, 12u, 4100u}) {  // splits inside vectors, between TIME_HIGH/LOW...
      auto reader = open_prophesee_raw(path, chunked(7'777), buffered(buffer));
      EXPECT_EQ(read_all(*reader).events, ref) << name << " buffer " << buffer;
    }
  }
}

TEST(PropheseeRaw, RandomCorruptionAfterTheHeaderIsAlwaysRecoverable) {
  // Bytes changed anywhere after the header, or the file cut anywhere, never throw or crash
  // (the sanitizer build runs this too): whatever is decoded keeps the stream contract, pixels
  // inside the sensor and time never going back.
  for (const char* name : {"gen3_sparks_evt2.raw", "gen41_street_evt3.raw"}) {
    const std::string src = test::real_data(name);
    FDV_REQUIRE_REAL_FILE(src);
    const std::vector<unsigned char> f = file_bytes(src);
    const std::size_t header = skip_header(f);
    const std::string path = test::scratch_dir("prophesee_fuzz") + "/f.raw";
    std::mt19937 rng(20261122);
    std::uniform_int_distribution<std::size_t> pos(header, f.size() - 1);
    std::uniform_int_distribution<int> byte(0, 255), count(1, 8);
    for (int trial = 0; trial < 40; ++trial) {
      std::vector<unsigned char> g = f;
      if (trial % 4 == 3) {
        g.resize(pos(rng));  // cut, possibly inside a word
      } else {
        for (int k = count(rng); k > 0; --k) g[pos(rng)] = static_cast<unsigned char>(byte(rng));
      }
      std::ofstream(path, std::ios::binary)
          .write(reinterpret_cast<const char*>(g.data()), static_cast<std::streamsize>(g.size()));
      ReadAll all;
      int width = 0, height = 0;
      ASSERT_NO_THROW({
        auto reader = open_prophesee_raw(path, chunked(20'000), buffered(4096));
        width = reader->info().width;
        height = reader->info().height;
        all = read_all(*reader);
      }) << name
         << " trial " << trial;
      for (std::size_t i = 0; i < all.events.size(); ++i) {
        ASSERT_LT(all.events[i].x, width) << name << " trial " << trial;
        ASSERT_LT(all.events[i].y, height) << name << " trial " << trial;
        if (i > 0) {
          ASSERT_GE(all.events[i].t, all.events[i - 1].t)
              << name << " trial " << trial << " event " << i;
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Synthetic streams: a tiny writer, words built from the format pages' bit layouts.

class RawWriter {
 public:
  explicit RawWriter(std::string header) : bytes_(std::move(header)) {}
  std::size_t data_offset() const { return offset_; }
  RawWriter& end_header() {
    offset_ = bytes_.size();
    return *this;
  }
  RawWriter& w32(std::uint32_t w) {
    for (int i = 0; i < 4; ++i) bytes_.push_back(static_cast<char>((w >> (8 * i)) & 0xFF));
    return *this;
  }
  RawWriter& w16(std::uint32_t w) {
    bytes_.push_back(static_cast<char>(w & 0xFF));
    bytes_.push_back(static_cast<char>((w >> 8) & 0xFF));
    return *this;
  }
  RawWriter& raw(const std::string& s) {
    bytes_ += s;
    return *this;
  }
  std::string write(const std::string& name) const {
    const std::string path = test::scratch_dir("prophesee_" + name) + "/" + name + ".raw";
    std::ofstream(path, std::ios::binary) << bytes_;
    return path;
  }

 private:
  std::string bytes_;
  std::size_t offset_ = 0;
};

// EVT 2.0 words.
std::uint32_t cd(bool on, std::uint32_t t_low, std::uint32_t x, std::uint32_t y) {
  return (on ? 1u : 0u) << 28 | t_low << 22 | x << 11 | y;
}
// EVT 3.0 words.
std::uint32_t addr_y(std::uint32_t y) { return y; }
std::uint32_t addr_x(std::uint32_t x, bool on) { return 0x2000u | (on ? 0x800u : 0u) | x; }
std::uint32_t base_x(std::uint32_t x, bool on) { return 0x3000u | (on ? 0x800u : 0u) | x; }
std::uint32_t vect12(std::uint32_t mask) { return 0x4000u | mask; }
std::uint32_t vect8(std::uint32_t mask) { return 0x5000u | mask; }
std::uint32_t tl3(std::uint32_t low) { return 0x6000u | low; }
std::uint32_t th3(std::uint32_t high) { return 0x8000u | high; }

constexpr TimeNs us(std::int64_t v) { return v * 1000; }

TEST(PropheseeRaw, Evt3VectorEvents) {
  RawWriter w("% evt 3.0\n% geometry 64x32\n");
  w.end_header().w16(th3(1)).w16(tl3(5)).w16(addr_y(3));
  w.w16(base_x(10, true)).w16(vect12(0b1000'0000'0101));  // x 10, 12, 21; base -> 22
  w.w16(vect8(0xF00 | 0b1000'0001));                      // bits 11..8 unused; x 22, 29; base -> 30
  w.w16(addr_x(40, false));                               // single event; does not move the base
  w.w16(vect12(0b1));                                     // x 30; base -> 42
  w.w16(vect12(0)).w16(vect8(0b10));  // an empty vector still advances: base 54, then x 55
  auto reader = open_prophesee_raw(w.write("vectors"));
  const TimeNs t = us((1 << 12) + 5);
  const std::vector<Event> expected = {{t, 10, 3, true}, {t, 12, 3, true}, {t, 21, 3, true},
                                       {t, 22, 3, true}, {t, 29, 3, true}, {t, 40, 3, false},
                                       {t, 30, 3, true}, {t, 55, 3, true}};
  EXPECT_EQ(read_all(*reader).events, expected);
  EXPECT_EQ(reader->report().total_dropped(), 0u);
}

TEST(PropheseeRaw, Evt3NewTimeHighStartsItsPeriod) {
  RawWriter w("% evt 3.0\n% geometry 64x32\n");
  w.end_header().w16(th3(1)).w16(tl3(100)).w16(addr_y(0)).w16(addr_x(1, true));
  w.w16(th3(1)).w16(addr_x(2, true));  // repeated TIME_HIGH: TIME_LOW kept
  w.w16(th3(2)).w16(addr_x(3, true));  // new period, no TIME_LOW yet: period start
  w.w16(tl3(3)).w16(addr_x(4, true));
  auto reader = open_prophesee_raw(w.write("time_high_period"));
  const std::vector<Event> expected = {{us(4096 + 100), 1, 0, true},
                                       {us(4096 + 100), 2, 0, true},
                                       {us(8192), 3, 0, true},
                                       {us(8192 + 3), 4, 0, true}};
  EXPECT_EQ(read_all(*reader).events, expected);
}

TEST(PropheseeRaw, Evt3TimeWrapIsCountedAndRepaired) {
  RawWriter w("% evt 3.0\n% geometry 64x32\n");
  w.end_header().w16(th3(0xFFF)).w16(tl3(0xFFE)).w16(addr_y(1)).w16(addr_x(1, false));
  w.w16(th3(0x000)).w16(tl3(1)).w16(addr_x(2, false));  // word index 4
  w.w16(th3(0x000)).w16(tl3(2)).w16(addr_x(3, false));
  auto reader = open_prophesee_raw(w.write("evt3_wrap"));
  const std::vector<Event> expected = {{us(0xFFFFFE), 1, 1, false},
                                       {us((1 << 24) + 1), 2, 1, false},
                                       {us((1 << 24) + 2), 3, 1, false}};
  EXPECT_EQ(read_all(*reader).events, expected);
  const auto& repaired = reader->report().repaired();
  ASSERT_EQ(repaired.count("time counter wrapped"), 1u);
  EXPECT_EQ(repaired.at("time counter wrapped").count, 1u);
  EXPECT_EQ(repaired.at("time counter wrapped").first_where,
            "byte " + std::to_string(w.data_offset() + 4 * 2));
  EXPECT_EQ(reader->report().total_dropped(), 0u);
}

TEST(PropheseeRaw, Evt2TimeWrapIsCountedAndRepaired) {
  RawWriter w("% evt 2.0\n% geometry 64x32\n");
  w.end_header().w32(th2(0x0FFFFFFF)).w32(cd(true, 63, 5, 6));
  w.w32(th2(0)).w32(cd(false, 0, 7, 8));
  auto reader = open_prophesee_raw(w.write("evt2_wrap"));
  const std::int64_t two34 = std::int64_t{1} << 34;
  const std::vector<Event> expected = {{us(two34 - 1), 5, 6, true}, {us(two34), 7, 8, false}};
  EXPECT_EQ(read_all(*reader).events, expected);
  EXPECT_EQ(reader->report().repaired().at("time counter wrapped").count, 1u);
}

TEST(PropheseeRaw, TimeHighGoingBackwardsDropsEventsUntilTimeRecovers) {
  {  // EVT 2.0: 100 -> 99 (a small step back, not a wrap) -> 100
    RawWriter w("% evt 2.0\n% geometry 64x32\n");
    w.end_header().w32(th2(100)).w32(cd(true, 10, 1, 1));
    w.w32(th2(99)).w32(cd(true, 0, 2, 2)).w32(cd(true, 63, 3, 3));
    w.w32(th2(100)).w32(cd(true, 10, 4, 4)).w32(cd(true, 11, 5, 5));
    auto reader = open_prophesee_raw(w.write("evt2_backwards"));
    const std::vector<Event> expected = {
        {us(6400 + 10), 1, 1, true}, {us(6400 + 10), 4, 4, true}, {us(6400 + 11), 5, 5, true}};
    EXPECT_EQ(read_all(*reader).events, expected);
    EXPECT_EQ(dropped(reader->report(), "event timestamp went backwards"), 2u);
    EXPECT_TRUE(reader->report().repaired().empty());
    EXPECT_TRUE(has_note(reader->info(), "TIME_HIGH went backwards 1 time"));
  }
  {  // EVT 3.0: 10 -> 9 -> 10
    RawWriter w("% evt 3.0\n% geometry 64x32\n");
    w.end_header().w16(th3(10)).w16(tl3(0)).w16(addr_y(0)).w16(addr_x(1, true));
    w.w16(th3(9)).w16(tl3(4000)).w16(addr_x(2, true));
    w.w16(th3(10)).w16(tl3(5)).w16(addr_x(3, true));
    auto reader = open_prophesee_raw(w.write("evt3_backwards"));
    const std::vector<Event> expected = {{us(10 * 4096), 1, 0, true},
                                         {us(10 * 4096 + 5), 3, 0, true}};
    EXPECT_EQ(read_all(*reader).events, expected);
    EXPECT_EQ(dropped(reader->report(), "event timestamp went backwards"), 1u);
    EXPECT_TRUE(reader->report().repaired().empty());
  }
}

TEST(PropheseeRaw, TimeHighFarAheadIsHeldUntilTheNextOneDecides) {
  const std::string glitch_reason =
      "event under a TIME_HIGH far ahead of the stream (held until the next TIME_HIGH)";
  {  // EVT 2.0: 100 -> 100 + 2^20 (67 s ahead: a corrupt word) -> 101. Without the hold, every
     // later event would be "behind" the corrupt time and dropped.
    RawWriter w("% evt 2.0\n% geometry 64x32\n");
    w.end_header().w32(th2(100)).w32(cd(true, 10, 1, 1));
    w.w32(th2(100 + (1 << 20))).w32(cd(true, 0, 2, 2)).w32(cd(false, 1, 3, 3));  // words 2-4
    w.w32(th2(101)).w32(cd(true, 5, 4, 4));
    w.w32(th2(102)).w32(cd(true, 6, 5, 5));
    auto reader = open_prophesee_raw(w.write("evt2_glitch"));
    const std::vector<Event> expected = {
        {us(6400 + 10), 1, 1, true}, {us(6464 + 5), 4, 4, true}, {us(6528 + 6), 5, 5, true}};
    EXPECT_EQ(read_all(*reader).events, expected);
    ASSERT_EQ(dropped(reader->report(), glitch_reason), 2u);
    EXPECT_EQ(reader->report().dropped().at(glitch_reason).first_where,
              "byte " + std::to_string(w.data_offset() + 4 * 3));
    EXPECT_EQ(dropped(reader->report(), "event timestamp went backwards"), 0u);
    EXPECT_TRUE(has_note(reader->info(), "came back 1 time(s)"));
  }
  {  // EVT 2.0: a real jump of 67 s (the next TIME_HIGH follows it): the held period's events
     // are lost, the stream goes on from the new time.
    RawWriter w("% evt 2.0\n% geometry 64x32\n");
    const std::uint32_t far = 100 + (1 << 20);
    w.end_header().w32(th2(100)).w32(cd(true, 10, 1, 1));
    w.w32(th2(far)).w32(cd(true, 0, 2, 2));
    w.w32(th2(far + 1)).w32(cd(true, 5, 4, 4)).w32(cd(true, 6, 6, 6));  // (EventSanitizer: a
    // first event far ahead is kept once the next one confirms it)
    auto reader = open_prophesee_raw(w.write("evt2_jump"));
    const std::vector<Event> expected = {{us(6400 + 10), 1, 1, true},
                                         {us(std::int64_t{far + 1} * 64 + 5), 4, 4, true},
                                         {us(std::int64_t{far + 1} * 64 + 6), 6, 6, true}};
    EXPECT_EQ(read_all(*reader).events, expected);
    EXPECT_EQ(dropped(reader->report(), glitch_reason), 1u);
    EXPECT_FALSE(has_note(reader->info(), "came back"));
  }
  {  // EVT 3.0: 10 -> 10 + 1000 (4.1 s ahead; without the hold the next word, 11, would be a
     // step back and every event dropped for 4 s) -> 11.
    RawWriter w("% evt 3.0\n% geometry 64x32\n");
    w.end_header().w16(th3(10)).w16(tl3(0)).w16(addr_y(0)).w16(addr_x(1, true));
    w.w16(th3(1010)).w16(tl3(7)).w16(addr_x(2, true)).w16(vect12(0x3)).w16(base_x(8, false));
    w.w16(th3(11)).w16(tl3(5)).w16(addr_x(3, true));
    auto reader = open_prophesee_raw(w.write("evt3_glitch"));
    const std::vector<Event> expected = {{us(10 * 4096), 1, 0, true},
                                         {us(11 * 4096 + 5), 3, 0, true}};
    EXPECT_EQ(read_all(*reader).events, expected);
    EXPECT_EQ(dropped(reader->report(), glitch_reason), 1u + 2u);  // ADDR_X, then VECT_12 bits 0-1
    EXPECT_EQ(dropped(reader->report(), "event timestamp went backwards"), 0u);
    EXPECT_TRUE(reader->report().repaired().empty());  // nor taken for a wrap
    EXPECT_TRUE(has_note(reader->info(), "came back 1 time(s)"));
  }
}

TEST(PropheseeRaw, ACorruptTimeHighInARealRecordingCostsOnlyItsPeriod) {
  // One TIME_HIGH word in the middle of the real EVT 2.0 recording moved 100000 periods (6.4 s)
  // ahead. The plain decoder (above) gives the events under it that far-future time; the reader
  // drops those and nothing else (before the hold: 195 485 events, the rest of the file).
  const std::string src = test::real_data("gen3_sparks_evt2.raw");
  FDV_REQUIRE_REAL_FILE(src);
  std::vector<unsigned char> b = file_bytes(src);
  std::vector<std::size_t> time_highs;
  for (std::size_t p = skip_header(b); p + 4 <= b.size(); p += 4)
    if (b[p + 3] >> 4 == 8) time_highs.push_back(p);
  const std::size_t p = time_highs[time_highs.size() / 2];
  std::uint32_t w;
  std::memcpy(&w, &b[p], 4);
  const std::uint32_t corrupt = (w & 0xF0000000u) | ((w & 0x0FFFFFFFu) + 100'000);
  std::memcpy(&b[p], &corrupt, 4);
  const std::string path = test::scratch_dir("prophesee_time_high_glitch") + "/g.raw";
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));

  const TimeNs glitch_ns = static_cast<TimeNs>(corrupt & 0x0FFFFFFFu) * 64 * 1000;
  std::vector<Event> expected;
  std::size_t under_glitch = 0;
  for (const Event& e : reference_evt2(path)) {
    if (e.t >= glitch_ns) {
      ++under_glitch;
    } else {
      expected.push_back(e);
    }
  }
  ASSERT_GT(under_glitch, 0u);
  auto reader = open_prophesee_raw(path, chunked(50'000));
  EXPECT_EQ(read_all(*reader).events, expected);
  EXPECT_EQ(reader->report().total_dropped(), under_glitch);
  EXPECT_TRUE(has_note(reader->info(), "came back 1 time(s)"));
}

TEST(PropheseeRaw, OutOfRangeCoordinatesAreDroppedAndCounted) {
  {
    RawWriter w("% evt 2.0\n% geometry 64x32\n");
    w.end_header()
        .w32(th2(1))
        .w32(cd(true, 0, 64, 0))
        .w32(cd(true, 0, 63, 31))
        .w32(cd(false, 0, 0, 32));
    auto reader = open_prophesee_raw(w.write("evt2_range"));
    EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(64), 63, 31, true}}));
    EXPECT_EQ(dropped(reader->report(), "event pixel outside the sensor"), 2u);
  }
  {
    RawWriter w("% evt 3.0\n% geometry 64x32\n");
    w.end_header()
        .w16(th3(0))
        .w16(tl3(0))
        .w16(addr_y(31))
        .w16(base_x(60, false))
        .w16(vect12(0xFFF));
    w.w16(addr_y(32)).w16(addr_x(0, true));
    auto reader = open_prophesee_raw(w.write("evt3_range"));
    const auto events = read_all(*reader).events;
    ASSERT_EQ(events.size(), 4u);  // x 60..63 of row 31; 64..71 and row 32 are outside
    EXPECT_EQ(events.front().x, 60);
    EXPECT_EQ(events.back().x, 63);
    EXPECT_EQ(dropped(reader->report(), "event pixel outside the sensor"), 9u);
  }
}

TEST(PropheseeRaw, TruncatedTrailingWordIsDroppedAndCounted) {
  {
    RawWriter w("% evt 2.0\n% geometry 64x32\n");
    w.end_header().w32(th2(1)).w32(cd(true, 1, 2, 3)).raw("\x01\x02\x03");
    auto reader = open_prophesee_raw(w.write("evt2_truncated"));
    EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(65), 2, 3, true}}));
    EXPECT_EQ(dropped(reader->report(), "truncated trailing word"), 1u);
    EXPECT_EQ(reader->report().dropped().at("truncated trailing word").first_where,
              "byte " + std::to_string(w.data_offset() + 8));
  }
  {
    RawWriter w("% evt 3.0\n% geometry 64x32\n");
    w.end_header().w16(th3(0)).w16(tl3(7)).w16(addr_y(1)).w16(addr_x(2, false)).raw("\x05");
    auto reader = open_prophesee_raw(w.write("evt3_truncated"));
    EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(7), 2, 1, false}}));
    EXPECT_EQ(dropped(reader->report(), "truncated trailing word"), 1u);
  }
}

TEST(PropheseeRaw, UnknownTriggerAndVendorWordsAreSkippedAndCounted) {
  {
    RawWriter w("% evt 2.0\n% geometry 64x32\n");
    w.end_header().w32(th2(2)).w32(0x3u << 28).w32(cd(true, 0, 1, 1)).w32(0xBu << 28 | 12345);
    w.w32(0xAu << 28 | 1).w32(0xAu << 28).w32(0xEu << 28).w32(0xFu << 28).w32(cd(false, 1, 2, 2));
    auto reader = open_prophesee_raw(w.write("evt2_unknown"));
    EXPECT_EQ(read_all(*reader).events,
              (std::vector<Event>{{us(128), 1, 1, true}, {us(129), 2, 2, false}}));
    EXPECT_EQ(dropped(reader->report(), "unknown EVT 2.0 word type"), 2u);
    EXPECT_EQ(reader->report().dropped().at("unknown EVT 2.0 word type").first_where,
              "byte " + std::to_string(w.data_offset() + 4));
    EXPECT_TRUE(has_note(reader->info(), "external trigger words skipped: 2"));
    EXPECT_TRUE(has_note(reader->info(), "vendor words (OTHERS / CONTINUED) skipped: 2"));
  }
  {
    RawWriter w("% evt 3.0\n% geometry 64x32\n");
    w.end_header().w16(th3(0)).w16(tl3(1)).w16(addr_y(1));
    w.w16(0x1000).w16(0x9000).w16(0xB000).w16(0xC000).w16(0xD123);  // reserved types
    w.w16(0xA001).w16(0x7000).w16(0xE000).w16(0xF000).w16(addr_x(3, true));
    auto reader = open_prophesee_raw(w.write("evt3_unknown"));
    EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(1), 3, 1, true}}));
    EXPECT_EQ(dropped(reader->report(), "unknown EVT 3.0 word type"), 5u);
    EXPECT_TRUE(has_note(reader->info(), "external trigger words skipped: 1"));
    EXPECT_TRUE(has_note(reader->info(), "vendor words (OTHERS / CONTINUED) skipped: 3"));
  }
}

TEST(PropheseeRaw, EventsBeforeTheirStateIsKnownAreDroppedAndCounted) {
  {
    RawWriter w("% evt 2.0\n% geometry 64x32\n");
    w.end_header().w32(cd(true, 0, 1, 1)).w32(cd(true, 0, 2, 2)).w32(th2(3)).w32(cd(true, 0, 3, 3));
    auto reader = open_prophesee_raw(w.write("evt2_before"));
    EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(192), 3, 3, true}}));
    EXPECT_EQ(dropped(reader->report(), "event before the first TIME_HIGH"), 2u);
    EXPECT_EQ(reader->report().dropped().at("event before the first TIME_HIGH").first_where,
              "byte " + std::to_string(w.data_offset()));
  }
  {
    RawWriter w("% evt 3.0\n% geometry 64x32\n");
    w.end_header().w16(addr_y(1)).w16(addr_x(1, true)).w16(base_x(0, true)).w16(vect8(0b11));
    w.w16(th3(1)).w16(tl3(0)).w16(addr_x(2, true));  // row known from before: kept
    auto reader = open_prophesee_raw(w.write("evt3_before"));
    EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(4096), 2, 1, true}}));
    EXPECT_EQ(dropped(reader->report(), "event before the first TIME_HIGH"), 3u);
  }
  {
    RawWriter w("% evt 3.0\n% geometry 64x32\n");
    w.end_header().w16(th3(1)).w16(tl3(0)).w16(addr_x(1, true)).w16(addr_y(2));
    w.w16(vect12(0b111)).w16(base_x(5, false)).w16(vect12(0b1));
    auto reader = open_prophesee_raw(w.write("evt3_no_address"));
    EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(4096), 5, 2, false}}));
    EXPECT_EQ(dropped(reader->report(), "event before the first ADDR_Y / VECT_BASE_X"), 4u);
  }
}

TEST(PropheseeRaw, EndKeywordTerminatesTheHeader) {
  // The first data word, ADDR_X 0x2025, is stored as the bytes '%' ' ': without "% end" it
  // would read as a header line. It comes before any TIME_HIGH, so it is dropped and counted.
  RawWriter w("% evt 3.0\n% geometry 64x32\n% end\n");
  w.end_header().w16(0x2025).w16(th3(2)).w16(tl3(3)).w16(addr_y(4)).w16(addr_x(5, true));
  auto reader = open_prophesee_raw(w.write("end_keyword"));
  EXPECT_EQ(read_all(*reader).events, (std::vector<Event>{{us(2 * 4096 + 3), 5, 4, true}}));
  EXPECT_EQ(dropped(reader->report(), "event before the first TIME_HIGH"), 1u);
  EXPECT_EQ(reader->report().dropped().at("event before the first TIME_HIGH").first_where,
            "byte " + std::to_string(w.data_offset()));
}

TEST(PropheseeRaw, HeaderVariantsDecideEncodingAndGeometry) {
  const auto header_of = [](const std::string& text, const std::string& name) {
    return read_prophesee_raw_header(RawWriter(text).end_header().w16(0x8000).write(name));
  };
  auto h = header_of("% Date 2020\n% plugin_name hal_plugin_gen3_fx3\n", "old_gen3");
  EXPECT_EQ(h.encoding, "evt2");
  EXPECT_EQ(h.width, 640);
  EXPECT_EQ(h.height, 480);
  h = header_of("% plugin_name hal_plugin_gen41_evk3\n", "old_gen41");
  EXPECT_EQ(h.encoding, "evt3");
  EXPECT_EQ(h.width, 1280);
  EXPECT_EQ(h.height, 720);
  h = header_of("% evt 3.0\n% format EVT3;height=720;width=1280\n% plugin_name x\n", "format_line");
  EXPECT_EQ(h.width, 1280);
  EXPECT_EQ(h.height, 720);
  h = header_of("% format EVT2;height=240;width=320\n", "format_only");
  EXPECT_EQ(h.encoding, "evt2");
  EXPECT_EQ(h.width, 320);
  h = header_of("% evt 2.0\r\n% geometry 304x240\r\n% plugin_name hal_plugin_gen3_fx3\r\n", "crlf");
  EXPECT_EQ(h.width, 304);  // geometry wins over plugin_name
  EXPECT_EQ(h.height, 240);
  EXPECT_EQ(h.data_offset,
            std::string("% evt 2.0\r\n% geometry 304x240\r\n% plugin_name hal_plugin_gen3_fx3\r\n")
                .size());
}

void expect_header_error(const std::string& header, const std::string& name,
                         const std::string& where, const std::string& reason_part) {
  const std::string path = RawWriter(header).end_header().w16(0x8000).write(name);
  try {
    open_recording(path);
    ADD_FAILURE() << name << ": no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.where(), where) << name;
    EXPECT_NE(e.reason().find(reason_part), std::string::npos) << name << ": " << e.reason();
  }
}

TEST(PropheseeRaw, BadHeadersAreRejectedWithAReason) {
  expect_header_error("% evt 3.0\n% plugin_name hal_plugin_mystery\n", "no_geometry",
                      "key geometry", "no sensor size");
  expect_header_error("% evt 3.0\n", "no_geometry_no_plugin", "key geometry", "no sensor size");
  expect_header_error("% evt 2.0\n% geometry 640by480\n", "bad_geometry", "key geometry",
                      "WIDTHxHEIGHT");
  expect_header_error("% evt 2.1\n% geometry 320x320\n", "evt21", "key evt", "not supported");
  expect_header_error("% date 2020-01-01\n% geometry 64x32\n", "no_encoding", "key evt",
                      "names no event encoding");
  expect_header_error("% Date 2020-01-01\n% Version 2\n% Height 240\n% Width 304\n", "dat",
                      "byte 0", "DAT file");
  expect_header_error("% evt 3.0\n% geometry 64x32", "truncated_header", "byte 10",
                      "not terminated");
}

TEST(PropheseeRaw, ChunksAreAboutTheRequestedSizeAndConcatenateToTheStream) {
  RawWriter w("% evt 2.0\n% geometry 64x32\n");
  w.end_header();
  std::vector<Event> expected;
  for (std::uint32_t i = 0; i < 1000; ++i) {
    if (i % 64 == 0) w.w32(th2(i / 64));
    w.w32(cd(i % 2 == 1, i % 64, i % 64, i % 32));
    expected.push_back({us(i), static_cast<std::uint16_t>(i % 64),
                        static_cast<std::uint16_t>(i % 32), i % 2 == 1});
  }
  auto reader = open_prophesee_raw(w.write("chunks"), chunked(64), buffered(12));
  const ReadAll all = read_all(*reader);
  EXPECT_EQ(all.events, expected);
  ASSERT_EQ(all.chunk_sizes.size(), 16u);  // 15 x 64 + 40
  EXPECT_EQ(all.chunk_sizes.back(), 40u);
  SensorChunk after;
  EXPECT_FALSE(reader->read(after));
  EXPECT_TRUE(after.empty());
}

TEST(PropheseeRaw, OptionsAreValidated) {
  EXPECT_TRUE(PropheseeRawOptions{}.validate().empty());
  EXPECT_FALSE(buffered(6).validate().empty());
  EXPECT_FALSE(buffered(0).validate().empty());
  const std::string path = RawWriter("% evt 2.0\n% geometry 8x8\n").end_header().write("options");
  EXPECT_THROW(open_prophesee_raw(path, {}, buffered(6)), ConfigError);
}

}  // namespace
}  // namespace fdv
