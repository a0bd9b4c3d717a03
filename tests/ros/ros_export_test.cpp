// `fdv export DATASET --to ros1-bag OUT.bag` as a user runs it: a small simulated dataset written
// as a bag both ways (dvs_msgs/EventArray; event_camera_msgs/EventPacket mono and libcaer), read
// back by fdv's own reader and compared with the dataset read directly, record by record; the
// bag also read by ROS's Python rosbag (an independent reader).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "fdv/io/recording.h"
#include "ros/bridge/ros1_bag_export.h"
#include "test_support.h"

namespace fdv {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

using Ran = test::CommandRun;

Ran fdv(const std::string& args, const std::string& name) {
  return test::run_command(std::string(FDV_BINARY) + " " + args, "ros_export_" + name);
}

SensorChunk read_all(const std::string& path) {
  auto reader = open_recording(path);
  SensorChunk all, chunk;
  while (reader->read(chunk)) {
    auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
    append(all.events, chunk.events);
    append(all.imu, chunk.imu);
    append(all.depth, chunk.depth);
    append(all.odometry, chunk.odometry);
  }
  EXPECT_EQ(reader->report().total_dropped(), 0u) << path;
  return all;
}

class RosExport : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = test::scratch_dir("ros_export");
    dataset_ = dir_ + "/dataset";
    // fast_forward at 64x48 for 0.1 s: events, IMU at 1 kHz, depth, odometry; under a second.
    const Ran sim = fdv("simulate --scenario fast_forward --seed 3 --resolution 64x48 --duration 0.1 "
                        "--threads 1 --out " + dataset_, "simulate");
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
    expected_ = read_all(dataset_);
  }

  /// Exports with `flags`, checks the summary and returns the bag read back.
  SensorChunk export_and_read(const std::string& flags, const std::string& name, json& summary) {
    const std::string bag = dir_ + "/" + name + ".bag";
    const Ran r = fdv("export " + dataset_ + " --to ros1-bag " + bag + " " + flags, name);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    summary = json::parse(r.out);
    return read_all(bag);
  }

  /// IMU, depth and odometry of `got` against the dataset's, times moved by `offset`.
  void expect_sensors_equal(const SensorChunk& got, TimeNs offset) {
    ASSERT_EQ(got.imu.size(), expected_.imu.size());
    for (std::size_t i = 0; i < got.imu.size(); ++i) {
      EXPECT_EQ(got.imu[i].t, expected_.imu[i].t + offset);
      EXPECT_EQ(got.imu[i].gyro_rad_s, expected_.imu[i].gyro_rad_s);
      EXPECT_EQ(got.imu[i].accel_m_s2, expected_.imu[i].accel_m_s2);
    }
    // The dataset's depth PNGs hold whole millimetres: 16UC1 carries them exactly.
    ASSERT_EQ(got.depth.size(), expected_.depth.size());
    for (std::size_t i = 0; i < got.depth.size(); ++i) {
      EXPECT_EQ(got.depth[i].t, expected_.depth[i].t + offset);
      EXPECT_EQ(got.depth[i].width, expected_.depth[i].width);
      EXPECT_EQ(got.depth[i].height, expected_.depth[i].height);
      EXPECT_TRUE(got.depth[i].depth_m == expected_.depth[i].depth_m) << "frame " << i;
    }
    // Position and angular velocity exact; the quaternion is renormalised by the reader and the
    // velocity goes through the body frame (v_B = q^-1 v_W, then v_W = q v_B): a few ulp.
    ASSERT_EQ(got.odometry.size(), expected_.odometry.size());
    for (std::size_t i = 0; i < got.odometry.size(); ++i) {
      const auto& g = got.odometry[i];
      const auto& e = expected_.odometry[i];
      EXPECT_EQ(g.t, e.t + offset);
      EXPECT_EQ(g.p_W_B, e.p_W_B);
      EXPECT_NEAR((g.q_W_B.coeffs() - e.q_W_B.coeffs()).norm(), 0, 1e-15);
      EXPECT_NEAR((g.v_W - e.v_W).norm(), 0, 1e-12);
      EXPECT_EQ(g.omega_B, e.omega_B);
    }
  }

  static std::string dir_, dataset_;
  static SensorChunk expected_;
};
std::string RosExport::dir_, RosExport::dataset_;
SensorChunk RosExport::expected_;

std::uint64_t messages(const json& summary, const std::string& topic) {
  for (const auto& t : summary.at("topics"))
    if (t.at("topic") == topic) return t.at("messages").get<std::uint64_t>();
  return 0;
}

TEST_F(RosExport, EventArrayBagReadsBackAsTheDataset) {
  ASSERT_FALSE(expected_.events.empty());
  ASSERT_FALSE(expected_.depth.empty());
  ASSERT_FALSE(expected_.odometry.empty());
  // The simulated clock starts at 0, which a ROS bag cannot hold: everything moves by 1 s.
  ASSERT_EQ(expected_.imu.front().t, 0);
  json summary;
  const SensorChunk got = export_and_read("", "event_array", summary);
  const TimeNs offset = kNsPerS;
  EXPECT_EQ(summary.at("time_offset_ns").get<TimeNs>(), offset);
  ASSERT_EQ(got.events.size(), expected_.events.size());
  for (std::size_t i = 0; i < got.events.size(); ++i) {
    Event e = expected_.events[i];
    e.t += offset;
    ASSERT_EQ(got.events[i], e) << "event " << i;
  }
  expect_sensors_equal(got, offset);
  EXPECT_EQ(summary.at("depth_encodings").at("16UC1"), expected_.depth.size());
  // A message starts at an event and takes the events of the next 1 ms (empty spans: none).
  std::uint64_t event_messages = 0;
  TimeNs start = 0;
  for (const Event& e : expected_.events)
    if (event_messages == 0 || e.t - start >= 1'000'000) {
      ++event_messages;
      start = e.t;
    }
  EXPECT_EQ(messages(summary, "/dvs/events"), event_messages);
  EXPECT_EQ(messages(summary, "/mavros/imu/data"), expected_.imu.size());
  EXPECT_EQ(messages(summary, "/camera/depth/image_rect_raw"), expected_.depth.size());
  EXPECT_EQ(messages(summary, "/mavros/local_position/odom"), expected_.odometry.size());
}

TEST_F(RosExport, EventPacketMonoIsExactAndLibcaerIsFlooredToTheMicrosecond) {
  json summary;
  const SensorChunk mono =
      export_and_read("--events-as event_packet --encoding mono --event-message-ms 2", "mono",
                      summary);
  const TimeNs offset = kNsPerS;
  ASSERT_EQ(mono.events.size(), expected_.events.size());
  for (std::size_t i = 0; i < mono.events.size(); ++i) {
    Event e = expected_.events[i];
    e.t += offset;
    ASSERT_EQ(mono.events[i], e) << "event " << i;
  }
  expect_sensors_equal(mono, offset);

  // The simulator's times are whole microseconds, so libcaer's floor changes none of them here
  // (BagExporter.LibcaerFloorsToTheMicrosecond checks one that it does change).
  const SensorChunk caer =
      export_and_read("--events-as event_packet --encoding libcaer", "libcaer", summary);
  ASSERT_EQ(caer.events.size(), expected_.events.size());
  for (std::size_t i = 0; i < caer.events.size(); ++i) {
    Event e = expected_.events[i];
    e.t = (e.t + offset) / 1000 * 1000;
    ASSERT_EQ(caer.events[i], e) << "event " << i;
  }
}

TEST(BagExporter, LibcaerFloorsToTheMicrosecondAndMonoKeepsTheNanoseconds) {
  const std::string dir = test::scratch_dir("bag_exporter");
  const std::vector<ros1::EventRecord> events = {
      {5'000'000'123, 1, 2, true}, {5'000'000'999, 3, 4, false}, {5'000'002'500, 5, 6, true}};
  for (const std::string encoding : {"mono", "libcaer"}) {
    ros1::BagExportOptions o;
    o.events_as = "event_packet";
    o.packet_encoding = encoding;
    o.width = 64;
    o.height = 48;
    o.event_message_ns = 2'000;  // two packets: {123, 999}, {2500}
    {
      ros1::BagExporter bag(dir + "/" + encoding + ".bag", o);
      bag.add_events(events.data(), events.size());
      bag.close();
      ASSERT_EQ(bag.topics().size(), 1u);
      EXPECT_EQ(bag.topics()[0].messages, 2u);
    }
    const SensorChunk got = read_all(dir + "/" + encoding + ".bag");
    ASSERT_EQ(got.events.size(), 3u) << encoding;
    const bool floored = encoding == "libcaer";
    EXPECT_EQ(got.events[0], (Event{floored ? 5'000'000'000 : 5'000'000'123, 1, 2, true}));
    EXPECT_EQ(got.events[1], (Event{floored ? 5'000'000'000 : 5'000'000'999, 3, 4, false}));
    EXPECT_EQ(got.events[2], (Event{floored ? 5'000'002'000 : 5'000'002'500, 5, 6, true}));
  }
}

TEST_F(RosExport, PythonRosbagReadsTheBag) {
  json summary;
  export_and_read("--events-as event_packet", "python", summary);
  const Ran r = test::run_command("/usr/bin/python3 -c \"import rosbag, sys; "
                    "i = rosbag.Bag(sys.argv[1]).get_type_and_topic_info(); "
                    "[print(t, v.msg_type, v.message_count) for t, v in sorted(i.topics.items())]; "
                    "[print(t, m) for t, m in sorted(i.msg_types.items())]\" " +
                        dir_ + "/python.bag",
                    "ros_export_python_rosbag");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ostringstream want;
  want << "/camera/depth/image_rect_raw sensor_msgs/Image " << expected_.depth.size() << "\n"
       << "/dvs/events event_camera_msgs/EventPacket " << messages(summary, "/dvs/events") << "\n"
       << "/mavros/imu/data sensor_msgs/Imu " << expected_.imu.size() << "\n"
       << "/mavros/local_position/odom nav_msgs/Odometry " << expected_.odometry.size() << "\n"
       << "event_camera_msgs/EventPacket 8a6101b351a64529ac77bd8b71074e52\n"
       << "nav_msgs/Odometry cd5e73d190d741a2f92e81eda573aca7\n"
       << "sensor_msgs/Image 060021388200f6f0f447d0fcd9c64743\n"
       << "sensor_msgs/Imu 6a62c6daae103f4ff57a132d6f95cec2\n";
  EXPECT_EQ(r.out, want.str());

  // Its events decoded by Python rosbag from the bag's own message definitions (genpy).
  export_and_read("", "python_array", summary);
  const Ran events = test::run_command("/usr/bin/python3 -c \"import rosbag, sys; "
                         "e = [e for _, m, _ in rosbag.Bag(sys.argv[1]).read_messages('/dvs/events') "
                         "for e in m.events]; "
                         "print(len(e), sum(v.x for v in e), sum(v.y for v in e), "
                         "sum(v.polarity for v in e), sum(v.ts.to_nsec() for v in e))\" " +
                             dir_ + "/python_array.bag",
                         "ros_export_python_events");
  ASSERT_EQ(events.exit_code, 0) << events.err;
  std::uint64_t x = 0, y = 0, on = 0;
  TimeNs t = 0;
  for (const Event& e : expected_.events) {
    x += e.x;
    y += e.y;
    on += e.polarity;
    t += e.t + kNsPerS;
  }
  EXPECT_EQ(events.out, fmt::format("{} {} {} {} {}\n", expected_.events.size(), x, y, on, t));
}

TEST_F(RosExport, BadOptionsAreClearErrors) {
  const std::string bag = dir_ + "/bad.bag";
  Ran r = fdv("export " + dataset_ + " --to ros1-bag " + bag + " --time-offset-ns 0", "zero");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("outside ROS 1 time"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--time-offset-ns"), std::string::npos) << r.err;
  r = fdv("export " + dataset_ + " --to ros1-bag " + bag + " --event-message-ms 5000", "span");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--event-message-ms"), std::string::npos) << r.err;
  r = fdv("export " + dataset_ + " --to ros2-bag " + bag, "format");
  EXPECT_NE(r.exit_code, 0);
}

}  // namespace
}  // namespace fdv
