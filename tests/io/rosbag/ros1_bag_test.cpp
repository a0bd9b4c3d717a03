// ROS 1 bag reader against bags written here by ROS's own library (ros1_bag_writer.h): every
// expected value comes from the generator formulas below, never from the reader.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "fdv/core/error.h"
#include "fdv/io/recording.h"
#include "fdv/io/rosbag/rosbag_reader.h"
#include "ros1_bag_writer.h"
#include "test_support.h"

namespace fdv {
namespace {

namespace fs = std::filesystem;
using test::ros1::BagWriter;
using test::ros1::Pose;
using test::ros1::RawEvent;
using test::ros1::Stamp;

constexpr std::uint32_t kSec = 1000;  // every stamp is 1000 s + nsec
constexpr int kWidth = 346, kHeight = 260;
constexpr int kEventMessages = 5, kEventsPerMessage = 100;
constexpr int kOutsideEvent = 250;  // written with x = 400: outside the sensor

Stamp at_ns(std::uint32_t nsec) { return {kSec, nsec}; }
TimeNs ns(std::uint32_t nsec) { return TimeNs{kSec} * kNsPerS + nsec; }

RawEvent event_k(int k) {
  RawEvent e;
  e.x = static_cast<std::uint16_t>(k == kOutsideEvent ? 400 : (k * 37) % kWidth);
  e.y = static_cast<std::uint16_t>((k * 11) % kHeight);
  e.ts = at_ns(static_cast<std::uint32_t>(k) * 20'000);
  e.polarity = k % 3 == 0;
  return e;
}

const double kS45 = std::sqrt(0.5);  // quaternion of 90 degrees about z: (0, 0, s45, s45)

/// The reference bag: every stream, several candidates for IMU, an image topic that is not
/// depth, a pose topic that is not ground truth, one depth frame of an unusable encoding.
void write_reference_bag(const std::string& path,
                         BagWriter::Compression compression = BagWriter::Compression::kNone) {
  BagWriter bag(path, compression);
  for (int m = 0; m < kEventMessages; ++m) {
    std::vector<RawEvent> events;
    for (int k = m * kEventsPerMessage; k < (m + 1) * kEventsPerMessage; ++k)
      events.push_back(event_k(k));
    const Stamp last = events.back().ts;
    bag.event_array("/dvs/events", {last.sec, last.nsec + 1000}, last, kWidth, kHeight, events);
  }
  for (int i = 0; i < 20; ++i) {
    const std::uint32_t t = static_cast<std::uint32_t>(i) * 500'000;
    bag.imu("/mavros/imu/data", at_ns(t + 100'000), at_ns(t), {0.01 * i, -0.02 * i, 0.5},
            {0.0, 0.0, 9.81 + 0.001 * i});
  }
  for (int i = 0; i < 30; ++i) {
    const std::uint32_t t = static_cast<std::uint32_t>(i) * 300'000;
    bag.imu("/dvs/imu", at_ns(t + 50'000), at_ns(t), {7, 7, 7}, {7, 7, 7});
  }
  {  // 16UC1, 4x3, step 8: mm = 1000 + 10 * (4v + u), pixel (1, 1) zero
    std::vector<std::uint8_t> data;
    for (int v = 0; v < 3; ++v)
      for (int u = 0; u < 4; ++u) {
        const std::uint16_t mm =
            (u == 1 && v == 1) ? 0 : static_cast<std::uint16_t>(1000 + 10 * (4 * v + u));
        data.push_back(static_cast<std::uint8_t>(mm & 0xFF));
        data.push_back(static_cast<std::uint8_t>(mm >> 8));
      }
    bag.image("/camera/depth/image_rect_raw", at_ns(2'000'100), at_ns(2'000'000), 4, 3, "16UC1", 8,
              data);
  }
  {  // 32FC1, 3x2, step 16 (4 bytes of row padding): 2.5, NaN, -1 / inf, 0.75, 10
    const float values[2][3] = {{2.5f, NAN, -1.0f}, {INFINITY, 0.75f, 10.0f}};
    std::vector<std::uint8_t> data(32, 0xEE);
    for (int v = 0; v < 2; ++v) std::memcpy(data.data() + 16 * v, values[v], 12);
    bag.image("/camera/depth/image_rect_raw", at_ns(5'000'100), at_ns(5'000'000), 3, 2, "32FC1", 16,
              data);
  }
  bag.image("/camera/depth/image_rect_raw", at_ns(8'000'100), at_ns(8'000'000), 2, 2, "bgr8", 6,
            std::vector<std::uint8_t>(12, 1));
  bag.image("/dvs/image_raw", at_ns(3'000'000), at_ns(3'000'000), 2, 2, "mono8", 2,
            std::vector<std::uint8_t>(4, 9));
  for (int i = 0; i < 4; ++i) {
    const std::uint32_t t = static_cast<std::uint32_t>(i) * 2'500'000;
    Pose p;
    p.p = {1.0 * i, 2.0 * i, 3.0};
    p.q = {0, 0, kS45, kS45};
    bag.odometry("/mavros/local_position/odom", at_ns(t + 10), at_ns(t), p, {1.0, 0.0, 0.5},
                 {0.1, 0.2, 0.3});
  }
  for (int i = 0; i < 3; ++i) {
    const std::uint32_t t = static_cast<std::uint32_t>(i) * 4'000'000 + 1'000;
    Pose p;
    p.p = {5.0 - i, 0.1 * i, 1.5};
    bag.transform_stamped("/vicon/ball/ball", at_ns(t), at_ns(t), p);
  }
  for (int i = 0; i < 2; ++i) {
    Pose p;
    p.p = {-1.0 * i, 0, 0};
    bag.pose_stamped("/drone/pose", at_ns(static_cast<std::uint32_t>(i) * 1'000'000),
                     at_ns(static_cast<std::uint32_t>(i) * 1'000'000), p);
  }
}

struct Everything {
  SensorChunk all;
  std::size_t chunks = 0;
  std::size_t max_chunk_events = 0;
};

Everything read_all(RecordingReader& reader) {
  Everything out;
  SensorChunk chunk;
  while (reader.read(chunk)) {
    ++out.chunks;
    out.max_chunk_events = std::max(out.max_chunk_events, chunk.events.size());
    auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
    append(out.all.events, chunk.events);
    append(out.all.imu, chunk.imu);
    append(out.all.depth, chunk.depth);
    append(out.all.odometry, chunk.odometry);
    append(out.all.ground_truth, chunk.ground_truth);
  }
  return out;
}

template <typename T>
bool non_decreasing(const std::vector<T>& v) {
  for (std::size_t i = 1; i < v.size(); ++i)
    if (v[i].t < v[i - 1].t) return false;
  return true;
}

bool has_note(const RecordingInfo& info, const std::string& part) {
  for (const auto& n : info.notes)
    if (n.find(part) != std::string::npos) return true;
  return false;
}

std::string expect_input_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError";
  return {};
}

class Ros1BagTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir("ros1_bag");
    bag_ = dir_ + "/run.bag";
    write_reference_bag(bag_);
  }
  std::string dir_, bag_;
};

TEST_F(Ros1BagTest, ReadsEveryStreamWrittenByRosbag) {
  ReaderOptions options;
  options.chunk_events = 150;
  auto reader = open_recording(bag_, options);  // detected by its magic bytes
  const auto& info = reader->info();
  EXPECT_EQ(info.format, "ros1_bag");
  EXPECT_EQ(info.width, kWidth);
  EXPECT_EQ(info.height, kHeight);
  const Everything got = read_all(*reader);

  // Events: all but the one outside the sensor, with their own per-event stamps.
  std::vector<Event> expected;
  for (int k = 0; k < kEventMessages * kEventsPerMessage; ++k) {
    if (k == kOutsideEvent) continue;
    const RawEvent e = event_k(k);
    expected.push_back({ns(e.ts.nsec), e.x, e.y, e.polarity});
  }
  EXPECT_EQ(got.all.events, expected);
  ASSERT_TRUE(reader->report().dropped().count("event pixel outside the sensor"));
  EXPECT_EQ(reader->report().dropped().at("event pixel outside the sensor").count, 1u);
  // Chunks of whole messages: at least chunk_events, at most one message more.
  EXPECT_GE(got.chunks, 3u);
  EXPECT_LE(got.max_chunk_events, options.chunk_events + kEventsPerMessage - 1);

  // IMU: the paper's topic wins over /dvs/imu, which has more messages; header stamps.
  ASSERT_EQ(got.all.imu.size(), 20u);
  for (int i = 0; i < 20; ++i) {
    const auto& s = got.all.imu[static_cast<std::size_t>(i)];
    EXPECT_EQ(s.t, ns(static_cast<std::uint32_t>(i) * 500'000));
    EXPECT_EQ(s.gyro_rad_s, Eigen::Vector3d(0.01 * i, -0.02 * i, 0.5));
    EXPECT_EQ(s.accel_m_s2, Eigen::Vector3d(0.0, 0.0, 9.81 + 0.001 * i));
  }
  EXPECT_TRUE(has_note(info, "imu: chose /mavros/imu/data among /dvs/imu, /mavros/imu/data"));

  // Depth: 16UC1 in mm -> m; 32FC1 in m with NaN / negative / inf -> 0; bgr8 dropped.
  ASSERT_EQ(got.all.depth.size(), 2u);
  const DepthFrame& d0 = got.all.depth[0];
  EXPECT_EQ(d0.t, ns(2'000'000));
  ASSERT_EQ(d0.width, 4);
  ASSERT_EQ(d0.height, 3);
  for (int v = 0; v < 3; ++v)
    for (int u = 0; u < 4; ++u)
      EXPECT_FLOAT_EQ(d0.at(u, v), (u == 1 && v == 1)
                                       ? 0.0f
                                       : static_cast<float>(1000 + 10 * (4 * v + u)) * 0.001f);
  const DepthFrame& d1 = got.all.depth[1];
  ASSERT_EQ(d1.width, 3);
  ASSERT_EQ(d1.height, 2);
  EXPECT_EQ(d1.depth_m, (std::vector<float>{2.5f, 0.0f, 0.0f, 0.0f, 0.75f, 10.0f}));
  EXPECT_EQ(reader->report().dropped().at("depth: image encoding is neither 16UC1 nor 32FC1").count,
            1u);

  // Odometry: pose as given; the twist is in the body frame: v_W = Rz(90 deg) (1, 0, 0.5).
  ASSERT_EQ(got.all.odometry.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    const auto& o = got.all.odometry[static_cast<std::size_t>(i)];
    EXPECT_EQ(o.t, ns(static_cast<std::uint32_t>(i) * 2'500'000));
    EXPECT_EQ(o.p_W_B, Eigen::Vector3d(1.0 * i, 2.0 * i, 3.0));
    EXPECT_NEAR(o.q_W_B.z(), kS45, 1e-12);
    EXPECT_NEAR(o.q_W_B.w(), kS45, 1e-12);
    EXPECT_NEAR((o.v_W - Eigen::Vector3d(0.0, 1.0, 0.5)).norm(), 0.0, 1e-12);
    EXPECT_EQ(o.omega_B, Eigen::Vector3d(0.1, 0.2, 0.3));
  }

  // Ground truth: the Vicon transform, not the vehicle's own pose topic.
  ASSERT_EQ(got.all.ground_truth.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const auto& g = got.all.ground_truth[static_cast<std::size_t>(i)];
    EXPECT_EQ(g.t, ns(static_cast<std::uint32_t>(i) * 4'000'000 + 1'000));
    EXPECT_EQ(g.p_W, Eigen::Vector3d(5.0 - i, 0.1 * i, 1.5));
  }

  // Topic listing: every topic, with type, count and rate over its bag-time span.
  ASSERT_EQ(info.topics.size(), 8u);
  std::map<std::string, TopicInfo> topics;
  for (const auto& t : info.topics) topics[t.topic] = t;
  EXPECT_EQ(topics["/dvs/events"].type, "dvs_msgs/EventArray");
  EXPECT_EQ(topics["/dvs/events"].count, 5u);
  EXPECT_EQ(topics["/mavros/imu/data"].type, "sensor_msgs/Imu");
  EXPECT_EQ(topics["/mavros/imu/data"].count, 20u);
  EXPECT_NEAR(topics["/mavros/imu/data"].rate_hz, 19 / 0.0095, 1e-6);  // 20 msgs over 9.5 ms
  EXPECT_EQ(topics["/dvs/imu"].count, 30u);
  EXPECT_EQ(topics["/camera/depth/image_rect_raw"].count, 3u);
  EXPECT_EQ(topics["/dvs/image_raw"].type, "sensor_msgs/Image");
  EXPECT_EQ(topics["/mavros/local_position/odom"].type, "nav_msgs/Odometry");
  EXPECT_EQ(topics["/vicon/ball/ball"].type, "geometry_msgs/TransformStamped");
  EXPECT_EQ(topics["/drone/pose"].type, "geometry_msgs/PoseStamped");
  EXPECT_EQ(topics["/drone/pose"].rate_hz, 1000.0);  // 2 messages 1 ms apart
  EXPECT_EQ(info.streams.size(), 5u);
}

TEST_F(Ros1BagTest, CompressedChunksReadTheSame) {
  for (auto c : {BagWriter::Compression::kLz4, BagWriter::Compression::kBz2}) {
    const std::string path = dir_ + "/compressed.bag";
    write_reference_bag(path, c);
    auto plain = open_ros1_bag(bag_);
    auto packed = open_ros1_bag(path);
    const Everything a = read_all(*plain), b = read_all(*packed);
    EXPECT_EQ(a.all.events, b.all.events);
    ASSERT_EQ(a.all.imu.size(), b.all.imu.size());
    ASSERT_EQ(a.all.depth.size(), b.all.depth.size());
    EXPECT_EQ(a.all.depth[1].depth_m, b.all.depth[1].depth_m);
    EXPECT_EQ(b.all.events.size(), 499u);
  }
}

TEST_F(Ros1BagTest, TopicsChosenByOptions) {
  ReaderOptions options;
  options.imu_topic = "/dvs/imu";
  options.odometry_topic = "/drone/pose";  // a pose topic may serve as odometry when asked for
  options.ground_truth_topic = "/mavros/local_position/odom";  // and odometry as ground truth
  auto reader = open_ros1_bag(bag_, options);
  const Everything got = read_all(*reader);
  ASSERT_EQ(got.all.imu.size(), 30u);
  EXPECT_EQ(got.all.imu[3].gyro_rad_s, Eigen::Vector3d(7, 7, 7));
  EXPECT_EQ(got.all.imu[3].t, ns(900'000));
  ASSERT_EQ(got.all.odometry.size(), 2u);
  EXPECT_EQ(got.all.odometry[1].p_W_B, Eigen::Vector3d(-1, 0, 0));
  EXPECT_EQ(got.all.odometry[1].v_W, Eigen::Vector3d::Zero());
  ASSERT_EQ(got.all.ground_truth.size(), 4u);
  EXPECT_EQ(got.all.ground_truth[2].p_W, Eigen::Vector3d(2, 4, 3));
}

TEST_F(Ros1BagTest, AutomaticChoiceSkipsATopicTheUserAssigned) {
  ReaderOptions options;
  options.odometry_topic = "/vicon/ball/ball";  // the only ground-truth candidate
  auto reader = open_ros1_bag(bag_, options);
  const Everything got = read_all(*reader);
  EXPECT_EQ(got.all.odometry.size(), 3u);
  EXPECT_TRUE(got.all.ground_truth.empty());

  options.ground_truth_topic = "/vicon/ball/ball";
  const std::string what = expect_input_error([&] { open_ros1_bag(bag_, options); });
  EXPECT_NE(what.find("requested for both the odometry and the ground_truth stream"),
            std::string::npos)
      << what;
}

TEST_F(Ros1BagTest, WrongTypeOnRequestedTopicIsAnError) {
  ReaderOptions options;
  options.events_topic = "/mavros/imu/data";
  const std::string what = expect_input_error([&] { open_ros1_bag(bag_, options); });
  EXPECT_NE(what.find("topic /mavros/imu/data"), std::string::npos) << what;
  EXPECT_NE(what.find("sensor_msgs/Imu"), std::string::npos) << what;
  EXPECT_NE(what.find("dvs_msgs/EventArray"), std::string::npos) << what;
}

TEST_F(Ros1BagTest, MissingRequestedTopicIsAnError) {
  ReaderOptions options;
  options.depth_topic = "/camera/depth/missing";
  const std::string what = expect_input_error([&] { open_ros1_bag(bag_, options); });
  EXPECT_NE(what.find("no such topic"), std::string::npos) << what;
  EXPECT_NE(what.find("/camera/depth/image_rect_raw (sensor_msgs/Image)"), std::string::npos)
      << what;
}

TEST_F(Ros1BagTest, EmptyBagHasNoTopicsAndNoData) {
  const std::string path = dir_ + "/empty.bag";
  { BagWriter bag(path); }
  auto reader = open_recording(path);
  EXPECT_TRUE(reader->info().topics.empty());
  EXPECT_TRUE(reader->info().streams.empty());
  SensorChunk chunk;
  EXPECT_FALSE(reader->read(chunk));
  EXPECT_TRUE(chunk.empty());
}

TEST_F(Ros1BagTest, Md5MismatchIsAnError) {
  const std::string path = dir_ + "/md5.bag";
  {
    BagWriter bag(path);
    bag.event_array("/dvs/events", at_ns(1000), at_ns(1000), kWidth, kHeight, {event_k(1)},
                    "dvs_msgs/EventArray", "0123456789abcdef0123456789abcdef");
  }
  const std::string what = expect_input_error([&] { open_ros1_bag(path); });
  EXPECT_NE(what.find("MD5"), std::string::npos) << what;
  EXPECT_NE(what.find("0123456789abcdef0123456789abcdef"), std::string::npos) << what;
  EXPECT_NE(what.find(test::ros1::kEventArrayMd5), std::string::npos) << what;
}

TEST_F(Ros1BagTest, PropheseeEventArrayHasTheDvsLayout) {
  const std::string path = dir_ + "/prophesee.bag";
  {
    BagWriter bag(path);
    bag.event_array("/prophesee/camera/cd_events_buffer", at_ns(100'000), at_ns(100'000), kWidth,
                    kHeight, {event_k(3), event_k(4)}, "prophesee_event_msgs/EventArray");
  }
  auto reader = open_ros1_bag(path);
  const Everything got = read_all(*reader);
  ASSERT_EQ(got.all.events.size(), 2u);
  EXPECT_EQ(got.all.events[1], (Event{ns(80'000), event_k(4).x, event_k(4).y, false}));
  EXPECT_TRUE(got.all.events[0].polarity);
}

// event_camera_msgs/EventPacket in ROS 1 bags: the ROS 2 reader's decoders, on packets encoded
// here from the encodings' definitions (docs/FORMATS.md, "ROS 2 bags").
void append_word(std::vector<std::uint8_t>& b, std::uint64_t w) {
  for (int i = 0; i < 8; ++i) b.push_back(static_cast<std::uint8_t>(w >> (8 * i)));
}
std::uint64_t mono_word(std::uint64_t x, std::uint64_t y, bool on, std::uint32_t dt_ns) {
  return (std::uint64_t{on} << 63) | (y << 48) | (x << 32) | dt_ns;
}
/// libcaer: uint32 data (x << 17 | y << 2 | polarity << 1 | valid), then int32 ts in us.
std::uint64_t libcaer_word(std::uint32_t x, std::uint32_t y, bool on, bool valid,
                           std::uint32_t ts_us) {
  const std::uint32_t data = (x << 17) | (y << 2) | (on ? 2u : 0u) | (valid ? 1u : 0u);
  return (std::uint64_t{ts_us} << 32) | data;
}

TEST_F(Ros1BagTest, EventPacketsInMonoAndLibcaer) {
  const std::string path = dir_ + "/event_packets.bag";
  {
    BagWriter bag(path);
    std::vector<std::uint8_t> m0, m1, c0;
    append_word(m0, mono_word(10, 20, true, 1'000));  // sensor time base 5 s
    append_word(m0, mono_word(11, 21, false, 2'000));
    append_word(m1, mono_word(12, 22, true, 500'000));
    bag.event_packet("/dvs/events", at_ns(100), at_ns(50), 64, 48, 5'000'000'000, "mono", m0);
    bag.event_packet("/dvs/events", at_ns(600'000), at_ns(499'000), 64, 48, 5'000'001'000, "mono",
                     m1);
    append_word(c0, libcaer_word(1, 2, true, true, 10));
    append_word(c0, libcaer_word(3, 4, true, false, 20));  // marked invalid
    append_word(c0, libcaer_word(5, 6, false, true, 25));
    bag.event_packet("/caer/events", at_ns(200), at_ns(200), 64, 48,
                     static_cast<std::uint64_t>(ns(0)), "libcaer", c0);
  }
  ReaderOptions options;
  options.events_topic = "/dvs/events";
  auto mono = open_ros1_bag(path, options);
  EXPECT_EQ(mono->info().width, 64);
  EXPECT_EQ(mono->info().height, 48);
  const Everything got = read_all(*mono);
  // Sensor time time_base + dt, moved so that the first event lands on its header stamp.
  ASSERT_EQ(got.all.events.size(), 3u);
  EXPECT_EQ(got.all.events[0], (Event{ns(50), 10, 20, true}));
  EXPECT_EQ(got.all.events[1], (Event{ns(1'050), 11, 21, false}));
  EXPECT_EQ(got.all.events[2], (Event{ns(500'050), 12, 22, true}));

  options.events_topic = "/caer/events";
  auto caer = open_ros1_bag(path, options);
  const Everything c = read_all(*caer);
  ASSERT_EQ(c.all.events.size(), 2u);  // t = time_base + ts us, already ROS time
  EXPECT_EQ(c.all.events[0], (Event{ns(10'000), 1, 2, true}));
  EXPECT_EQ(c.all.events[1], (Event{ns(25'000), 5, 6, false}));
  EXPECT_EQ(caer->report().dropped().at("libcaer: event marked invalid").count, 1u);
}

TEST_F(Ros1BagTest, TimeGoingBackwardsAndShortMessagesAreCounted) {
  const std::string path = dir_ + "/damaged.bag";
  {
    BagWriter bag(path);
    bag.imu("/imu", at_ns(1'000), at_ns(2'000), {1, 0, 0}, {0, 0, 1});
    bag.imu("/imu", at_ns(2'000), at_ns(1'500), {2, 0, 0}, {0, 0, 1});  // header goes back
    bag.imu("/imu", at_ns(3'000), at_ns(0), {3, 0, 0}, {0, 0, 1});      // stamp 1000 s + 0 ns
    bag.imu("/imu", at_ns(4'000), {0, 0}, {4, 0, 0}, {0, 0, 1});        // zero stamp: bag time
    bag.raw("/imu", at_ns(5'000), "sensor_msgs/Imu", test::ros1::generated_md5("sensor_msgs/Imu"),
            std::vector<std::uint8_t>(40, 0));  // a header and nothing more
  }
  auto reader = open_ros1_bag(path);
  const Everything got = read_all(*reader);
  ASSERT_EQ(got.all.imu.size(), 2u);
  EXPECT_EQ(got.all.imu[0].gyro_rad_s.x(), 1.0);
  EXPECT_EQ(got.all.imu[1].gyro_rad_s.x(), 4.0);
  EXPECT_EQ(got.all.imu[1].t, ns(4'000));
  const auto& r = reader->report();
  EXPECT_EQ(r.dropped().at("imu: timestamp went backwards").count, 2u);
  EXPECT_EQ(r.dropped().at("imu: timestamp went backwards").first_where, "/imu message 2");
  EXPECT_EQ(r.dropped().at("imu: message truncated").count, 1u);
  EXPECT_EQ(r.repaired().at("imu: header stamp is zero, bag time used").count, 1u);
}

TEST_F(Ros1BagTest, TruncatedBagIsAnError) {
  const std::string path = dir_ + "/truncated.bag";
  fs::copy_file(bag_, path);
  fs::resize_file(path, fs::file_size(path) * 3 / 4);
  const std::string what = expect_input_error([&] { open_recording(path); });
  EXPECT_NE(what.find("truncated or damaged"), std::string::npos) << what;
}

// An unindexed bag is what `rosbag record` leaves when it is killed: the header's index_pos is
// still 0 and the index records at the end were never written. rosbag's storage library does
// not reindex (the `rosbag reindex` tool does), so the reader stops with that advice rather
// than guessing at a partial bag.
TEST_F(Ros1BagTest, UnindexedBagIsAnErrorNamingReindex) {
  const std::string path = dir_ + "/unindexed.bag";
  fs::copy_file(bag_, path);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto field = bytes.find("index_pos=");
  ASSERT_NE(field, std::string::npos);
  std::uint64_t index_pos = 0;
  std::memcpy(&index_pos, bytes.data() + field + 10, 8);
  ASSERT_GT(index_pos, 0u);
  ASSERT_LT(index_pos, bytes.size());
  std::memset(bytes.data() + field + 10, 0, 8);
  bytes.resize(index_pos);  // the index was never written
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  const std::string what = expect_input_error([&] { open_recording(path); });
  EXPECT_NE(what.find("unindexed"), std::string::npos) << what;
  EXPECT_NE(what.find("rosbag reindex"), std::string::npos) << what;
}

TEST_F(Ros1BagTest, NotABagIsAnError) {
  const std::string path = dir_ + "/not.bag";
  std::ofstream(path) << "#ROSBAG V1.2\nold bag";
  const std::string what = expect_input_error([&] { open_ros1_bag(path); });
  EXPECT_NE(what.find("byte 0"), std::string::npos) << what;
  EXPECT_NE(what.find("1.2"), std::string::npos) << what;
}

// ---------------------------------------------------------------------------------------------
// Damaged bags. Debian's rosbag library trusts every length and offset in the file; the reader
// checks them first (ros1_bag_structure.h). These bags were crashes before that check.

std::string file_string(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_string(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

/// The top-level records of a bag, walked the plain way (format 2.0: uint32 header length,
/// header, uint32 data length, data): position, op and where the data starts.
struct TopRecord {
  std::size_t pos = 0, data = 0;
  int op = 0;
};
std::vector<TopRecord> top_records(const std::string& b) {
  std::vector<TopRecord> out;
  auto u32 = [&](std::size_t p) {
    std::uint32_t v;
    std::memcpy(&v, b.data() + p, 4);
    return v;
  };
  for (std::size_t p = 13; p + 8 <= b.size();) {
    const std::uint32_t header_len = u32(p);
    const std::string header = b.substr(p + 4, header_len);
    const std::size_t op = header.find("op=");
    out.push_back({p, p + 8 + header_len, op == std::string::npos ? -1 : header[op + 3]});
    p += 8 + header_len + u32(p + 4 + header_len);
  }
  return out;
}

bool is_prefix(const std::vector<Event>& part, const std::vector<Event>& whole) {
  return part.size() <= whole.size() && std::equal(part.begin(), part.end(), whole.begin());
}

TEST_F(Ros1BagTest, IndexOffsetOffItsMessageEndsTheReadAtThatChunkAndIsCounted) {
  // The first index data record (just after the first chunk): its first entry's offset moved by
  // one byte, into the middle of a message record. The library would parse a header there.
  std::string b = file_string(bag_);
  const auto records = top_records(b);
  const auto index =
      std::find_if(records.begin(), records.end(), [](const TopRecord& r) { return r.op == 4; });
  ASSERT_NE(index, records.end());
  std::uint32_t offset;
  std::memcpy(&offset, b.data() + index->data + 8, 4);  // entry: time (8 bytes), offset (4)
  ++offset;
  std::memcpy(b.data() + index->data + 8, &offset, 4);
  const std::string path = dir_ + "/bad_offset.bag";
  write_string(path, b);

  auto clean = open_ros1_bag(bag_);
  const Everything whole = read_all(*clean);
  auto reader = open_ros1_bag(path);
  Everything part;
  ASSERT_NO_THROW(part = read_all(*reader));
  EXPECT_LT(part.all.events.size(), whole.all.events.size());
  EXPECT_TRUE(is_prefix(part.all.events, whole.all.events));
  const auto& dropped = reader->report().dropped();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_EQ(dropped.begin()->first,
            "bag damaged, the rest is unreadable: the index places a message where no message data "
            "record of its chunk starts");
  EXPECT_EQ(dropped.begin()->second.first_where.rfind("byte ", 0), 0u)
      << dropped.begin()->second.first_where;
}

TEST_F(Ros1BagTest, DamagedIndexSectionIsAnErrorNamingTheRecord) {
  // The first connection record of the index section: its header length made huge.
  std::string b = file_string(bag_);
  const auto records = top_records(b);
  const auto connection =
      std::find_if(records.begin(), records.end(), [](const TopRecord& r) { return r.op == 7; });
  ASSERT_NE(connection, records.end());
  const std::uint32_t huge = 0xFFFFFF00u;
  std::memcpy(b.data() + connection->pos, &huge, 4);
  const std::string path = dir_ + "/bad_connection.bag";
  write_string(path, b);
  const std::string what = expect_input_error([&] { open_ros1_bag(path); });
  EXPECT_NE(what.find("byte " + std::to_string(connection->pos) +
                      ": connection record: record header length"),
            std::string::npos)
      << what;
  EXPECT_NE(what.find("rosbag reindex"), std::string::npos) << what;
}

/// `bag` with its first chunk's `size` field (its records' size once decompressed) set to
/// `size`, written to `path`; returns the chunk record's byte position.
std::size_t write_with_first_chunk_size(std::string bag, std::uint32_t size, const std::string& path) {
  const auto records = top_records(bag);
  const auto chunk =
      std::find_if(records.begin(), records.end(), [](const TopRecord& r) { return r.op == 5; });
  if (chunk == records.end()) {
    ADD_FAILURE() << "the bag has no chunk record";
    return 0;
  }
  const std::size_t field = bag.find("size=", chunk->pos);
  if (field >= chunk->data) {
    ADD_FAILURE() << "the chunk record's header has no size field";
    return 0;
  }
  std::memcpy(bag.data() + field + 5, &size, 4);
  write_string(path, bag);
  return chunk->pos;
}

TEST_F(Ros1BagTest, ImplausibleChunkSizeIsAnErrorNotAnAllocation) {
  // 4 GiB - 16: the library would allocate that; the reader stops at the chunk record instead.
  const std::string path = dir_ + "/huge_chunk.bag";
  const std::size_t chunk = write_with_first_chunk_size(file_string(bag_), 0xFFFFFFF0u, path);
  const std::string what = expect_input_error([&] { open_ros1_bag(path); });
  EXPECT_NE(what.find("byte " + std::to_string(chunk) + ": chunk record: size 4294967280 is implausible"),
            std::string::npos)
      << what;
}

TEST_F(Ros1BagTest, EmptyRecordHeaderInAChunkEndsTheReadAndIsCounted) {
  // The first record inside the first (uncompressed) chunk with header length 0: it has no `op`
  // field. Reading its zero header bytes once passed a null pointer to memcpy (UBSan, CI fuzz).
  // The read stops there and counts it, as for any damaged chunk.
  std::string b = file_string(bag_);
  const auto records = top_records(b);
  const auto chunk =
      std::find_if(records.begin(), records.end(), [](const TopRecord& r) { return r.op == 5; });
  ASSERT_NE(chunk, records.end());
  const std::uint32_t zero = 0;
  std::memcpy(b.data() + chunk->data, &zero, 4);
  const std::string path = dir_ + "/empty_header.bag";
  write_string(path, b);
  auto reader = open_ros1_bag(path);
  Everything got;
  ASSERT_NO_THROW(got = read_all(*reader));
  const auto& dropped = reader->report().dropped();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_EQ(dropped.begin()->first,
            "bag damaged, the rest is unreadable: record in a chunk: record header is empty (no "
            "`op` field)");
  EXPECT_EQ(dropped.begin()->second.first_where.rfind("byte " + std::to_string(chunk->data), 0),
            0u)
      << dropped.begin()->second.first_where;
}

TEST_F(Ros1BagTest, RandomCorruptionIsAnInputErrorOrAReadableStream) {
  // Bytes changed anywhere, in plain and compressed bags: an InputError naming where, or a read
  // that keeps the stream contract; never another exception or a crash (the sanitizer build
  // runs this too).
  for (auto c : {BagWriter::Compression::kNone, BagWriter::Compression::kLz4,
                 BagWriter::Compression::kBz2}) {
    const std::string src = dir_ + "/source.bag";
    write_reference_bag(src, c);
    const std::string f = file_string(src);
    const std::string path = dir_ + "/fuzz.bag";
    std::mt19937 rng(20261122);
    std::uniform_int_distribution<std::size_t> pos(13, f.size() - 1);
    std::uniform_int_distribution<int> byte(0, 255), count(1, 8);
    for (int trial = 0; trial < 40; ++trial) {
      std::string g = f;
      for (int k = count(rng); k > 0; --k) g[pos(rng)] = static_cast<char>(byte(rng));
      write_string(path, g);
      Everything r;
      try {
        auto reader = open_ros1_bag(path);
        r = read_all(*reader);
      } catch (const InputError& e) {
        EXPECT_FALSE(e.where().empty() && e.reason().empty()) << "trial " << trial;
        continue;
      } catch (const std::exception& e) {
        ADD_FAILURE() << "trial " << trial << ": not an InputError: " << e.what();
        continue;
      }
      EXPECT_TRUE(non_decreasing(r.all.events)) << "trial " << trial;
      EXPECT_TRUE(non_decreasing(r.all.imu)) << "trial " << trial;
      for (const Event& e : r.all.events) {
        ASSERT_LT(e.x, kWidth) << "trial " << trial;
        ASSERT_LT(e.y, kHeight) << "trial " << trial;
      }
    }
  }
}

TEST_F(Ros1BagTest, CompressedChunkSizeAboveTheLimitIsAnErrorNotAnAllocation) {
  // An lz4 chunk whose `size` field says 200 MiB: within what the format allows, but the check
  // (and then the library) would allocate it however small the compressed data. Above
  // kMaxChunkSize (128 MiB): an error at the chunk record.
  const std::string path = dir_ + "/lz4.bag";
  write_reference_bag(path, BagWriter::Compression::kLz4);
  const std::size_t chunk = write_with_first_chunk_size(file_string(path), 200u << 20, path);
  const std::string what = expect_input_error([&] { open_ros1_bag(path); });
  EXPECT_NE(what.find("byte " + std::to_string(chunk) +
                      ": chunk record: size 209715200 is implausible (> 128 MiB)"),
            std::string::npos)
      << what;
}

TEST_F(Ros1BagTest, ConnectionCountAboveTheLimitIsAnError) {
  // rosbag::View is quadratic in the connections it matches (a bag of 40,000 one-message topics,
  // 17 MB, took 11 s in `fdv info`): the bag header's conn_count is bounded (kMaxConnections).
  std::string b = file_string(bag_);
  const std::size_t field = b.find("conn_count=");
  ASSERT_NE(field, std::string::npos);
  const std::uint32_t many = 4097;
  std::memcpy(b.data() + field + 11, &many, 4);
  const std::string path = dir_ + "/many_connections.bag";
  write_string(path, b);
  const std::string what = expect_input_error([&] { open_ros1_bag(path); });
  EXPECT_NE(what.find("byte 13: bag header record: conn_count 4097 is above the reader's limit "
                      "of 4096 connections"),
            std::string::npos)
      << what;
}

TEST_F(Ros1BagTest, TopicAndTypeThatAreNotUtf8AreEscapedInTheSummary) {
  // Connection headers are the bag's text: a topic name with a byte that is not UTF-8 is listed
  // escaped (the summary goes into JSON), and the escaped name selects it.
  const std::string path = dir_ + "/utf8.bag";
  {
    BagWriter bag(path);
    bag.imu("/imu\xFE", at_ns(100), at_ns(100), {0, 0, 1}, {0, 0, 9.81});
    bag.raw("/other", at_ns(200), "pkg/T\xFF", "0123456789abcdef0123456789abcdef", {1, 2, 3});
  }
  auto reader = open_ros1_bag(path);
  nlohmann::json j;
  j["notes"] = reader->info().notes;
  for (const auto& t : reader->info().topics) j["topics"].push_back({t.topic, t.type});
  std::string text;
  ASSERT_NO_THROW(text = j.dump());
  EXPECT_NE(text.find("/imu\\\\xFE"), std::string::npos) << text;
  EXPECT_NE(text.find("pkg/T\\\\xFF"), std::string::npos) << text;
  EXPECT_EQ(read_all(*reader).all.imu.size(), 1u);  // chosen automatically, read by its raw name

  ReaderOptions options;
  options.imu_topic = "/imu\\xFE";
  auto chosen = open_ros1_bag(path, options);
  EXPECT_EQ(read_all(*chosen).all.imu.size(), 1u);
}

std::size_t open_descriptors() {
  return static_cast<std::size_t>(
      std::distance(fs::directory_iterator("/proc/self/fd"), fs::directory_iterator()));
}

TEST_F(Ros1BagTest, BagFromMemoryReadsLikeTheFileAndLeavesNothingBehind) {
  const std::string bytes = file_string(bag_);
  auto from_file = open_ros1_bag(bag_);
  const Everything a = read_all(*from_file);
  const std::size_t descriptors = open_descriptors();
  for (int i = 0; i < 20; ++i) {
    auto reader = open_ros1_bag_bytes(bytes, "memory.bag");
    EXPECT_EQ(reader->info().path, "memory.bag");
    EXPECT_EQ(reader->info().notes, from_file->info().notes);
    const Everything b = read_all(*reader);
    EXPECT_EQ(a.all.events, b.all.events);
    EXPECT_EQ(a.all.imu.size(), b.all.imu.size());
    EXPECT_EQ(a.all.depth.size(), b.all.depth.size());
  }
  EXPECT_EQ(open_descriptors(), descriptors);

  // Errors name the given name, and the memory file is closed after them too.
  std::string damaged = bytes;
  const auto records = top_records(damaged);
  const auto connection =
      std::find_if(records.begin(), records.end(), [](const TopRecord& r) { return r.op == 7; });
  ASSERT_NE(connection, records.end());
  const std::uint32_t huge = 0xFFFFFF00u;
  std::memcpy(damaged.data() + connection->pos, &huge, 4);
  for (const std::string& input : {damaged, std::string("not a bag"), std::string()}) {
    try {
      open_ros1_bag_bytes(input, "memory.bag");
      ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), "memory.bag") << e.what();
    }
  }
  EXPECT_EQ(open_descriptors(), descriptors);
}

// Readers reuse the library's bag objects (constructing one costs about 20 ms): whatever the
// previous reader met (a bag the library refused mid-open, an empty bag, two readers at once), the
// next one reads exactly what a first reader read.
TEST_F(Ros1BagTest, ReadersOneAfterAnotherShareNoState) {
  auto first = open_ros1_bag(bag_);
  const Everything a = read_all(*first);
  const std::vector<TopicInfo> topics = first->info().topics;
  first.reset();

  std::string unindexed = file_string(bag_);  // refused by the library's open, not before it
  const auto field = unindexed.find("index_pos=");
  ASSERT_NE(field, std::string::npos);
  std::memset(unindexed.data() + field + 10, 0, 8);
  EXPECT_NE(expect_input_error([&] { open_ros1_bag_bytes(unindexed, "unindexed.bag"); }).find("unindexed"),
            std::string::npos);
  const std::string empty = dir_ + "/empty.bag";
  { BagWriter bag(empty); }
  EXPECT_TRUE(open_ros1_bag(empty)->info().topics.empty());
  const std::string lz4 = dir_ + "/lz4.bag";
  write_reference_bag(lz4, BagWriter::Compression::kLz4);
  auto both_a = open_ros1_bag(lz4), both_b = open_ros1_bag(bag_);  // two bags in use at once
  EXPECT_EQ(read_all(*both_a).all.events, a.all.events);
  EXPECT_EQ(read_all(*both_b).all.events, a.all.events);
  both_a.reset();
  both_b.reset();

  auto again = open_ros1_bag(bag_);
  const Everything b = read_all(*again);
  ASSERT_EQ(again->info().topics.size(), topics.size());
  for (std::size_t i = 0; i < topics.size(); ++i) {
    EXPECT_EQ(again->info().topics[i].topic, topics[i].topic);
    EXPECT_EQ(again->info().topics[i].count, topics[i].count);
  }
  EXPECT_EQ(b.all.events, a.all.events);
  EXPECT_EQ(b.all.imu.size(), a.all.imu.size());
  EXPECT_EQ(b.all.depth.size(), a.all.depth.size());
  EXPECT_EQ(b.all.odometry.size(), a.all.odometry.size());
  EXPECT_EQ(b.all.ground_truth.size(), a.all.ground_truth.size());
  EXPECT_EQ(b.chunks, a.chunks);
}

}  // namespace
}  // namespace fdv
