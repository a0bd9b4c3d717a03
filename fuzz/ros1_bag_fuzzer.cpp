// A ROS 1 bag given as its bytes, read to its end as `fdv info` reads it (through an anonymous
// memory file: Debian's rosbag storage library opens bags by path only).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fdv/io/rosbag/ros1_plugin_api.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fdv::fuzz::expect_contract([&] {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    fdv::fuzz::drain(*fdv::ros1::open_reader_bytes(bytes, fdv::fuzz::kInputName, {}));
  });
  return 0;
}
