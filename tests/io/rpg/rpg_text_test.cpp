// RPG Event-Camera Dataset text layout. Every folder here is written by the test with values
// known by hand; expectations are those values, never the reader's output fed back.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/io/recording.h"
#include "fdv/io/rpg/rpg_text_reader.h"
#include "fdv/io/table_stream.h"
#include "fdv/io/text_fields.h"
#include "test_support.h"

namespace fdv {
namespace {

ReaderOptions chunked(std::size_t chunk_events) {
  ReaderOptions o;
  o.chunk_events = chunk_events;
  return o;
}

void write(const std::string& dir, const std::string& name, const std::string& text) {
  std::ofstream(std::filesystem::path(dir) / name) << text;
}

struct AllStreams {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  std::vector<OdometrySample> odometry;
  std::vector<SensorChunk> chunks;
};

AllStreams read_everything(RecordingReader& r) {
  AllStreams all;
  SensorChunk c;
  while (r.read(c)) {
    all.chunks.push_back(c);
    all.events.insert(all.events.end(), c.events.begin(), c.events.end());
    all.imu.insert(all.imu.end(), c.imu.begin(), c.imu.end());
    all.odometry.insert(all.odometry.end(), c.odometry.begin(), c.odometry.end());
  }
  return all;
}

const ReadReport::Entry* dropped(const ReadReport& r, const std::string& reason) {
  const auto it = r.dropped().find(reason);
  return it == r.dropped().end() ? nullptr : &it->second;
}

TEST(RpgText, ReadsEveryStreamWithExactTimesAndColumnOrder) {
  const auto dir = test::scratch_dir("rpg_full");
  write(dir, "events.txt",
        "1.0 0 0 1\n"
        "1.0000005 239 179 0\n"
        "1.001 10 20 1\n"
        "1.0020000004 11 21 0\n"    // tenth decimal rounds down
        "1.0030000005 12 22 1\n");  // ... and up
  write(dir, "imu.txt", "1.0005 0.1 0.2 9.81 0.01 0.02 0.03\n1.0025 0.4 0.5 9.6 0.04 0.05 0.06\n");
  write(dir, "groundtruth.txt",
        "1.0 1 2 3 0 0 0 1\n"
        "1.002 1.5 2 3 0 0 0.7071067811865476 0.7071067811865476\n");
  write(dir, "calib.txt", "199.0 198.5 120.2 90.1 -0.35 0.15 0.001 -0.002 0.01\n");

  auto reader = open_recording(dir, chunked(2));
  const RecordingInfo& info = reader->info();
  EXPECT_EQ(info.format, "rpg_text");
  EXPECT_EQ(info.width, 240);
  EXPECT_EQ(info.height, 180);
  EXPECT_EQ(info.streams, (std::vector<StreamKind>{StreamKind::kEvents, StreamKind::kImu,
                                                   StreamKind::kOdometry}));
  ASSERT_TRUE(info.calibration.has_value());
  const PinholeCamera& cam = info.calibration->event_camera;
  EXPECT_EQ(cam.width, 240);
  EXPECT_EQ(cam.height, 180);
  EXPECT_DOUBLE_EQ(cam.fx, 199.0);
  EXPECT_DOUBLE_EQ(cam.fy, 198.5);
  EXPECT_DOUBLE_EQ(cam.cx, 120.2);
  EXPECT_DOUBLE_EQ(cam.cy, 90.1);
  EXPECT_DOUBLE_EQ(cam.distortion.k1, -0.35);
  EXPECT_DOUBLE_EQ(cam.distortion.k2, 0.15);
  EXPECT_DOUBLE_EQ(cam.distortion.p1, 0.001);
  EXPECT_DOUBLE_EQ(cam.distortion.p2, -0.002);
  EXPECT_DOUBLE_EQ(cam.distortion.k3, 0.01);
  bool groundtruth_note = false;
  for (const auto& n : info.notes)
    groundtruth_note |= n.find("groundtruth.txt") != std::string::npos;
  EXPECT_TRUE(groundtruth_note);

  const AllStreams all = read_everything(*reader);
  const std::vector<Event> expected = {{1'000'000'000, 0, 0, true},
                                       {1'000'000'500, 239, 179, false},
                                       {1'001'000'000, 10, 20, true},
                                       {1'002'000'000, 11, 21, false},
                                       {1'003'000'001, 12, 22, true}};
  EXPECT_EQ(all.events, expected);

  ASSERT_EQ(all.imu.size(), 2u);
  EXPECT_EQ(all.imu[0].t, 1'000'500'000);
  EXPECT_EQ(all.imu[0].accel_m_s2, Eigen::Vector3d(0.1, 0.2, 9.81));  // accelerometer first
  EXPECT_EQ(all.imu[0].gyro_rad_s, Eigen::Vector3d(0.01, 0.02, 0.03));
  EXPECT_EQ(all.imu[1].accel_m_s2, Eigen::Vector3d(0.4, 0.5, 9.6));

  ASSERT_EQ(all.odometry.size(), 2u);
  EXPECT_EQ(all.odometry[0].t, 1'000'000'000);
  EXPECT_EQ(all.odometry[0].p_W_B, Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(all.odometry[0].q_W_B.isApprox(Eigen::Quaterniond::Identity()));
  // qx qy qz qw = 0 0 s s: 90 degrees about z; the file's last column is qw.
  EXPECT_NEAR(all.odometry[1].q_W_B.w(), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(all.odometry[1].q_W_B.z(), std::sqrt(0.5), 1e-12);
  EXPECT_EQ(all.odometry[1].v_W, Eigen::Vector3d::Zero());
  EXPECT_EQ(all.odometry[1].omega_B, Eigen::Vector3d::Zero());

  // Streams follow the events: chunk k carries the records up to its last event time.
  ASSERT_EQ(all.chunks.size(), 3u);
  EXPECT_EQ(all.chunks[0].events.size(), 2u);
  EXPECT_EQ(all.chunks[0].imu.size(), 0u);       // 1.0005 > 1.0000005
  EXPECT_EQ(all.chunks[0].odometry.size(), 1u);  // 1.0
  EXPECT_EQ(all.chunks[1].imu.size(), 1u);       // 1.0005 <= 1.002
  EXPECT_EQ(all.chunks[1].odometry.size(), 1u);  // 1.002
  EXPECT_EQ(all.chunks[2].imu.size(), 1u);       // the rest once the events are done
  EXPECT_EQ(reader->report().total_dropped(), 0u);
}

TEST(RpgText, BadEventLinesAreDroppedAndCountedWithTheirLine) {
  const auto dir = test::scratch_dir("rpg_bad_events");
  write(dir, "events.txt",
        "1.0 1 1 1\n"    // 1 ok
        "1.1 2 2\n"      // 2 columns
        "abc 3 3 1\n"    // 3 malformed timestamp
        "nan 3 3 1\n"    // 4 non-finite
        "1.2 -1 3 1\n"   // 5 negative pixel
        "1.2 x 3 1\n"    // 6 malformed pixel
        "1.2 3 3 2\n"    // 7 polarity
        "1.2 3 3 -1\n"   // 8 polarity
        "1.3 240 0 1\n"  // 9 outside the 240x180 sensor
        "1.25 4 4 1\n"   // 10 ok
        "1.2 5 5 1\n"    // 11 time went backwards
        "1.4 6 6 0\n"    // 12 ok
        "1.5 1e2 3 1\n"  // 13 malformed pixel (not an integer)
        "inf 1 1 1\n"    // 14 non-finite
        "1.5 7 7 1 9\n"  // 15 columns
        "1.6 8 8 1.0\n"  // 16 polarity
        "1.7 9 nan 1\n"  // 17 non-finite pixel
        "1.8 9 9 0\n");  // 18 ok
  auto reader = open_rpg_text(dir, chunked(4));
  const AllStreams all = read_everything(*reader);
  const std::vector<Event> expected = {{1'000'000'000, 1, 1, true},
                                       {1'250'000'000, 4, 4, true},
                                       {1'400'000'000, 6, 6, false},
                                       {1'800'000'000, 9, 9, false}};
  EXPECT_EQ(all.events, expected);
  const std::string file = (std::filesystem::path(dir) / "events.txt").string();
  const auto& report = reader->report();
  const auto expect_drop = [&](const std::string& reason, std::uint64_t count, int first_line) {
    const auto* e = dropped(report, reason);
    ASSERT_NE(e, nullptr) << reason;
    EXPECT_EQ(e->count, count) << reason;
    EXPECT_EQ(e->first_where, file + ":line " + std::to_string(first_line)) << reason;
  };
  expect_drop("events: expected 4 columns (t x y p)", 2, 2);
  expect_drop("events: malformed timestamp", 1, 3);
  expect_drop("events: non-finite value", 3, 4);
  expect_drop("events: malformed pixel coordinate", 3, 5);
  expect_drop("events: bad polarity (expected 0 or 1)", 3, 7);
  // Sensor-size and time-order drops are counted per batch of lines.
  ASSERT_NE(dropped(report, "event pixel outside the sensor"), nullptr);
  EXPECT_EQ(dropped(report, "event pixel outside the sensor")->count, 1u);
  ASSERT_NE(dropped(report, "event timestamp went backwards"), nullptr);
  EXPECT_EQ(dropped(report, "event timestamp went backwards")->count, 1u);
  EXPECT_EQ(report.total_dropped(), 14u);
}

TEST(RpgText, BadImuAndGroundTruthLinesAreDroppedAndCounted) {
  const auto dir = test::scratch_dir("rpg_bad_streams");
  write(dir, "events.txt", "1.0 1 1 1\n2.0 2 2 0\n");
  write(dir, "imu.txt",
        "1.0 0 0 9.8 0 0 0\n"
        "1.1 0 0 nan 0 0 0\n"     // NaN
        "1.2 0 0 9.8 0 0\n"       // columns
        "1.3 0 0 9.8 0 zero 0\n"  // malformed
        "0.95 0 0 9.8 0 0 0\n"    // backwards
        "1.4 1 0 9.8 0 0 -inf\n"  // infinite
        "1.5 2 0 9.8 0 0 0\n");
  write(dir, "groundtruth.txt",
        "1.0 0 0 0 0 0 0 1\n"
        "1.1 0 0 0 0 0 0 2\n"    // not a unit quaternion
        "1.2 0 NaN 0 0 0 0 1\n"  // NaN
        "bad 0 0 0 0 0 0 1\n"    // timestamp
        "1.3 0 0 0 0 0 1 0\n");
  auto reader = open_recording(dir);
  const AllStreams all = read_everything(*reader);
  ASSERT_EQ(all.imu.size(), 2u);
  EXPECT_EQ(all.imu[1].t, 1'500'000'000);
  EXPECT_EQ(all.imu[1].accel_m_s2.x(), 2.0);
  ASSERT_EQ(all.odometry.size(), 2u);
  EXPECT_EQ(all.odometry[1].t, 1'300'000'000);
  const std::string imu = (std::filesystem::path(dir) / "imu.txt").string();
  const std::string gt = (std::filesystem::path(dir) / "groundtruth.txt").string();
  const auto& report = reader->report();
  const auto expect_drop = [&](const std::string& reason, std::uint64_t count,
                               const std::string& where) {
    const auto* e = dropped(report, reason);
    ASSERT_NE(e, nullptr) << reason;
    EXPECT_EQ(e->count, count) << reason;
    EXPECT_EQ(e->first_where, where) << reason;
  };
  expect_drop("imu: non-finite value", 2, imu + ":line 2");
  expect_drop("imu: expected 7 columns", 1, imu + ":line 3");
  expect_drop("imu: malformed number", 1, imu + ":line 4");
  expect_drop("imu: timestamp went backwards", 1, imu + ":line 5");
  expect_drop("groundtruth: quaternion is not unit length", 1, gt + ":line 2");
  expect_drop("groundtruth: non-finite value", 1, gt + ":line 3");
  expect_drop("groundtruth: malformed timestamp", 1, gt + ":line 4");
  EXPECT_EQ(report.total_dropped(), 8u);
}

TEST(RpgText, EventsOnlyFolderAndStreamingInBoundedChunks) {
  const auto dir = test::scratch_dir("rpg_events_only");
  {
    std::ofstream f(std::filesystem::path(dir) / "events.txt");
    for (int i = 0; i < 10'000; ++i)
      f << "0." << 100'000'000 + i << " " << i % 240 << " " << i % 180 << " " << i % 2 << "\n";
  }
  auto reader = open_recording(dir, chunked(1000));
  EXPECT_EQ(reader->info().streams, std::vector<StreamKind>{StreamKind::kEvents});
  EXPECT_FALSE(reader->info().calibration.has_value());
  const AllStreams all = read_everything(*reader);
  ASSERT_EQ(all.chunks.size(), 10u);
  for (const auto& c : all.chunks) EXPECT_EQ(c.events.size(), 1000u);
  ASSERT_EQ(all.events.size(), 10'000u);
  EXPECT_EQ(all.events[1234], (Event{100'001'234, 1234 % 240, 1234 % 180, false}));
}

TEST(RpgText, AFifoOrAFolderInPlaceOfAFileIsAnErrorNotAHang) {
  // Opening a FIFO blocks until a writer comes: the reader must refuse it before opening.
  for (const char* name : {"events.txt", "imu.txt", "groundtruth.txt", "calib.txt"}) {
    const auto dir = test::scratch_dir(std::string("rpg_fifo_") + name);
    write(dir, "events.txt", "0.1 1 2 1\n");
    const std::string path = dir + "/" + name;
    std::filesystem::remove(path);
    ASSERT_EQ(mkfifo(path.c_str(), 0600), 0) << name;
    EXPECT_EQ(test::input_error_of(path, [&] { open_recording(dir); }),
              " | not a regular file (a FIFO or a device cannot be read)")
        << name;
    std::filesystem::remove(path);
    std::filesystem::create_directory(path);
    EXPECT_EQ(test::input_error_of(path, [&] { open_recording(dir); }), " | is a folder, not a file") << name;
  }
}

TEST(RpgText, BadCalibrationIsAnErrorWithFileAndLine) {
  const auto expect_error = [](const std::string& calib, const std::string& where,
                               const std::string& reason_part) {
    const auto dir = test::scratch_dir("rpg_bad_calib");
    write(dir, "events.txt", "1.0 1 1 1\n");
    write(dir, "calib.txt", calib);
    try {
      open_recording(dir);
      ADD_FAILURE() << "no error for " << calib;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), (std::filesystem::path(dir) / "calib.txt").string());
      EXPECT_EQ(e.where(), where) << calib;
      EXPECT_NE(e.reason().find(reason_part), std::string::npos) << e.reason();
    }
  };
  expect_error("199 198 120 90 0.1\n", "line 1", "4, 8 or 9 numbers");
  expect_error("199 nan 120 90\n", "line 1", "non-finite value in column 2");
  expect_error("199 198 abc 90\n", "line 1", "malformed number in column 3");
  expect_error("# comment\n199 198 600 90\n", "line 2", "far outside");
  expect_error("199 198 120 90\n1 2 3 4\n", "line 2", "single line");
  expect_error("", "line 1", "empty");
}

TEST(RpgText, FolderWithoutEventsIsNotRecognised) {
  const auto dir = test::scratch_dir("rpg_no_events");
  write(dir, "imu.txt", "1.0 0 0 9.8 0 0 0\n");
  EXPECT_THROW(open_recording(dir), InputError);
  EXPECT_THROW(open_rpg_text(dir), InputError);
}

using test::text;

// The in-memory entry points read what the folder reader reads, with the same drops.
TEST(RpgText, InMemoryEntryPointsParseOneFileEach) {
  ReadReport report;
  const auto events = read_rpg_events(
      text("# t x y p\n1.0 3 4 1\n1.5 240 0 1\n1.900000001 5 6 0\nx 1 1 1\n"), "mem/events.txt",
      report);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0], (Event{1'000'000'000, 3, 4, true}));
  EXPECT_EQ(events[1], (Event{1'900'000'001, 5, 6, false}));
  ASSERT_NE(dropped(report, "event pixel outside the sensor"), nullptr);
  ASSERT_NE(dropped(report, "events: malformed timestamp"), nullptr);
  EXPECT_EQ(dropped(report, "events: malformed timestamp")->first_where, "mem/events.txt:line 5");

  const auto imu = read_rpg_imu(text("0.5 1 2 3 4 5 6\n0.25 1 2 3 4 5 6\n"), "imu.txt", report);
  ASSERT_EQ(imu.size(), 1u);
  EXPECT_DOUBLE_EQ(imu[0].accel_m_s2.z(), 3.0);
  EXPECT_DOUBLE_EQ(imu[0].gyro_rad_s.x(), 4.0);
  ASSERT_NE(dropped(report, "imu: timestamp went backwards"), nullptr);

  const auto gt = read_rpg_groundtruth(text("1 1 2 3 0 0 0 1\n"), "groundtruth.txt", report);
  ASSERT_EQ(gt.size(), 1u);
  EXPECT_DOUBLE_EQ(gt[0].p_W_B.y(), 2.0);

  const Calibration c = read_rpg_calib(text("200 200 120 90\n"), "calib.txt");
  EXPECT_DOUBLE_EQ(c.event_camera.fx, 200.0);
  EXPECT_THROW(read_rpg_calib(text("200 200\n"), "calib.txt"), InputError);
}

// 1e10 s is beyond int64 nanoseconds: the line is dropped, no time wraps.
TEST(RpgText, TimesBeyondInt64NanosecondsAreDropped) {
  ReadReport report;
  const auto events = read_rpg_events(
      text("1.0 3 4 1\n9223372037.0 3 4 1\n-9223372037.5 3 4 1\n2.0 3 4 0\n"), "events.txt",
      report);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].t, 2'000'000'000);
  ASSERT_NE(dropped(report, "events: malformed timestamp"), nullptr);
  EXPECT_EQ(dropped(report, "events: malformed timestamp")->count, 2u);
  EXPECT_EQ(dropped(report, "events: malformed timestamp")->first_where, "events.txt:line 2");
}

// A file with no newline is not read into memory whole: an error naming the file and line.
TEST(RpgText, OverlongLineIsAnErrorNamingTheFile) {
  const auto dir = test::scratch_dir("rpg_long_line");
  write(dir, "events.txt", "1.0 3 4 1\n" + std::string(kMaxLineBytes + 1, '1') + "\n");
  auto reader = open_recording(dir);
  SensorChunk chunk;
  try {
    while (reader->read(chunk)) {
    }
    FAIL() << "an overlong line was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), (std::filesystem::path(dir) / "events.txt").string());
    EXPECT_EQ(e.where(), "line 2");
  }
}

// All imu.txt rows up to the first chunk's last event time used to come in that one chunk.
TEST(RpgText, ImuRowsPerChunkAreBounded) {
  const auto dir = test::scratch_dir("rpg_rows_per_chunk");
  write(dir, "events.txt", "1.0 3 4 1\n1.0 3 4 0\n1.0 5 5 1\n");
  std::string imu;
  for (std::size_t i = 0; i < kMaxTableRowsPerChunk + 10; ++i) imu += "0.5 0 0 9.81 0 0 0\n";
  write(dir, "imu.txt", imu);
  auto reader = open_recording(dir, chunked(1));
  SensorChunk c;
  std::size_t total = 0, most = 0;
  while (reader->read(c)) {
    total += c.imu.size();
    most = std::max(most, c.imu.size());
  }
  EXPECT_EQ(total, kMaxTableRowsPerChunk + 10);
  EXPECT_EQ(most, kMaxTableRowsPerChunk);
}

}  // namespace
}  // namespace fdv
