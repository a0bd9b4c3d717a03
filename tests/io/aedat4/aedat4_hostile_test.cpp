// AEDAT 4.0 reader on hostile input: the in-memory entry point, an XML stream
// description without a root element, decompression bombs (Zstd and LZ4, with and without a
// declared content size) and packets above the size limit. Inputs are built in memory with the
// test's own writer, or are the fuzzer's findings in ../shared/fuzz-findings.
#include <gtest/gtest.h>
#include <zstd.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
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

std::unique_ptr<RecordingReader> open_bytes(const Bytes& b, const std::string& name) {
  return open_aedat4(std::make_unique<std::istringstream>(std::string(b.begin(), b.end())), name);
}

const std::vector<TestEvent> kTwo = {{1'000'000, 1, 2, 1}, {1'000'010, 3, 4, 0}};
const std::string kTooLarge = "decompressed packet larger than the 64 MiB limit";

// ---- in-memory entry point ------------------------------------------------------------------

TEST(Aedat4Hostile, StreamEntryPointReadsLikeThePath) {
  for (const char* name : {"davis346_ball_throw_person.aedat4", "dvxplorer_person_static.aedat4",
                           "davis346_flicker_noise.aedat4"}) {
    const std::string path = test::real_data(name);
    FDV_REQUIRE_REAL_FILE(path);
    const Result by_path = read_all(open_aedat4(path));
    const Result by_stream = read_all(open_bytes(read_bytes(path), "in-memory copy"));
    ASSERT_EQ(by_stream.events.size(), by_path.events.size()) << name;
    EXPECT_EQ(by_stream.events, by_path.events) << name;
    ASSERT_EQ(by_stream.imu.size(), by_path.imu.size()) << name;
    for (std::size_t i = 0; i < by_path.imu.size(); ++i)
      ASSERT_EQ(by_stream.imu[i].t, by_path.imu[i].t) << name;
    EXPECT_EQ(by_stream.info.notes, by_path.info.notes) << name;
    EXPECT_EQ(by_stream.info.path, "in-memory copy");
  }
}

TEST(Aedat4Hostile, StreamErrorsNameTheGivenName) {
  try {
    open_bytes(Bytes{'#', '!', 'A', 'E', 'R'}, "fuzz-input-3");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "fuzz-input-3");
    EXPECT_EQ(e.where(), "byte 5");
  }
}

TEST(Aedat4Hostile, FolderIsAnInputError) {
  // It used to escape as std::filesystem::filesystem_error (file_size of a folder).
  const std::string dir = test::scratch_dir("aedat4_folder");
  try {
    open_aedat4(dir);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir);
  }
}

// ---- f1: a stream description without a root element -------------------------------------------

Bytes file_with_xml(const std::string& xml) {
  Bytes f = {'#', '!', 'A', 'E', 'R', '-', 'D', 'A', 'T', '4', '.', '0', '\r', '\n'};
  const Bytes h = io_header(0, -1, xml);
  f.insert(f.end(), h.begin(), h.end());
  return f;
}

TEST(Aedat4Hostile, XmlWithoutRootElementIsAnInputError) {
  for (const std::string xml : {"<!-- only a comment -->", "", "<?xml version=\"1.0\"?>", "  "}) {
    try {
      open_bytes(file_with_xml(xml), "no_root.aedat4");
      ADD_FAILURE() << "no InputError for '" << xml << "'";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "no_root.aedat4");
      EXPECT_EQ(e.where(), "byte 14");
      EXPECT_NE(e.reason().find("not valid XML"), std::string::npos) << e.what();
    }
  }
}

TEST(Aedat4Hostile, XmlWithoutRootElementFindings) {
  for (const char* name :
       {"aedat4/f1-header-xml-no-root.aedat4", "aedat4/f1-header-xml-comment-only.aedat4"}) {
    const std::string path = test::fuzz_finding(name);
    FDV_REQUIRE_REAL_FILE(path);
    try {
      open_aedat4(path);
      ADD_FAILURE() << "no InputError for " << path;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.reason(), "IOHeader stream description: not valid XML (no root element)");
    }
  }
}

TEST(Aedat4Hostile, NonUtf8XmlTextIsEscaped) {
  // tinyxml2 does not check UTF-8: a stream's source and type reach info().notes, the XML text
  // can reach an error message.
  std::string xml = info_xml({{0, "EVTS", 346, 260}, {1, "FRME", 346, 260}});
  xml.replace(xml.find("TEST_CAMERA"), 11, "CAM\xFF\xC3");
  xml.replace(xml.find("FRME"), 4, "FR\x80" "E");
  Bytes f = file_with_xml(xml);
  const Bytes packet = events_payload(kTwo);
  const std::int32_t head[2] = {1, static_cast<std::int32_t>(packet.size())};
  f.insert(f.end(), reinterpret_cast<const std::uint8_t*>(head),
           reinterpret_cast<const std::uint8_t*>(head) + 8);
  f.insert(f.end(), packet.begin(), packet.end());  // a packet of the stream with that type
  const Result r = read_all(open_bytes(f, "utf8.aedat4"));
  EXPECT_NO_THROW((void)nlohmann::json(r.info.notes).dump());
  EXPECT_EQ(r.info.notes.at(1), "events: stream 0, 346x260, source CAM\\xFF\\xC3");
  EXPECT_EQ(r.info.notes.at(2), "stream 1 (FR\\x80E): 1 packets skipped");
  try {
    open_bytes(file_with_xml("<dv\xFF><node></dv\xFF>"), "bad.aedat4");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NO_THROW((void)nlohmann::json(std::string(e.what())).dump()) << e.what();
  }
}

// ---- f7: decompression bombs ---------------------------------------------------------------------

/// One byte more than the limit, all zero (compresses to a few hundred KiB at most).
const Bytes& just_too_large() {
  static const Bytes b(kAedat4MaxPacketBytes + 1, 0);
  return b;
}

Bytes zstd_frame(const Bytes& in, bool declare_size) {
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, declare_size ? 1 : 0);
  Bytes out(ZSTD_compressBound(in.size()));
  const std::size_t n = ZSTD_compress2(cctx, out.data(), out.size(), in.data(), in.size());
  ZSTD_freeCCtx(cctx);
  if (ZSTD_isError(n)) throw std::runtime_error("test: Zstd error");
  out.resize(n);
  return out;
}

Bytes lz4_frame(const Bytes& in, bool declare_size) {
  LZ4F_preferences_t prefs{};
  if (declare_size) prefs.frameInfo.contentSize = in.size();
  Bytes out(LZ4F_compressFrameBound(in.size(), &prefs));
  const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
  if (LZ4F_isError(n)) throw std::runtime_error("test: LZ4 error");
  out.resize(n);
  return out;
}

/// A file of three events packets: valid, `bomb`, valid. Reading stops at the bomb with an
/// InputError naming the name and the packet's byte.
void expect_bomb_refused(int compression, const Bytes& bomb, const std::string& name) {
  Aedat4Synthesizer w(compression, {{0, "EVTS", 346, 260}});
  w.packet(0, events_payload({kTwo[0]}));
  const std::size_t bad = w.raw_packet(0, bomb);
  w.packet(0, events_payload({kTwo[1]}));
  try {
    (void)read_all(open_bytes(w.file(), name));
    ADD_FAILURE() << name << ": the bomb was not refused";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), name);
    EXPECT_EQ(e.where(), "packet at byte " + std::to_string(w.header_end() + bad)) << name;
    EXPECT_NE(e.reason().find(kTooLarge), std::string::npos) << e.what();
  }
}

TEST(Aedat4Hostile, ZstdBombDeclaringItsSizeIsRefusedUnopened) {
  expect_bomb_refused(3, zstd_frame(just_too_large(), true), "zstd_declared");
}

TEST(Aedat4Hostile, ZstdBombOfUnknownSizeStopsAtTheLimit) {
  expect_bomb_refused(3, zstd_frame(just_too_large(), false), "zstd_unknown");
}

TEST(Aedat4Hostile, Lz4BombDeclaringItsSizeIsRefusedUnopened) {
  expect_bomb_refused(1, lz4_frame(just_too_large(), true), "lz4_declared");
}

TEST(Aedat4Hostile, Lz4BombOfUnknownSizeStopsAtTheLimit) {
  expect_bomb_refused(1, lz4_frame(just_too_large(), false), "lz4_unknown");
}

TEST(Aedat4Hostile, FramesOfUnknownAndDeclaredSizeStillDecode) {
  for (const bool declare : {false, true}) {
    Aedat4Synthesizer zw(3, {{0, "EVTS", 346, 260}});
    zw.raw_packet(0, zstd_frame(events_payload(kTwo), declare));
    const Result z = read_all(open_bytes(zw.file(), "zstd"));
    EXPECT_EQ(z.events.size(), 2u) << declare;
    EXPECT_TRUE(z.report.dropped().empty()) << declare;
    Aedat4Synthesizer lw(1, {{0, "EVTS", 346, 260}});
    lw.raw_packet(0, lz4_frame(events_payload(kTwo), declare));
    const Result l = read_all(open_bytes(lw.file(), "lz4"));
    EXPECT_EQ(l.events.size(), 2u) << declare;
    EXPECT_TRUE(l.report.dropped().empty()) << declare;
  }
}

TEST(Aedat4Hostile, UncompressedPacketAboveTheLimitIsSkippedUnread) {
  Aedat4Synthesizer w(0, {{0, "EVTS", 346, 260}});
  w.packet(0, events_payload({kTwo[0]}));
  const std::size_t bad = w.raw_packet(0, just_too_large());
  w.packet(0, events_payload({kTwo[1]}));
  const Result r = read_all(open_bytes(w.file(), "big"));
  EXPECT_EQ(r.events.size(), 2u);
  const std::string reason = "packet larger than the 64 MiB limit";
  EXPECT_EQ(dropped(r.report, reason), 1u);
  EXPECT_EQ(first_where(r.report, reason), "byte " + std::to_string(w.header_end() + bad));
}

TEST(Aedat4Hostile, ZstdBombFinding) {
  const std::string path = test::fuzz_finding("aedat4/f7-zstd-bomb.aedat4");
  FDV_REQUIRE_REAL_FILE(path);
  try {
    (void)read_all(open_aedat4(path));
    ADD_FAILURE() << "the bomb was not refused";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.where(), "packet at byte 3126");
  }
}

}  // namespace
}  // namespace fdv
