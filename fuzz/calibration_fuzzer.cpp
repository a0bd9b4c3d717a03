// A calibration file in memory, in either layout (the project's YAML, or OpenCV's FileStorage
// XML / YAML), as `fdv run --calib` loads it.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fdv/core/calibration.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fdv::fuzz::expect_contract([&] {
    (void)fdv::load_calibration_text(std::string_view(reinterpret_cast<const char*>(data), size),
                                     fdv::fuzz::kInputName);
  });
  return 0;
}
