// One file of an RPG text dataset folder in memory. Byte 0 picks the file (events.txt, imu.txt,
// groundtruth.txt, calib.txt); the rest is its text.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <sstream>
#include <string>

#include "fdv/io/rpg/rpg_text_reader.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  using namespace fdv;
  const std::string name = std::string(fuzz::kInputName) + "/";
  fuzz::expect_contract([&] {
    auto in = std::make_unique<std::istringstream>(std::string(reinterpret_cast<const char*>(data) + 1, size - 1));
    ReadReport report;
    switch (data[0] % 4) {
      case 0: (void)read_rpg_events(std::move(in), name + "events.txt", report); break;
      case 1: (void)read_rpg_imu(std::move(in), name + "imu.txt", report); break;
      case 2: (void)read_rpg_groundtruth(std::move(in), name + "groundtruth.txt", report); break;
      default: (void)read_rpg_calib(std::move(in), name + "calib.txt"); break;
    }
    (void)report.to_json().dump();
  });
  return 0;
}
