// A ROS 2 bag (.db3, SQLite) given as its bytes, read to its end as `fdv info` reads it; SQLite
// reads the image in place.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fdv/io/rosbag/rosbag_reader.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fdv::fuzz::expect_contract([&] {
    std::string bytes(reinterpret_cast<const char*>(data), size);
    fdv::fuzz::drain(*fdv::open_ros2_bag_bytes(std::move(bytes), fdv::fuzz::kInputName));
  });
  return 0;
}
