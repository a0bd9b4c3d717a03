// AEDAT 4.0 writer: what it writes is read back by fdv's reader and by the tests' independent
// decoder (aedat4_test_util.h: raw FlatBuffer offsets, LZ4 / Zstd called directly), against the
// events and samples given, the unit conversions done by hand, and the real recordings.
#include "fdv/io/aedat4/aedat4_writer.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "aedat4_test_util.h"
#include "fdv/core/error.h"
#include "fdv/io/aedat4/aedat4_reader.h"
#include "test_support.h"

namespace fdv {
namespace {

namespace t = test::aedat4;

/// Events over more than one packet, with and without a fraction of a microsecond, and IMU
/// samples with hand-checked unit conversions.
struct Sample {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
};
Sample sample() {
  Sample s;
  for (int i = 0; i < 20000; ++i)
    s.events.push_back({1'600'000'000'000'000'000 + std::int64_t{i} * 2000 + (i % 3 == 0 ? 0 : 250),
                        static_cast<std::uint16_t>(i % 346), static_cast<std::uint16_t>(i % 260), i % 2 == 0});
  for (int i = 0; i < 3; ++i) {
    ImuSample m;
    m.t = 1'600'000'000'000'000'000 + std::int64_t{i} * 1'000'000;
    m.accel_m_s2 = {0, 0, 9.80665 * (i + 1)};  // 1, 2, 3 g
    m.gyro_rad_s = {std::numbers::pi, 0, -std::numbers::pi / 2};  // 180, 0, -90 deg/s
    s.imu.push_back(m);
  }
  return s;
}

class Aedat4WriterRoundTrip : public ::testing::TestWithParam<Aedat4Compression> {};

TEST_P(Aedat4WriterRoundTrip, ReadsBackThroughTheReaderAndTheIndependentDecoder) {
  const std::string path = test::scratch_dir("aedat4_writer") + "/out.aedat4";
  const Sample s = sample();
  {
    Aedat4Writer w(path, 346, 260, GetParam());
    w.add(std::span<const Event>(s.events).first(5000));
    w.add(s.imu);
    w.add(std::span<const Event>(s.events).subspan(5000));
    w.close();
    EXPECT_EQ(w.events(), 20000u);
    EXPECT_EQ(w.imu_samples(), 3u);
    // Two of every three events have 250 ns past the microsecond; the IMU times are whole.
    EXPECT_EQ(w.floored_times(), 20000u - 6667u);
  }
  // Independent decode: the header, the stream description and every element.
  const t::RawFile raw = t::independent_decode(t::read_bytes(path));
  EXPECT_EQ(raw.compression, static_cast<int>(GetParam()));
  EXPECT_EQ(raw.data_table_position, -1);
  EXPECT_NE(raw.info_xml.find("<attr key=\"sizeX\" type=\"int\">346</attr>"), std::string::npos) << raw.info_xml;
  // 5000 events, 3 samples, then 15000 events in packets of at most 8192: 1 + 1 + 2 packets.
  ASSERT_EQ(raw.packets.size(), 4u);
  EXPECT_EQ(raw.packets[1].identifier, "IMUS");
  ASSERT_EQ(raw.events.size(), s.events.size());
  for (std::size_t i = 0; i < s.events.size(); ++i) {
    ASSERT_EQ(raw.events[i].t_us, s.events[i].t / 1000) << i;
    ASSERT_EQ(raw.events[i].x, s.events[i].x) << i;
    ASSERT_EQ(raw.events[i].y, s.events[i].y) << i;
    ASSERT_EQ(raw.events[i].polarity, s.events[i].polarity) << i;
  }
  ASSERT_EQ(raw.imu.size(), 3u);
  EXPECT_FLOAT_EQ(raw.imu[2].accel_g[2], 3.f);
  EXPECT_FLOAT_EQ(raw.imu[0].gyro_deg_s[0], 180.f);
  EXPECT_FLOAT_EQ(raw.imu[0].gyro_deg_s[2], -90.f);

  // fdv's reader: the same events floored to the microsecond, the IMU in SI units.
  const t::Result got = t::read_all(open_recording(path));
  EXPECT_EQ(got.report.total_dropped(), 0u) << got.report.to_json().dump();
  EXPECT_EQ(got.info.width, 346);
  EXPECT_EQ(got.info.height, 260);
  ASSERT_EQ(got.events.size(), s.events.size());
  for (std::size_t i = 0; i < s.events.size(); ++i) {
    Event want = s.events[i];
    want.t = want.t / 1000 * 1000;
    ASSERT_EQ(got.events[i], want) << i;
  }
  ASSERT_EQ(got.imu.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(got.imu[i].t, s.imu[i].t);
    EXPECT_LT((got.imu[i].accel_m_s2 - s.imu[i].accel_m_s2).norm(), 1e-5);  // float32 in g
    EXPECT_LT((got.imu[i].gyro_rad_s - s.imu[i].gyro_rad_s).norm(), 1e-6);
  }
}

INSTANTIATE_TEST_SUITE_P(Compressions, Aedat4WriterRoundTrip,
                         ::testing::Values(Aedat4Compression::kNone, Aedat4Compression::kLz4,
                                           Aedat4Compression::kZstd),
                         [](const auto& param_info) {
                           return std::string(param_info.param == Aedat4Compression::kNone  ? "None"
                                              : param_info.param == Aedat4Compression::kLz4 ? "Lz4"
                                                                                      : "Zstd");
                         });

TEST(Aedat4Writer, RealRecordingRoundTripsEventForEvent) {
  const std::string in = test::real_data("davis346_ball_throw_person.aedat4");
  FDV_REQUIRE_REAL_FILE(in);
  const t::Result original = t::read_all(open_recording(in));
  const std::string path = test::scratch_dir("aedat4_writer_real") + "/out.aedat4";
  {
    Aedat4Writer w(path, original.info.width, original.info.height);
    w.add(original.events);
    w.add(original.imu);
    w.close();
    EXPECT_EQ(w.floored_times(), 0u);  // a DAVIS's times are whole microseconds
  }
  const t::Result copy = t::read_all(open_recording(path));
  EXPECT_EQ(copy.events, original.events);
  ASSERT_EQ(copy.imu.size(), original.imu.size());
  for (std::size_t i = 0; i < copy.imu.size(); ++i) {
    ASSERT_EQ(copy.imu[i].t, original.imu[i].t);
    // g and deg/s as float32, as recorded: the round trip is exact up to float rounding.
    ASSERT_LT((copy.imu[i].accel_m_s2 - original.imu[i].accel_m_s2).norm(), 1e-5) << i;
    ASSERT_LT((copy.imu[i].gyro_rad_s - original.imu[i].gyro_rad_s).norm(), 1e-6) << i;
  }
}

TEST(Aedat4Writer, BadSizesTimesAndPixelsAreErrorsNamingWhat) {
  const std::string dir = test::scratch_dir("aedat4_writer_bad");
  EXPECT_THROW(Aedat4Writer(dir + "/a.aedat4", 40000, 10), ConfigError);
  EXPECT_THROW(Aedat4Writer(dir + "/a.aedat4", 10, 10, Aedat4Compression::kZstdHigh), ConfigError);
  EXPECT_THROW(Aedat4Writer(dir + "/no/such/folder.aedat4", 10, 10), InputError);
  Aedat4Writer w(dir + "/b.aedat4", 10, 10);
  const std::vector<Event> events = {{2000, 1, 1, true}, {1000, 1, 1, true}};
  const std::string backwards = test::input_error_of(dir + "/b.aedat4", [&] { w.add(events); });
  EXPECT_NE(backwards.find("event 1"), std::string::npos) << backwards;
  EXPECT_NE(backwards.find("time goes backwards"), std::string::npos) << backwards;
  const std::vector<Event> outside = {{3000, 10, 0, true}};
  const std::string pixel = test::input_error_of(dir + "/b.aedat4", [&] { w.add(outside); });
  EXPECT_NE(pixel.find("outside the 10x10 sensor"), std::string::npos) << pixel;
}

}  // namespace
}  // namespace fdv
