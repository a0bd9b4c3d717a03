#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <span>
#include <sstream>
#include <zstd.h>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/io/dataset/dataset_writer.h"
#include "fdv/io/dataset/depth_image.h"
#include "fdv/io/table_stream.h"
#include "test_support.h"

namespace fdv {
namespace {
namespace fs = std::filesystem;

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

// as_stored gives what a reader of the written folder reads back, to the bit: samples with more
// digits than the rows keep (9 significant), a quaternion the rounding leaves a little off unit
// length, depth between millimetres; and nothing for a row the reader drops.
TEST(Dataset, AsStoredIsWhatTheReaderReadsBack) {
  const auto dir = test::scratch_dir("dataset_as_stored");
  const ImuSample imu{kNsPerMs, {0.123456789012345, -1.0 / 3.0, 2e-7 / 3.0}, {0.1, -9.80665432101, 1e5 / 7.0}};
  OdometrySample odo;
  odo.t = 2 * kNsPerMs;
  odo.p_W_B = {1.0 / 3.0, -2.0 / 7.0, 1.2345678901234};
  odo.q_W_B = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  odo.v_W = {0.7 / 3.0, 0, -1e-9 / 3.0};
  odo.omega_B = {1.0 / 9.0, 2.0 / 9.0, 4.0 / 9.0};
  DepthFrame depth{3 * kNsPerMs, 32, 24, std::vector<float>(32 * 24, 2.3456f)};
  depth.depth_m[0] = std::numeric_limits<float>::quiet_NaN();
  depth.depth_m[1] = 70.0f;  // beyond the 16-bit millimetres
  {
    DatasetWriter w(dir, small_calibration());
    w.add_imu(imu);
    w.add_odometry(odo);
    w.add_depth(depth);
    w.finish();
  }
  const AllStreams all = read_everything(*open_recording(dir, {}));
  ASSERT_EQ(all.imu.size(), 1u);
  ASSERT_EQ(all.odometry.size(), 1u);
  ASSERT_EQ(all.depth.size(), 1u);
  const auto imu_stored = as_stored(imu);
  const auto odo_stored = as_stored(odo);
  ASSERT_TRUE(imu_stored && odo_stored);
  EXPECT_NE(imu_stored->gyro_rad_s, imu.gyro_rad_s);  // the rounding is real
  EXPECT_EQ(imu_stored->t, all.imu[0].t);
  EXPECT_EQ(imu_stored->gyro_rad_s, all.imu[0].gyro_rad_s);
  EXPECT_EQ(imu_stored->accel_m_s2, all.imu[0].accel_m_s2);
  EXPECT_EQ(odo_stored->t, all.odometry[0].t);
  EXPECT_EQ(odo_stored->p_W_B, all.odometry[0].p_W_B);
  EXPECT_EQ(odo_stored->q_W_B.coeffs(), all.odometry[0].q_W_B.coeffs());
  EXPECT_EQ(odo_stored->v_W, all.odometry[0].v_W);
  EXPECT_EQ(odo_stored->omega_B, all.odometry[0].omega_B);
  const DepthFrame depth_stored = as_stored(depth);
  EXPECT_EQ(depth_stored.t, all.depth[0].t);
  EXPECT_EQ(depth_stored.depth_m, all.depth[0].depth_m);
  EXPECT_EQ(depth_stored.depth_m[0], 0.0f);     // invalid
  EXPECT_EQ(depth_stored.depth_m[1], 65535 * 0.001f);  // clamped
  EXPECT_EQ(depth_stored.depth_m[2], 2346 * 0.001f);   // whole millimetres
  ImuSample bad = imu;
  bad.accel_m_s2.x() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(as_stored(bad).has_value());  // the reader drops the row
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

using test::text;

std::string events_bin(std::uint32_t w, std::uint32_t h, std::uint64_t count,
                       const std::vector<Event>& events) {
  std::string b(kEventsMagic, 8);
  b.append(reinterpret_cast<const char*>(&w), 4);
  b.append(reinterpret_cast<const char*>(&h), 4);
  b.append(reinterpret_cast<const char*>(&count), 8);
  for (const Event& e : events) {
    char r[16] = {};
    std::memcpy(r, &e.t, 8);
    std::memcpy(r + 8, &e.x, 2);
    std::memcpy(r + 10, &e.y, 2);
    r[12] = e.polarity ? 1 : 0;
    b.append(r, 16);
  }
  return b;
}

std::string reason_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.where() + ": " + e.reason();
  }
  return "no error";
}

TEST(DatasetInMemory, EventsBinCountIsBoundedByTheBytesPresent) {
  ReadReport report;
  // A count of 2^64-1 with two records: nothing is allocated for the declared count.
  const auto events = read_dataset_events(
      text(events_bin(64, 48, ~std::uint64_t{0}, {{10, 1, 2, true}, {20, 63, 47, false}})),
      "events.bin", 64, 48, report);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1], (Event{20, 63, 47, false}));
  EXPECT_EQ(report.dropped().at("events.bin truncated: events missing at the end").count,
            ~std::uint64_t{0} - 2);
  EXPECT_EQ(reason_of([] {
              ReadReport r;
              read_dataset_events(text(events_bin(65, 48, 0, {})), "events.bin", 64, 48, r);
            }),
            "byte 8: resolution differs from dataset.yaml");
  EXPECT_EQ(reason_of([] {
              ReadReport r;
              read_dataset_events(text("FDVEVT01"), "events.bin", 64, 48, r);
            }),
            "byte 0: truncated header");
}

TEST(DatasetInMemory, ManifestSizeIsBoundedAndNamesTheKey) {
  EXPECT_EQ(parse_dataset_manifest("width: 64\nheight: 48\nformat: fdv_dataset\n", "m").width, 64);
  EXPECT_EQ(parse_dataset_manifest("width: 4096\nheight: 1\n", "m").width, kMaxDatasetSensorSide);
  const auto bad = [](const std::string& yaml) {
    return reason_of([&] { parse_dataset_manifest(yaml, "dataset.yaml"); });
  };
  EXPECT_EQ(bad("width: 0\nheight: 48\n"), "key width: must be 1 to 4096 pixels");
  EXPECT_EQ(bad("width: 64\nheight: -48\n"), "key height: must be 1 to 4096 pixels");
  EXPECT_EQ(bad("width: 4097\nheight: 48\n"), "key width: must be 1 to 4096 pixels");
  EXPECT_EQ(bad("width: 64\n"), "key height: missing (the event sensor size is required)");
  EXPECT_NE(bad("width: 1e10\nheight: 48\n").find("key width: not an integer"), std::string::npos);
  EXPECT_NE(bad("width: [1]\nheight: 48\n").find("key width: not an integer"), std::string::npos);
  EXPECT_EQ(bad("just text"), ": not a YAML mapping (needs width and height)");
  EXPECT_NE(bad("width: [64\n").find("line "), std::string::npos);
  EXPECT_NE(bad(std::string(100'000, '[')).find("nested deeper than the YAML parser's limit"), std::string::npos);
  EXPECT_NE(bad("width: 64\nheight: 48\n#" + std::string(kMaxConfigFileBytes, 'x'))
                .find("larger than"),
            std::string::npos);
}

TEST(DatasetInMemory, CsvFilesAndDepthIndex) {
  ReadReport report;
  const auto imu = read_dataset_imu(text("# t_ns,gx,gy,gz,ax,ay,az\n5,1,2,3,4,5,6\n"), "imu.csv", report);
  ASSERT_EQ(imu.size(), 1u);
  EXPECT_DOUBLE_EQ(imu[0].gyro_rad_s.x(), 1.0);
  EXPECT_DOUBLE_EQ(imu[0].accel_m_s2.z(), 6.0);
  const auto poses = read_dataset_poses(text("7,1,2,3,0,0,0,1,0,0,0,0,0,0\n"), "odometry.csv", report);
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0].t, 7);
  // An id beyond int (a double cast to int would be undefined) is dropped.
  const auto objects = read_dataset_objects(
      text("1,1,0,0,1,0,0,0\n2,1e300,0,0,1,0,0,0\n3,-3e9,0,0,1,0,0,0\n4,2,0,0,1,0,0,0\n"),
      "objects.csv", report);
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_EQ(objects[1].id, 2);
  EXPECT_EQ(report.dropped().at("ground truth: object id is not an integer").count, 2u);
  // A frame file must lie inside the folder: an absolute path or ".." could name a device.
  const auto rows = read_dataset_depth_index(
      text("1,depth/0.png\n2,/dev/zero\n3,../x.png\n4,depth/../../x.png\n5,depth/1.png\n"),
      "depth.csv", report);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].file, "depth/1.png");
  EXPECT_EQ(report.dropped().at("depth: file path leaves the dataset folder").count, 3u);
  EXPECT_EQ(report.dropped().at("depth: file path leaves the dataset folder").first_where,
            "depth.csv:line 2");
}

std::vector<std::uint8_t> png_of(const cv::Mat& m) {
  std::vector<std::uint8_t> bytes;
  cv::imencode(".png", m, bytes);
  return bytes;
}

TEST(DatasetInMemory, DepthPngIsCheckedBeforeDecoding) {
  cv::Mat mm(3, 4, CV_16UC1, cv::Scalar(1500));
  mm.at<std::uint16_t>(2, 3) = 0;
  ReadReport report;
  const auto frame = decode_dataset_depth(png_of(mm), 42, std::nullopt, "d.png", report);
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->t, 42);
  EXPECT_EQ(frame->width, 4);
  EXPECT_FLOAT_EQ(frame->at(0, 0), 1.5f);
  EXPECT_FLOAT_EQ(frame->at(3, 2), 0.0f);
  EXPECT_FALSE(decode_dataset_depth(png_of(mm), 0, PinholeCamera{5, 3, 1, 1, 2, 1, {}}, "d.png",
                                    report));
  EXPECT_EQ(report.dropped().at("depth: image size differs from the depth camera calibration").count,
            1u);
  EXPECT_FALSE(decode_dataset_depth(png_of(cv::Mat(3, 4, CV_8UC1, cv::Scalar(1))), 0,
                                    std::nullopt, "d.png", report));
  EXPECT_EQ(report.dropped().at("depth: image is not 16-bit single channel").count, 1u);
  // A header declaring 30000 x 30000 (1.8 GB decoded) is refused before OpenCV allocates.
  std::vector<std::uint8_t> huge = png_of(mm);
  const std::uint8_t side[4] = {0, 0, 0x75, 0x30};  // 30000 big-endian
  std::memcpy(&huge[16], side, 4);
  std::memcpy(&huge[20], side, 4);
  EXPECT_FALSE(decode_dataset_depth(huge, 0, std::nullopt, "d.png", report));
  EXPECT_EQ(report.dropped().at("depth: image larger than 4194304 pixels").count, 1u);
  // Neither encoding: a TIFF, nothing.
  std::vector<std::uint8_t> tiff;
  cv::imencode(".tiff", mm, tiff);
  EXPECT_FALSE(decode_dataset_depth(tiff, 0, std::nullopt, "d.png", report));
  EXPECT_FALSE(decode_dataset_depth({}, 0, std::nullopt, "d.png", report));
  EXPECT_EQ(report.dropped().at("depth: file is neither a PNG nor a Zstandard frame").count, 2u);
  // A valid header with a corrupt body.
  std::vector<std::uint8_t> cut = png_of(mm);
  cut.resize(40);
  EXPECT_FALSE(decode_dataset_depth(cut, 0, std::nullopt, "d.png", report));
  EXPECT_EQ(report.dropped().at("depth: image missing or unreadable").count, 1u);
}

// The two encodings against an independent codec: OpenCV's PNG writer and reader.
TEST(DepthImage, PngFromEitherWriterDecodesToTheSameMillimetres) {
  cv::Mat mm(7, 9, CV_16UC1);
  for (int v = 0; v < mm.rows; ++v)
    for (int u = 0; u < mm.cols; ++u) mm.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(v * 9000 + u * 7 + 1);
  mm.at<std::uint16_t>(3, 4) = 65535;
  const std::span<const std::uint16_t> values(mm.ptr<std::uint16_t>(), mm.total());
  std::vector<std::uint16_t> decoded(mm.total());
  ASSERT_EQ(decode_depth_png(png_of(mm), 9, 7, decoded), "");
  EXPECT_TRUE(std::equal(decoded.begin(), decoded.end(), values.begin()));
  const std::vector<std::uint8_t> ours = encode_depth_png(values, 9, 7);
  const cv::Mat by_opencv = cv::imdecode(ours, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(by_opencv.type(), CV_16UC1);
  EXPECT_EQ(cv::countNonZero(by_opencv != mm), 0);
  std::fill(decoded.begin(), decoded.end(), 0);
  ASSERT_EQ(decode_depth_png(ours, 9, 7, decoded), "");
  EXPECT_TRUE(std::equal(decoded.begin(), decoded.end(), values.begin()));
  // The size the caller expects is the image's, or it is an error (never a write past the span).
  EXPECT_NE(decode_depth_png(ours, 9, 6, std::span(decoded).first(54)), "");
}

TEST(DepthImage, ZstdFrameHoldsTheLittleEndianMillimetres) {
  const std::vector<std::uint16_t> values = {0, 1, 1500, 65535, 258, 7};
  const std::vector<std::uint8_t> frame = encode_depth_zstd(values);
  std::vector<std::uint8_t> raw(values.size() * 2);
  ASSERT_EQ(ZSTD_decompress(raw.data(), raw.size(), frame.data(), frame.size()), raw.size());
  EXPECT_EQ(raw[6], 0xFF);  // 65535
  EXPECT_EQ(raw[8], 2);     // 258 = 0x0102, low byte first
  EXPECT_EQ(raw[9], 1);
  std::vector<std::uint16_t> decoded(values.size());
  ASSERT_EQ(decode_depth_zstd(frame, decoded), "");
  EXPECT_EQ(decoded, values);
  std::vector<std::uint16_t> larger(values.size() + 1);
  EXPECT_NE(decode_depth_zstd(frame, larger).find("frame holds 12 bytes"), std::string::npos);
  std::vector<std::uint8_t> cut = frame;
  cut.resize(cut.size() - 2);
  EXPECT_NE(decode_depth_zstd(cut, decoded), "");
}

TEST(DatasetInMemory, DepthZstdFrameTakesItsSizeFromTheCalibration) {
  const std::vector<std::uint16_t> values = {1500, 0, 2000, 250, 65535, 1};  // 3 x 2
  const std::vector<std::uint8_t> frame = encode_depth_zstd(values);
  ReadReport report;
  const auto f = decode_dataset_depth(frame, 7, PinholeCamera{3, 2, 1, 1, 1, 1, {}}, "d.zst", report);
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->width, 3);
  EXPECT_EQ(f->height, 2);
  EXPECT_FLOAT_EQ(f->at(0, 0), 1.5f);
  EXPECT_FLOAT_EQ(f->at(1, 0), 0.0f);
  EXPECT_FLOAT_EQ(f->at(1, 1), 65.535f);
  EXPECT_FALSE(decode_dataset_depth(frame, 7, std::nullopt, "d.zst", report));
  EXPECT_EQ(report.dropped().at("depth: a Zstandard frame needs the depth camera's size (calibration.yaml)").count, 1u);
  EXPECT_FALSE(decode_dataset_depth(frame, 7, PinholeCamera{4, 2, 1, 1, 1, 1, {}}, "d.zst", report));
  EXPECT_EQ(report.dropped().at("depth: image missing or unreadable").first_where,
            "d.zst: frame holds 12 bytes, not the 16 of the depth camera's image");
}

// The writer's two encodings read back to the same frame, rounded to millimetres.
TEST(Dataset, DepthFramesRoundTripInBothEncodings) {
  Calibration calib = small_calibration();
  DepthFrame frame;
  frame.t = 5000;
  frame.width = calib.depth_camera->width;
  frame.height = calib.depth_camera->height;
  frame.depth_m.resize(static_cast<std::size_t>(frame.width) * frame.height);
  for (std::size_t i = 0; i < frame.depth_m.size(); ++i) frame.depth_m[i] = 0.25f + 0.0137f * static_cast<float>(i % 997);
  frame.depth_m[3] = std::numeric_limits<float>::quiet_NaN();
  frame.depth_m[4] = -1.0f;
  frame.depth_m[5] = 100.0f;  // beyond 65.535 m: the largest value
  for (const auto& [encoding, ext] : {std::pair{DepthEncoding::kZstd, ".zst"}, std::pair{DepthEncoding::kPng, ".png"}}) {
    const auto dir = test::scratch_dir(std::string("dataset_depth_round_trip") + ext);
    {
      DatasetWriter w(dir, calib, encoding);
      w.add_events(std::vector<Event>{{0, 1, 1, true}, {10000, 2, 2, false}});
      w.add_depth(frame);
      w.finish();
    }
    EXPECT_TRUE(fs::exists(fs::path(dir) / ("depth/000000" + std::string(ext))));
    auto reader = open_recording(dir);
    const auto all = read_everything(*reader);
    ASSERT_EQ(all.depth.size(), 1u) << ext;
    const DepthFrame& back = all.depth[0];
    EXPECT_EQ(back.t, 5000);
    ASSERT_EQ(back.depth_m.size(), frame.depth_m.size());
    for (std::size_t i = 6; i < frame.depth_m.size(); ++i)
      ASSERT_NEAR(back.depth_m[i], frame.depth_m[i], 0.0005f + 1e-6f) << ext << " pixel " << i;
    EXPECT_EQ(back.depth_m[3], 0.0f);
    EXPECT_EQ(back.depth_m[4], 0.0f);
    EXPECT_FLOAT_EQ(back.depth_m[5], 65.535f);
  }
}

// The folder reader runs the same checks: a depth row naming a device or a folder is dropped.
TEST(Dataset, DepthRowsOutsideTheFolderOrNotFilesAreDropped) {
  const auto dir = test::scratch_dir("dataset_depth_paths");
  {
    DatasetWriter w(dir, small_calibration());
    w.add_events(std::vector<Event>{{0, 1, 1, true}, {100, 2, 2, false}});
    w.finish();
  }
  std::ofstream(dir + "/depth.csv") << "# t_ns,file\n10,/dev/zero\n20,depth\n30,../dataset_bad_rows/imu.csv\n";
  auto reader = open_recording(dir);
  EXPECT_TRUE(read_everything(*reader).depth.empty());
  const auto& dropped = reader->report().dropped();
  EXPECT_EQ(dropped.at("depth: file path leaves the dataset folder").count, 2u);
  EXPECT_EQ(dropped.at("depth: image missing or unreadable").count, 1u);
}

// The file name comes from depth.csv and reaches the report: fdv info's JSON needs UTF-8
// (it ended with nlohmann's type_error.316).
TEST(Dataset, DepthFileNameInTheReportIsValidUtf8) {
  const auto dir = test::scratch_dir("dataset_depth_name_utf8");
  {
    DatasetWriter w(dir, small_calibration());
    w.add_events(std::vector<Event>{{0, 1, 1, true}, {100, 2, 2, false}});
    w.finish();
  }
  std::ofstream(dir + "/depth.csv") << "# t_ns,file\n10,depth/\xFF\xFE.png\n";
  auto reader = open_recording(dir);
  read_everything(*reader);
  EXPECT_EQ(reader->report().dropped().at("depth: image missing or unreadable").first_where,
            dir + "/depth/\\xFF\\xFE.png");
  EXPECT_NO_THROW(reader->report().to_json().dump());
}

TEST(Dataset, ManifestSizeOutOfBoundsIsAnErrorNamingTheKey) {
  const auto dir = test::scratch_dir("dataset_manifest_bounds");
  {
    DatasetWriter w(dir, small_calibration());
    w.finish();
  }
  std::ofstream(dir + "/dataset.yaml") << "format: fdv_dataset\nwidth: -64\nheight: 48\n";
  try {
    open_recording(dir);
    FAIL() << "a negative width was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir + "/dataset.yaml");
    EXPECT_EQ(e.where(), "key width");
  }
}

// Rows up to a chunk's horizon come in bounded pieces: all IMU rows and depth frames at the first
// event's time were handed out in the first chunk (a 1 GB imu.csv would have been one chunk).
TEST(Dataset, RowsPerChunkAreBoundedWhateverTheHorizon) {
  const auto dir = test::scratch_dir("dataset_rows_per_chunk");
  const std::size_t imu_rows = kMaxTableRowsPerChunk + 100, depth_rows = 3 * kMaxDepthFramesPerChunk;
  {
    DatasetWriter w(dir, small_calibration());
    w.add_events(std::vector<Event>(2000, Event{0, 1, 1, true}));
    w.add_depth(DepthFrame{0, 32, 24, std::vector<float>(32 * 24, 1.0f)});
    for (std::size_t i = 0; i < imu_rows; ++i) w.add_imu({0, {0, 0, 0}, {0, 0, 9.81}});
    w.finish();
  }
  {
    std::ifstream in(dir + "/depth.csv");
    std::string header, row;
    std::getline(in, header);
    std::getline(in, row);
    std::ofstream out(dir + "/depth.csv");
    out << header << "\n";
    for (std::size_t i = 0; i < depth_rows; ++i) out << row << "\n";
  }
  ReaderOptions options;
  options.chunk_events = 500;
  auto reader = open_recording(dir, options);
  SensorChunk c;
  std::size_t imu = 0, depth = 0, max_imu = 0, max_depth = 0;
  while (reader->read(c)) {
    imu += c.imu.size();
    depth += c.depth.size();
    max_imu = std::max(max_imu, c.imu.size());
    max_depth = std::max(max_depth, c.depth.size());
  }
  EXPECT_EQ(imu, imu_rows);
  EXPECT_EQ(depth, depth_rows);
  EXPECT_EQ(max_imu, kMaxTableRowsPerChunk);
  EXPECT_EQ(max_depth, kMaxDepthFramesPerChunk);
}

// chunk_events = 0 read nothing and never finished (read() returned true forever).
TEST(Dataset, ZeroChunkEventsStillEnds) {
  const auto dir = test::scratch_dir("dataset_zero_chunk");
  {
    DatasetWriter w(dir, small_calibration());
    w.add_events(std::vector<Event>{{0, 1, 1, true}, {100, 2, 2, false}});
    w.finish();
  }
  ReaderOptions zero;
  zero.chunk_events = 0;
  auto reader = open_recording(dir, zero);
  EXPECT_EQ(read_everything(*reader).events.size(), 2u);
}

}  // namespace
}  // namespace fdv
