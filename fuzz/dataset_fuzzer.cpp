// One file of the project's dataset folder (`fdv simulate` output) in memory. Byte 0 picks the
// file: dataset.yaml, events.bin (of a 64x48 sensor, as the seeds), imu.csv, odometry.csv,
// truth/objects.csv, depth.csv, or a depth frame file (PNG or Zstandard) with the seeds' 64x48
// depth camera or without a calibration; the rest is its content.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <string_view>

#include "fdv/io/dataset/dataset_reader.h"
#include "fuzz/fuzz_support.h"

namespace {
/// The sensor of the seeds' simulated dataset (fuzz/make_seeds.py).
constexpr int kSeedWidth = 64, kSeedHeight = 48;
/// Its depth camera (the size matters: a Zstandard frame has no header of its own).
const fdv::PinholeCamera kSeedDepthCamera{64, 48, 38.57, 38.57, 32, 24, {}};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  using namespace fdv;
  const std::string folder = std::string(fuzz::kInputName) + "/";
  const char* text = reinterpret_cast<const char*>(data) + 1;
  const std::size_t length = size - 1;
  const auto stream = [&] { return std::make_unique<std::istringstream>(std::string(text, length)); };
  fuzz::expect_contract([&] {
    ReadReport report;
    switch (data[0] % 8) {
      case 0: (void)parse_dataset_manifest(std::string_view(text, length), folder + "dataset.yaml"); break;
      case 1: (void)read_dataset_events(stream(), folder + "events.bin", kSeedWidth, kSeedHeight, report); break;
      case 2: (void)read_dataset_imu(stream(), folder + "imu.csv", report); break;
      case 3: (void)read_dataset_poses(stream(), folder + "odometry.csv", report); break;
      case 4: (void)read_dataset_objects(stream(), folder + "truth/objects.csv", report); break;
      case 5: (void)read_dataset_depth_index(stream(), folder + "depth.csv", report); break;
      default:
        (void)decode_dataset_depth(std::span<const std::uint8_t>(data + 1, length), 0,
                                   data[0] % 8 == 6 ? std::optional(kSeedDepthCamera) : std::nullopt,
                                   folder + "depth/000000.png", report);
        break;
    }
    (void)report.to_json().dump();
  });
  return 0;
}
