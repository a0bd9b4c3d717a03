#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "fdv/core/error.h"
#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/io/dataset/dataset_writer.h"
#include "test_support.h"

namespace fdv {
namespace {

Calibration small_calibration() {
  Calibration c;
  c.event_camera = {64, 48, 50, 50, 32, 24, {}};
  c.depth_camera = PinholeCamera{32, 24, 25, 25, 16, 12, {}};
  return c;
}

struct AllStreams {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  std::vector<DepthFrame> depth;
  std::vector<OdometrySample> odometry;
  std::vector<ObjectState> truth;
  std::size_t chunks = 0;
};

AllStreams read_everything(RecordingReader& r) {
  AllStreams all;
  SensorChunk c;
  while (r.read(c)) {
    ++all.chunks;
    all.events.insert(all.events.end(), c.events.begin(), c.events.end());
    all.imu.insert(all.imu.end(), c.imu.begin(), c.imu.end());
    all.depth.insert(all.depth.end(), c.depth.begin(), c.depth.end());
    all.odometry.insert(all.odometry.end(), c.odometry.begin(), c.odometry.end());
    all.truth.insert(all.truth.end(), c.ground_truth.begin(), c.ground_truth.end());
  }
  return all;
}

// Writes a small dataset whose every value is known, reads it back in small chunks.
TEST(Dataset, RoundTripsEveryStreamInChunks) {
  const auto dir = test::scratch_dir("dataset_roundtrip");
  std::vector<Event> events;
  for (int i = 0; i < 1000; ++i)
    events.push_back({i * 10'000, static_cast<std::uint16_t>(i % 64), static_cast<std::uint16_t>(i % 48), i % 3 == 0});
  {
    DatasetWriter w(dir, small_calibration());
    w.add_events(events);
    for (int i = 0; i < 10; ++i) {
      w.add_imu({i * kNsPerMs, {0.1 * i, 0, 0}, {0, 0, 9.81}});
      OdometrySample o;
      o.t = i * kNsPerMs;
      o.p_W_B = {i * 0.01, 0, 1};
      o.v_W = {1, 0, 0};
      w.add_odometry(o);
      w.add_body_truth(o);
      w.add_object_truth({i * kNsPerMs, 1, {1, 2, 3.0 + i}, {0, 0, 1}});
    }
    DepthFrame d{5 * kNsPerMs, 32, 24, std::vector<float>(32 * 24, 2.345f)};
    d.depth_m[0] = 0.0f;
    w.add_depth(d);
    w.finish("scenario: unit_test\nseed: 7\n");
  }
  ReaderOptions small_chunks;
  small_chunks.chunk_events = 128;
  auto reader = open_recording(dir, small_chunks);
  EXPECT_EQ(reader->info().format, "fdv_dataset");
  EXPECT_EQ(reader->info().width, 64);
  ASSERT_TRUE(reader->info().calibration.has_value());
  const AllStreams all = read_everything(*reader);
  EXPECT_GE(all.chunks, 8u);
  EXPECT_EQ(all.events, events);
  ASSERT_EQ(all.imu.size(), 10u);
  EXPECT_DOUBLE_EQ(all.imu[3].gyro_rad_s.x(), 0.3);
  ASSERT_EQ(all.odometry.size(), 10u);
  EXPECT_DOUBLE_EQ(all.odometry[9].p_W_B.x(), 0.09);
  ASSERT_EQ(all.truth.size(), 10u);
  EXPECT_DOUBLE_EQ(all.truth[4].p_W.z(), 7.0);
  ASSERT_EQ(all.depth.size(), 1u);
  EXPECT_FLOAT_EQ(all.depth[0].at(1, 0), 2.345f);  // millimetre PNG: 2345 mm
  EXPECT_FLOAT_EQ(all.depth[0].at(0, 0), 0.0f);
  EXPECT_EQ(reader->report().total_dropped(), 0u);
  EXPECT_EQ(read_body_truth(dir).size(), 10u);
  EXPECT_EQ(read_object_truth(dir).size(), 10u);
}

TEST(Dataset, BadRowsAreCountedWithTheirLine) {
  const auto dir = test::scratch_dir("dataset_bad_rows");
  {
    DatasetWriter w(dir, small_calibration());
    w.add_events(std::vector<Event>{{0, 1, 1, true}, {100, 2, 2, false}});
    w.finish();
  }
  std::ofstream(dir + "/imu.csv") << "# header\n"
                                  << "1000,0,0,0,0,0,9.81\n"
                                  << "2000,nan,0,0,0,0,9.81\n"   // line 3: NaN
                                  << "500,0,0,0,0,0,9.81\n"      // line 4: backwards
                                  << "3000,0,0,0\n"              // line 5: too few columns
                                  << "4000,0,0,0,0,0,9.81\n";
  auto reader = open_recording(dir);
  const AllStreams all = read_everything(*reader);
  EXPECT_EQ(all.imu.size(), 2u);
  const auto& dropped = reader->report().dropped();
  ASSERT_EQ(dropped.count("imu: malformed or non-finite value"), 1u);
  EXPECT_NE(dropped.at("imu: malformed or non-finite value").first_where.find("imu.csv:line 3"),
            std::string::npos);
  EXPECT_EQ(dropped.at("imu: timestamp went backwards").count, 1u);
  EXPECT_EQ(dropped.at("imu: expected 7 columns").count, 1u);
}

TEST(Dataset, TruncatedAndCorruptEventFiles) {
  const auto dir = test::scratch_dir("dataset_truncated");
  std::vector<Event> events;
  for (int i = 0; i < 100; ++i) events.push_back({i, 3, 4, true});
  {
    DatasetWriter w(dir, small_calibration());
    w.add_events(events);
    w.finish();
  }
  const auto bin = dir + "/events.bin";
  std::filesystem::resize_file(bin, kEventsHeaderBytes + 40 * 16 + 5);  // 40 whole + partial
  {
    auto reader = open_recording(dir);
    EXPECT_EQ(read_everything(*reader).events.size(), 40u);
    EXPECT_EQ(reader->report().dropped().at("events.bin truncated: events missing at the end").count, 60u);
  }
  {  // an event outside the 64x48 sensor and one going back in time
    std::fstream f(bin, std::ios::in | std::ios::out | std::ios::binary);
    const std::uint16_t x = 500;
    f.seekp(kEventsHeaderBytes + 10 * 16 + 8);
    f.write(reinterpret_cast<const char*>(&x), 2);
    const std::int64_t t = -5;
    f.seekp(kEventsHeaderBytes + 20 * 16);
    f.write(reinterpret_cast<const char*>(&t), 8);
  }
  {
    auto reader = open_recording(dir);
    EXPECT_EQ(read_everything(*reader).events.size(), 38u);
    EXPECT_EQ(reader->report().dropped().at("event pixel outside the sensor").count, 1u);
    EXPECT_EQ(reader->report().dropped().at("event timestamp went backwards").count, 1u);
  }
  {  // wrong magic: a clear error at byte 0
    std::fstream f(bin, std::ios::in | std::ios::out | std::ios::binary);
    f.write("XXXX", 4);
  }
  try {
    open_recording(dir);
    FAIL() << "wrong magic accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "byte 0");
    EXPECT_NE(e.reason().find("magic"), std::string::npos);
  }
}

TEST(OpenRecording, MissingAndUnknownInputsAreClearErrors) {
  EXPECT_THROW(open_recording("/no/such/file.aedat4"), InputError);
  const auto dir = test::scratch_dir("unknown_format");
  std::ofstream(dir + "/x.dat") << "hello world";
  try {
    open_recording(dir + "/x.dat");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(e.reason().find("unrecognised"), std::string::npos);
  }
}

}  // namespace
}  // namespace fdv
