// Writes the seed corpus of fuzz_ros1_bag: small ROS 1 bags made by ROS's own library (the tests'
// writer), one per chunk compression, with every message type the reader decodes.
//   fuzz_ros1_seed_writer OUT_DIR
#include <cstdio>
#include <string>
#include <vector>

#include "io/rosbag/ros1_bag_writer.h"

namespace {

using namespace fdv::test::ros1;

void write_bag(const std::string& path, BagWriter::Compression compression) {
  BagWriter bag(path, compression);
  const auto at = [](std::uint32_t ms) { return Stamp{1, ms * 1'000'000}; };
  std::vector<RawEvent> events;
  for (std::uint16_t i = 0; i < 24; ++i)
    events.push_back({static_cast<std::uint16_t>(i * 3), static_cast<std::uint16_t>(i * 2), at(i), i % 2 == 0});
  bag.event_array("/dvs/events", at(1), at(0), 346, 260, events);
  bag.imu("/dvs/imu", at(2), at(2), {0.1, 0.2, 0.3}, {0.0, 0.0, 9.81});
  bag.image("/camera/depth/image_rect_raw", at(3), at(3), 2, 2, "16UC1", 4, {0xE8, 0x03, 0, 0, 0xD0, 0x07, 0xFF, 0xFF});
  bag.odometry("/odom", at(4), at(4), Pose{{1, 2, 3}, {0, 0, 0, 1}}, {0.5, 0, 0}, {0, 0, 0.1});
  bag.pose_stamped("/vicon/ball", at(5), at(5), Pose{{4, 5, 6}, {0, 0, 0, 1}});
  bag.transform_stamped("/tf_ball", at(6), at(6), Pose{{7, 8, 9}, {0, 0, 0, 1}});
  bag.event_array("/dvs/events", at(7), at(6), 346, 260, events);
  bag.close();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  write_bag(dir + "/plain.bag", BagWriter::Compression::kNone);
  write_bag(dir + "/lz4.bag", BagWriter::Compression::kLz4);
  write_bag(dir + "/bz2.bag", BagWriter::Compression::kBz2);
  return 0;
}
