// AEDAT 4.0 reader on bad and synthetic input: modified copies of a real recording (positions
// found by the independent decoder of aedat4_test_util.h) and small files built byte by byte
// with the test's own writer. Expectations are hand-computed or come from the independent decode.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "aedat4_test_util.h"
#include "fdv/core/error.h"
#include "fdv/io/aedat4/aedat4_reader.h"
#include "fdv/io/recording.h"
#include "test_support.h"

namespace fdv {
namespace {

using test::dropped;
using test::first_where;

using namespace test::aedat4;

constexpr const char* kBall = "davis346_ball_throw_person.aedat4";

Result read_file(const std::string& path, std::size_t chunk_events = 1 << 16) {
  ReaderOptions options;
  options.chunk_events = chunk_events;
  return read_all(open_aedat4(path, options));
}

std::vector<Event> converted(const std::vector<RawEvent>& raw, std::size_t first,
                             std::size_t last) {
  std::vector<Event> out;
  for (std::size_t i = first; i < last; ++i)
    out.push_back({raw[i].t_us * 1000, static_cast<std::uint16_t>(raw[i].x),
                   static_cast<std::uint16_t>(raw[i].y), raw[i].polarity});
  return out;
}

/// Expects open_aedat4(path) to throw InputError naming the file, `where` and `reason_part`.
void expect_input_error(const std::string& path, const std::string& where,
                        const std::string& reason_part) {
  try {
    open_aedat4(path);
    ADD_FAILURE() << "no InputError for " << path;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.where(), where) << e.what();
    EXPECT_NE(e.reason().find(reason_part), std::string::npos) << e.what();
  }
}

std::string at(std::uint64_t offset) { return "byte " + std::to_string(offset); }

// ---- unrecoverable: the header -------------------------------------------------------------

TEST(Aedat4BadInput, WrongMagic) {
  const std::string src = test::real_data(kBall);
  FDV_REQUIRE_REAL_FILE(src);
  Bytes f = read_bytes(src);
  f[9] = '3';  // "#!AER-DAT3.0"
  const std::string path = test::scratch_dir("aedat4_magic") + "/wrong_magic.aedat4";
  write_bytes(path, f);
  expect_input_error(path, "byte 0", "wrong magic");
  // open_recording does not take it for AEDAT 4 either.
  EXPECT_THROW(open_recording(path), InputError);
}

TEST(Aedat4BadInput, TruncatedHeader) {
  const std::string src = test::real_data(kBall);
  FDV_REQUIRE_REAL_FILE(src);
  const Bytes f = read_bytes(src);
  const std::string dir = test::scratch_dir("aedat4_truncated_header");
  // Cut inside the IOHeader (3108 bytes from byte 18): the size at byte 14 runs past the end.
  write_bytes(dir + "/a.aedat4", Bytes(f.begin(), f.begin() + 1000));
  expect_input_error(dir + "/a.aedat4", "byte 14", "truncated header");
  // Cut inside the size field.
  write_bytes(dir + "/b.aedat4", Bytes(f.begin(), f.begin() + 16));
  expect_input_error(dir + "/b.aedat4", "byte 14", "truncated header");
  // Cut inside the magic itself.
  write_bytes(dir + "/c.aedat4", Bytes(f.begin(), f.begin() + 10));
  expect_input_error(dir + "/c.aedat4", "byte 10", "truncated header");
}

TEST(Aedat4BadInput, HeaderIsNotAValidFlatBuffer) {
  const std::string src = test::real_data(kBall);
  FDV_REQUIRE_REAL_FILE(src);
  const std::string dir = test::scratch_dir("aedat4_bad_header");
  Bytes f = read_bytes(src);
  // Root offset (bytes 18-21) pointing far outside the 3108-byte buffer.
  Bytes a = f;
  a[18] = 0xF0;
  a[19] = 0xFF;
  a[20] = 0x00;
  write_bytes(dir + "/a.aedat4", a);
  expect_input_error(dir + "/a.aedat4", "byte 14", "not a valid FlatBuffer");
  // Wrong file identifier (bytes 22-25 are "IOHE").
  Bytes b = f;
  b[22] = 'X';
  write_bytes(dir + "/b.aedat4", b);
  expect_input_error(dir + "/b.aedat4", "byte 14", "not a valid FlatBuffer");
  // The infoNode string's length (at its start) made larger than the buffer.
  Bytes c = f;
  const std::uint8_t* h = c.data() + 18;
  const std::size_t info = deref(h, field_at(h, deref(h, 0), 2));
  c[18 + info + 3] = 0x7F;
  write_bytes(dir + "/c.aedat4", c);
  expect_input_error(dir + "/c.aedat4", "byte 14", "not a valid FlatBuffer");
}

TEST(Aedat4BadInput, UnusableStreamDescription) {
  const std::string dir = test::scratch_dir("aedat4_bad_xml");
  Aedat4Synthesizer no_size(0, {{0, "EVTS", 0, 0}});
  write_bytes(dir + "/no_size.aedat4", no_size.file());
  expect_input_error(dir + "/no_size.aedat4", "byte 14", "sizeX/sizeY");

  Bytes f = Aedat4Synthesizer(0, {{0, "EVTS", 10, 10}}).file();
  const std::string xml = info_xml({{0, "EVTS", 10, 10}});
  // Break the XML in place (same length): an unclosed tag.
  const auto pos = std::search(f.begin(), f.end(), xml.begin(), xml.end()) - f.begin();
  f[static_cast<std::size_t>(pos) + xml.find("</dv>") + 1] = 'x';
  write_bytes(dir + "/bad_xml.aedat4", f);
  expect_input_error(dir + "/bad_xml.aedat4", "byte 14", "not valid XML");
}

// ---- recoverable: packets ------------------------------------------------------------------

TEST(Aedat4BadInput, TruncatedFileKeepsWhatCameBefore) {
  const std::string src = test::real_data(kBall);
  FDV_REQUIRE_REAL_FILE(src);
  const Bytes f = read_bytes(src);
  const RawFile raw = independent_decode(f);
  // Cut in the middle of the 10th events packet.
  std::vector<const RawPacket*> evts;
  for (const auto& p : raw.packets)
    if (p.identifier == "EVTS") evts.push_back(&p);
  ASSERT_GE(evts.size(), 10u);
  const RawPacket& cut = *evts[9];
  const std::size_t cut_at = cut.offset + 8 + static_cast<std::size_t>(cut.size) / 2;
  const std::string path = test::scratch_dir("aedat4_truncated") + "/t.aedat4";
  write_bytes(path, Bytes(f.begin(), f.begin() + static_cast<std::ptrdiff_t>(cut_at)));

  const Result r = read_file(path, 1000);
  EXPECT_EQ(r.events, converted(raw.events, 0, cut.first_event));
  std::size_t imu_before = 0;
  for (const auto& p : raw.packets)
    if (p.identifier == "IMUS" && p.offset < cut.offset) imu_before += p.imu_count;
  EXPECT_EQ(r.imu.size(), imu_before);
  const std::string reason = "packet runs past the end of the file (truncated file)";
  EXPECT_EQ(dropped(r.report, reason), 1u);
  EXPECT_EQ(first_where(r.report, reason), at(cut.offset));
  EXPECT_EQ(r.report.total_dropped(), 1u) << r.report.to_json().dump();
}

TEST(Aedat4BadInput, CorruptLz4PacketIsDroppedAndReadingContinues) {
  const std::string src = test::real_data(kBall);
  FDV_REQUIRE_REAL_FILE(src);
  Bytes f = read_bytes(src);
  const RawFile raw = independent_decode(f);
  std::vector<const RawPacket*> evts;
  for (const auto& p : raw.packets)
    if (p.identifier == "EVTS") evts.push_back(&p);
  const RawPacket& bad = *evts[2];
  // Overwrite the LZ4 frame magic number (first 4 payload bytes): the frame cannot decode.
  for (int i = 0; i < 4; ++i) f[bad.offset + 8 + static_cast<std::size_t>(i)] = 0xAB;
  const std::string path = test::scratch_dir("aedat4_corrupt_lz4") + "/c.aedat4";
  write_bytes(path, f);

  const Result r = read_file(path);
  std::vector<Event> want = converted(raw.events, 0, bad.first_event);
  const auto rest = converted(raw.events, bad.first_event + bad.event_count, raw.events.size());
  want.insert(want.end(), rest.begin(), rest.end());
  EXPECT_EQ(r.events, want);
  EXPECT_EQ(r.imu.size(), raw.imu.size());
  const std::string reason = "corrupt compressed packet (LZ4 frame does not decode)";
  EXPECT_EQ(dropped(r.report, reason), 1u) << r.report.to_json().dump();
  EXPECT_EQ(first_where(r.report, reason), at(bad.offset));
  EXPECT_EQ(r.report.total_dropped(), 1u);
}

TEST(Aedat4BadInput, UnknownStreamIdIsCountedAndSkipped) {
  const std::string src = test::real_data(kBall);
  FDV_REQUIRE_REAL_FILE(src);
  Bytes f = read_bytes(src);
  const RawFile raw = independent_decode(f);
  const RawPacket* trig = nullptr;
  std::size_t triggers = 0;
  for (const auto& p : raw.packets)
    if (p.identifier == "TRIG") {
      if (!trig) trig = &p;
      ++triggers;
    }
  ASSERT_NE(trig, nullptr);
  f[trig->offset] = 7;  // stream id 3 -> 7 (the header declares 0..3)
  const std::string path = test::scratch_dir("aedat4_unknown_stream") + "/u.aedat4";
  write_bytes(path, f);

  const Result r = read_file(path);
  EXPECT_EQ(r.events, converted(raw.events, 0, raw.events.size()));
  EXPECT_EQ(r.imu.size(), raw.imu.size());
  const std::string reason = "packet with a stream id not in the header";
  EXPECT_EQ(dropped(r.report, reason), 1u);
  EXPECT_EQ(first_where(r.report, reason), at(trig->offset));
  const auto& notes = r.info.notes;
  EXPECT_NE(std::find(notes.begin(), notes.end(),
                      "triggers: " + std::to_string(triggers - 1) + " packets skipped"),
            notes.end());
}

// ---- synthesised files ---------------------------------------------------------------------

const std::vector<TestEvent> kEvents = {{1'000'000, 0, 0, 1},
                                        {1'000'010, 345, 259, 0},
                                        {1'000'010, 17, 3, 1},
                                        {1'000'020, 100, 200, 0}};

std::vector<Event> kEventsNs() {
  return {{1'000'000'000, 0, 0, true},
          {1'000'010'000, 345, 259, false},
          {1'000'010'000, 17, 3, true},
          {1'000'020'000, 100, 200, false}};
}

class Aedat4SynthesisedCompression : public ::testing::TestWithParam<int> {};

TEST_P(Aedat4SynthesisedCompression, SynthesisedFileDecodes) {
  const int c = GetParam();
  Aedat4Synthesizer w(c, {{0, "EVTS", 346, 260}, {1, "FRME", 346, 260}, {2, "IMUS"}});
  w.packet(0, events_payload({kEvents[0], kEvents[1]}));
  w.raw_packet(1, Bytes(40, 0x55));  // frames are skipped without being decoded
  w.packet(2, imu_payload({{1'000'005, {0, 0, -1}, {90, 0, -180}}}));
  w.packet(0, events_payload({kEvents[2], kEvents[3]}));
  const std::string path = test::scratch_dir("aedat4_c" + std::to_string(c)) + "/s.aedat4";
  write_bytes(path, w.file());

  const Result r = read_file(path);
  EXPECT_EQ(r.events, kEventsNs());
  ASSERT_EQ(r.imu.size(), 1u);
  EXPECT_EQ(r.imu[0].t, 1'000'005'000);
  EXPECT_EQ(r.imu[0].accel_m_s2, Eigen::Vector3d(0, 0, -9.80665));
  EXPECT_NEAR(r.imu[0].gyro_rad_s.x(), std::numbers::pi / 2, 1e-15);
  EXPECT_EQ(r.imu[0].gyro_rad_s.y(), 0.0);
  EXPECT_NEAR(r.imu[0].gyro_rad_s.z(), -std::numbers::pi, 1e-15);
  EXPECT_EQ(r.report.total_dropped(), 0u) << r.report.to_json().dump();
  const char* names[] = {"none", "LZ4", "LZ4 high", "Zstd", "Zstd high"};
  EXPECT_EQ(r.info.notes.at(0), std::string("compression: ") + names[c]);
  EXPECT_NE(std::find(r.info.notes.begin(), r.info.notes.end(), "frames: 1 packets skipped"),
            r.info.notes.end());
  EXPECT_EQ(r.info.width, 346);
  EXPECT_EQ(r.info.height, 260);
}

INSTANTIATE_TEST_SUITE_P(AllCompressions, Aedat4SynthesisedCompression, ::testing::Values(0, 1, 2, 3, 4));

TEST(Aedat4BadInput, CorruptZstdPacketIsDroppedAndReadingContinues) {
  Aedat4Synthesizer w(3, {{0, "EVTS", 346, 260}});
  w.packet(0, events_payload({kEvents[0]}));
  const std::size_t bad = w.packet(0, events_payload({kEvents[1], kEvents[2]}));
  w.packet(0, events_payload({kEvents[3]}));
  Bytes f = w.file();
  const std::size_t bad_at = w.header_end() + bad;
  f[bad_at + 8] ^= 0xFF;  // Zstd frame magic
  const std::string path = test::scratch_dir("aedat4_corrupt_zstd") + "/z.aedat4";
  write_bytes(path, f);

  const Result r = read_file(path);
  EXPECT_EQ(r.events, (std::vector<Event>{kEventsNs()[0], kEventsNs()[3]}));
  const std::string reason = "corrupt compressed packet (Zstd frame does not decode)";
  EXPECT_EQ(dropped(r.report, reason), 1u) << r.report.to_json().dump();
  EXPECT_EQ(first_where(r.report, reason), at(bad_at));
}

TEST(Aedat4BadInput, TruncatedCompressedFrameIsDropped) {
  // A packet whose LZ4 frame lost its last bytes (size field consistent with the shorter
  // payload): the frame ends early.
  Aedat4Synthesizer w(1, {{0, "EVTS", 346, 260}});
  Bytes payload = compress(1, events_payload({kEvents[0], kEvents[1]}));
  payload.resize(payload.size() - 6);
  const std::size_t bad = w.raw_packet(0, payload);
  w.packet(0, events_payload({kEvents[2]}));
  const std::string path = test::scratch_dir("aedat4_short_lz4") + "/s.aedat4";
  write_bytes(path, w.file());
  const Result r = read_file(path);
  EXPECT_EQ(r.events, (std::vector<Event>{kEventsNs()[2]}));
  EXPECT_EQ(r.report.total_dropped(), 1u) << r.report.to_json().dump();
  EXPECT_EQ(r.report.dropped().begin()->second.first_where, at(w.header_end() + bad));
}

TEST(Aedat4BadInput, PayloadThatIsNotAFlatBufferIsDropped) {
  Aedat4Synthesizer w(0, {{0, "EVTS", 346, 260}, {2, "IMUS"}});
  const std::size_t bad = w.raw_packet(0, Bytes(64, 0xEE));
  const std::size_t imu_as_events = w.packet(0, imu_payload({{5, {0, 0, 1}, {0, 0, 0}}}));
  w.packet(0, events_payload({kEvents[0]}));
  const std::string path = test::scratch_dir("aedat4_not_fb") + "/n.aedat4";
  write_bytes(path, w.file());
  const Result r = read_file(path);
  EXPECT_EQ(r.events, (std::vector<Event>{kEventsNs()[0]}));
  const std::string reason = "events packet is not a valid EVTS FlatBuffer";
  EXPECT_EQ(dropped(r.report, reason), 2u);  // garbage, and an IMUS buffer on the events stream
  EXPECT_EQ(first_where(r.report, reason), at(w.header_end() + bad));
  (void)imu_as_events;
}

TEST(Aedat4BadInput, NanImuSampleIsDropped) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  Aedat4Synthesizer w(1, {{0, "EVTS", 346, 260}, {2, "IMUS"}});
  const std::size_t imu_at = w.packet(2, imu_payload({{10, {0, 0, -1}, {0, 0, 0}},
                                                      {20, {nan, 0, -1}, {0, 0, 0}},
                                                      {30, {0.5f, 0, 0}, {0, -45, 0}}}));
  const std::string path = test::scratch_dir("aedat4_nan_imu") + "/n.aedat4";
  write_bytes(path, w.file());
  const Result r = read_file(path);
  ASSERT_EQ(r.imu.size(), 2u);
  EXPECT_EQ(r.imu[0].t, 10'000);
  EXPECT_EQ(r.imu[1].t, 30'000);
  EXPECT_EQ(r.imu[1].accel_m_s2, Eigen::Vector3d(0.5 * 9.80665, 0, 0));
  EXPECT_NEAR(r.imu[1].gyro_rad_s.y(), -std::numbers::pi / 4, 1e-15);
  const std::string reason = "imu sample with a non-finite (NaN or infinite) value";
  EXPECT_EQ(dropped(r.report, reason), 1u);
  EXPECT_EQ(first_where(r.report, reason), at(w.header_end() + imu_at));
}

TEST(Aedat4BadInput, EventsOutsideTheSensorOrGoingBackwardsAreDropped) {
  Aedat4Synthesizer w(0, {{0, "EVTS", 346, 260}, {2, "IMUS"}});
  w.packet(0, events_payload({{100, 10, 10, 1},
                              {110, 346, 5, 1},  // x = width: outside
                              {120, -1, 5, 0},   // negative x: outside
                              {90, 11, 11, 0},   // backwards
                              {130, 345, 259, 1}}));
  w.packet(0, events_payload({{125, 1, 1, 1}, {140, 2, 2, 0}}));  // 125 < 130: backwards
  w.packet(2, imu_payload({{50, {0, 0, 1}, {0, 0, 0}}, {40, {0, 0, 1}, {0, 0, 0}}}));
  const std::string path = test::scratch_dir("aedat4_sanitize") + "/s.aedat4";
  write_bytes(path, w.file());
  const Result r = read_file(path);
  EXPECT_EQ(r.events,
            (std::vector<Event>{
                {100'000, 10, 10, true}, {130'000, 345, 259, true}, {140'000, 2, 2, false}}));
  EXPECT_EQ(dropped(r.report, "event pixel outside the sensor"), 2u);
  EXPECT_EQ(dropped(r.report, "event timestamp went backwards"), 2u);
  EXPECT_EQ(dropped(r.report, "imu timestamp went backwards"), 1u);
  ASSERT_EQ(r.imu.size(), 1u);
  EXPECT_EQ(r.imu[0].t, 50'000);
}

TEST(Aedat4BadInput, DataTableIsNeverNeeded) {
  // Bytes shaped like the DV packet index: an LZ4 frame magic first, which read as a packet
  // header gives an unknown stream id and a negative size.
  const Bytes table = {0x04, 0x22, 0x4D, 0x18, 0x40, 0x40, 0xC0, 0x9C, 1, 2, 3, 4, 5, 6, 7, 8};
  const auto make = [&](std::int64_t table_position, bool with_table) {
    Aedat4Synthesizer w(1, {{0, "EVTS", 346, 260}});
    w.packet(0, events_payload({kEvents[0], kEvents[1]}));
    w.packet(0, events_payload({kEvents[2], kEvents[3]}));
    return w.file(with_table ? table : Bytes{}, table_position);
  };
  const std::string dir = test::scratch_dir("aedat4_table");
  // Correct position: the table ends the packets, nothing dropped.
  write_bytes(dir + "/ok.aedat4", make(-2, true));
  Result r = read_file(dir + "/ok.aedat4");
  EXPECT_EQ(r.events, kEventsNs());
  EXPECT_EQ(r.report.total_dropped(), 0u) << r.report.to_json().dump();
  // No table and position -1 (an interrupted recording): nothing dropped.
  write_bytes(dir + "/none.aedat4", make(-1, false));
  r = read_file(dir + "/none.aedat4");
  EXPECT_EQ(r.events, kEventsNs());
  EXPECT_EQ(r.report.total_dropped(), 0u);
  // Wrong positions (inside a packet; before the last packet's header would be: at the header
  // end): every packet is still read; the unlocated table bytes are counted.
  Aedat4Synthesizer probe(1, {{0, "EVTS", 346, 260}});
  for (std::int64_t wrong :
       {std::int64_t{-1}, std::int64_t{40}, static_cast<std::int64_t>(probe.header_end())}) {
    write_bytes(dir + "/wrong.aedat4", make(wrong, true));
    r = read_file(dir + "/wrong.aedat4");
    EXPECT_EQ(r.events, kEventsNs()) << "table position " << wrong;
    EXPECT_EQ(r.report.total_dropped(), 1u) << r.report.to_json().dump();
  }
}

TEST(Aedat4Streaming, BigPacketIsHandedOutInChunks) {
  std::vector<TestEvent> many;
  for (int i = 0; i < 5000; ++i)
    many.push_back({1000 + i, static_cast<std::int16_t>(i % 300),
                    static_cast<std::int16_t>(i % 200), static_cast<std::uint8_t>(i % 2)});
  Aedat4Synthesizer w(4, {{0, "EVTS", 346, 260}, {2, "IMUS"}});
  w.packet(2, imu_payload({{1500, {0, 0, 1}, {0, 0, 0}},
                           {5999, {0, 0, 1}, {0, 0, 0}},
                           {7000, {0, 0, 1}, {0, 0, 0}}}));
  w.packet(0, events_payload(many));
  const std::string path = test::scratch_dir("aedat4_chunks") + "/c.aedat4";
  write_bytes(path, w.file());

  ReaderOptions options;
  options.chunk_events = 1000;
  auto reader = open_aedat4(path, options);
  SensorChunk chunk;
  std::vector<std::size_t> events, imu;
  while (reader->read(chunk)) {
    events.push_back(chunk.events.size());
    imu.push_back(chunk.imu.size());
  }
  // 5 chunks of 1000 events (times 1000-1999 µs, ..., 5000-5999 µs); IMU only up to the
  // chunk's last event time: 1500 µs with the 1st chunk, 5999 µs with the 5th, and 7000 µs,
  // after every event, once the file is exhausted (a last chunk without events).
  EXPECT_EQ(events, (std::vector<std::size_t>{1000, 1000, 1000, 1000, 1000, 0}));
  EXPECT_EQ(imu, (std::vector<std::size_t>{1, 0, 0, 0, 1, 1}));
}

TEST(Aedat4BadInput, RandomCorruptionAfterTheHeaderIsAlwaysRecoverable) {
  // Byte corruption anywhere after the IOHeader never throws or crashes: whatever survives still
  // keeps the stream contract (time order, pixels inside the sensor), and at most the
  // independent decode's events come out.
  const std::string src = test::real_data("dvxplorer_person_static.aedat4");
  FDV_REQUIRE_REAL_FILE(src);
  const Bytes f = read_bytes(src);
  const RawFile raw = independent_decode(f);
  const std::string path = test::scratch_dir("aedat4_fuzz") + "/f.aedat4";
  std::mt19937 rng(20240611);
  std::uniform_int_distribution<std::size_t> pos(raw.packets_begin, f.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255), count(1, 8);
  for (int trial = 0; trial < 60; ++trial) {
    Bytes g = f;
    for (int k = count(rng); k > 0; --k) g[pos(rng)] = static_cast<std::uint8_t>(byte(rng));
    write_bytes(path, g);
    Result r;
    ASSERT_NO_THROW(r = read_file(path, 4096)) << "trial " << trial;
    EXPECT_LE(r.events.size(), raw.events.size()) << "trial " << trial;
    for (std::size_t i = 0; i < r.events.size(); ++i) {
      ASSERT_LT(r.events[i].x, 320) << "trial " << trial;
      ASSERT_LT(r.events[i].y, 240) << "trial " << trial;
      if (i > 0) {
        ASSERT_GE(r.events[i].t, r.events[i - 1].t) << "trial " << trial;
      }
    }
    for (std::size_t i = 1; i < r.imu.size(); ++i) ASSERT_GE(r.imu[i].t, r.imu[i - 1].t);
  }
}

}  // namespace
}  // namespace fdv
