// An AEDAT 4.0 file in memory, read to its end as `fdv info` reads it.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <sstream>

#include "fdv/io/aedat4/aedat4_reader.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fdv::fuzz::expect_contract([&] {
    auto in = std::make_unique<std::istringstream>(std::string(reinterpret_cast<const char*>(data), size));
    fdv::fuzz::drain(*fdv::open_aedat4(std::move(in), fdv::fuzz::kInputName));
  });
  return 0;
}
