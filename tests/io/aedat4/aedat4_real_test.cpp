// AEDAT 4.0 reader on the three real recordings, checked against (a) the figures in
// shared/data/README.md and (b) an independent decode written in this test (aedat4_test_util.h:
// raw FlatBuffer offsets, LZ4 called directly, no generated schema code, no XML parser).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <string>
#include <vector>

#include "aedat4_test_util.h"
#include "fdv/io/aedat4/aedat4_reader.h"
#include "fdv/io/recording.h"
#include "test_support.h"

namespace fdv {
namespace {

using namespace test::aedat4;

struct RealFile {
  const char* name;
  std::size_t events;  // README figures
  std::size_t imu;
  int width, height;
  double duration_s;
};

void PrintTo(const RealFile& f, std::ostream* os) { *os << f.name; }

const RealFile kRealFiles[] = {
    {"davis346_ball_throw_person.aedat4", 237'073, 740, 346, 260, 0.75},
    {"dvxplorer_person_static.aedat4", 111'954, 475, 320, 240, 0.59},
    {"davis346_flicker_noise.aedat4", 117'667, 130, 346, 260, 0.13},
};

struct ReadAll {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  std::vector<std::size_t> chunk_sizes;
  /// An IMU sample later than every event handed out so far, in a chunk before the last one
  /// with events (the contract hands IMU out up to the last event time while events remain).
  bool imu_ahead_of_events = false;
};

ReadAll read_with_chunks(RecordingReader& reader) {
  ReadAll r;
  SensorChunk chunk;
  std::vector<bool> ahead;  // per chunk
  while (reader.read(chunk)) {
    EXPECT_FALSE(chunk.empty());
    r.events.insert(r.events.end(), chunk.events.begin(), chunk.events.end());
    r.chunk_sizes.push_back(chunk.events.size());
    bool a = false;
    for (const auto& s : chunk.imu) a = a || r.events.empty() || s.t > r.events.back().t;
    ahead.push_back(a);
    r.imu.insert(r.imu.end(), chunk.imu.begin(), chunk.imu.end());
  }
  std::size_t last_with_events = 0;
  for (std::size_t i = 0; i < r.chunk_sizes.size(); ++i)
    if (r.chunk_sizes[i] > 0) last_with_events = i;
  for (std::size_t i = 0; i < last_with_events; ++i)
    r.imu_ahead_of_events = r.imu_ahead_of_events || ahead[i];
  return r;
}

int xml_int(const std::string& xml, const std::string& key) {
  std::smatch m;
  const std::regex re("key=\"" + key + "\" type=\"int\">([0-9]+)<");
  return std::regex_search(xml, m, re) ? std::stoi(m[1]) : -1;
}

class Aedat4Real : public ::testing::TestWithParam<RealFile> {};

TEST_P(Aedat4Real, MatchesIndependentDecodeAndReadme) {
  const RealFile& rf = GetParam();
  const std::string path = test::real_data(rf.name);
  FDV_REQUIRE_REAL_FILE(path);
  const RawFile raw = independent_decode(read_bytes(path));

  // The README figures and the independent decode agree (the second route).
  ASSERT_EQ(raw.events.size(), rf.events);
  ASSERT_EQ(raw.imu.size(), rf.imu);
  EXPECT_EQ(xml_int(raw.info_xml, "sizeX"), rf.width);
  EXPECT_EQ(xml_int(raw.info_xml, "sizeY"), rf.height);
  EXPECT_EQ(raw.compression, 1);  // LZ4, as the README says

  auto reader = open_recording(path);
  EXPECT_EQ(reader->info().format, "aedat4");
  EXPECT_EQ(reader->info().width, rf.width);
  EXPECT_EQ(reader->info().height, rf.height);
  const ReadAll got = read_with_chunks(*reader);
  EXPECT_EQ(reader->report().total_dropped(), 0u) << reader->report().to_json().dump();

  // Every event, field by field, in file order: µs -> ns, coordinates and polarity unchanged.
  ASSERT_EQ(got.events.size(), raw.events.size());
  for (std::size_t i = 0; i < raw.events.size(); ++i) {
    const RawEvent& e = raw.events[i];
    const Event want{e.t_us * 1000, static_cast<std::uint16_t>(e.x),
                     static_cast<std::uint16_t>(e.y), e.polarity};
    ASSERT_EQ(got.events[i], want) << "event " << i;
  }
  EXPECT_NEAR(to_seconds(got.events.back().t - got.events.front().t), rf.duration_s, 0.01);

  ASSERT_EQ(got.imu.size(), raw.imu.size());
  for (std::size_t i = 0; i < raw.imu.size(); ++i) {
    const RawImu& m = raw.imu[i];
    ASSERT_EQ(got.imu[i].t, m.t_us * 1000) << "imu " << i;
    for (int k = 0; k < 3; ++k) {
      // g -> m/s^2 with standard gravity; deg/s -> rad/s. Relative 1e-12 covers double rounding.
      const double a = static_cast<double>(m.accel_g[k]) * 9.80665;
      const double w = static_cast<double>(m.gyro_deg_s[k]) * std::numbers::pi / 180.0;
      ASSERT_NEAR(got.imu[i].accel_m_s2[k], a, 1e-12 * (1 + std::abs(a))) << "imu " << i;
      ASSERT_NEAR(got.imu[i].gyro_rad_s[k], w, 1e-12 * (1 + std::abs(w))) << "imu " << i;
    }
  }
}

TEST_P(Aedat4Real, SmallChunksGiveTheSameStream) {
  const std::string path = test::real_data(GetParam().name);
  FDV_REQUIRE_REAL_FILE(path);
  ReaderOptions small;
  small.chunk_events = 1000;
  ReaderOptions large;
  large.chunk_events = 10'000'000;
  auto a = open_aedat4(path, small);
  auto b = open_aedat4(path, large);
  const ReadAll sa = read_with_chunks(*a);
  const ReadAll sb = read_with_chunks(*b);
  EXPECT_EQ(sa.events, sb.events);
  ASSERT_EQ(sa.imu.size(), sb.imu.size());
  for (std::size_t i = 0; i < sa.imu.size(); ++i) {
    EXPECT_EQ(sa.imu[i].t, sb.imu[i].t);
    EXPECT_EQ(sa.imu[i].accel_m_s2, sb.imu[i].accel_m_s2);
    EXPECT_EQ(sa.imu[i].gyro_rad_s, sb.imu[i].gyro_rad_s);
  }
  // About chunk_events per read: never more; full chunks except at the end of the events.
  EXPECT_EQ(sb.chunk_sizes.front(), sb.events.size());
  const auto full = std::count(sa.chunk_sizes.begin(), sa.chunk_sizes.end(), std::size_t{1000});
  EXPECT_EQ(static_cast<std::size_t>(full), sa.events.size() / 1000);
  EXPECT_LE(*std::max_element(sa.chunk_sizes.begin(), sa.chunk_sizes.end()), 1000u);
  // IMU is handed out only up to the last event handed out (while events remain).
  EXPECT_FALSE(sa.imu_ahead_of_events);
}

INSTANTIATE_TEST_SUITE_P(RealFiles, Aedat4Real, ::testing::ValuesIn(kRealFiles),
                         [](const auto& param_info) {
                           std::string n = param_info.param.name;
                           return n.substr(0, n.find('.'));
                         });

TEST(Aedat4RealNotes, SkippedFramesAndTriggersCounted) {
  const std::string path = test::real_data("davis346_ball_throw_person.aedat4");
  FDV_REQUIRE_REAL_FILE(path);
  const RawFile raw = independent_decode(read_bytes(path));
  const auto count = [&](const char* id) {
    return std::count_if(raw.packets.begin(), raw.packets.end(),
                         [&](const RawPacket& p) { return p.identifier == id; });
  };
  ASSERT_EQ(count("FRME"), 19);  // README: 19 frames
  const auto triggers = count("TRIG");
  ASSERT_GT(triggers, 0);

  auto reader = open_aedat4(path);
  SensorChunk chunk;
  while (reader->read(chunk)) {
  }
  const auto& notes = reader->info().notes;
  const auto has = [&](const std::string& s) {
    return std::find(notes.begin(), notes.end(), s) != notes.end();
  };
  EXPECT_TRUE(has("compression: LZ4"));
  EXPECT_TRUE(has("frames: 19 packets skipped"));
  EXPECT_TRUE(has("triggers: " + std::to_string(triggers) + " packets skipped"));
  EXPECT_EQ(reader->info().streams,
            (std::vector<StreamKind>{StreamKind::kEvents, StreamKind::kImu}));
}

TEST(Aedat4RealImu, FirstSampleOfBallThrowByHand) {
  // First IMU sample of davis346_ball_throw_person as decoded by hand (python, raw offsets):
  // t = 1610696585221086 µs, accel (-0.2236328125, -0.92431640625, -0.3544921875) g,
  // gyro (2.288818359375, 1.1444091796875, -2.166748046875) deg/s (all exact binary fractions).
  const std::string path = test::real_data("davis346_ball_throw_person.aedat4");
  FDV_REQUIRE_REAL_FILE(path);
  auto reader = open_aedat4(path);
  SensorChunk chunk;
  std::vector<ImuSample> imu;
  while (imu.empty() && reader->read(chunk)) imu = chunk.imu;
  ASSERT_FALSE(imu.empty());
  EXPECT_EQ(imu[0].t, 1610696585221086LL * 1000);
  EXPECT_NEAR(imu[0].accel_m_s2.x(), -0.2236328125 * 9.80665, 1e-12);
  EXPECT_NEAR(imu[0].accel_m_s2.y(), -0.92431640625 * 9.80665, 1e-12);
  EXPECT_NEAR(imu[0].accel_m_s2.z(), -0.3544921875 * 9.80665, 1e-12);
  EXPECT_NEAR(imu[0].gyro_rad_s.x(), 2.288818359375 * std::numbers::pi / 180, 1e-14);
  EXPECT_NEAR(imu[0].gyro_rad_s.z(), -2.166748046875 * std::numbers::pi / 180, 1e-14);
  // |a| of a nearly still camera is about 1 g.
  EXPECT_NEAR(imu[0].accel_m_s2.norm(), 9.81, 0.3);
}

}  // namespace
}  // namespace fdv
