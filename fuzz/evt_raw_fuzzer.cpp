// A Prophesee RAW file (EVT 2.0 or 3.0, by its header) in memory, read to its end as `fdv info`
// reads it.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <sstream>

#include "fdv/io/prophesee/prophesee_raw_reader.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fdv::fuzz::expect_contract([&] {
    auto in = std::make_unique<std::istringstream>(std::string(reinterpret_cast<const char*>(data), size));
    fdv::fuzz::drain(*fdv::open_prophesee_raw(std::move(in), fdv::fuzz::kInputName));
  });
  return 0;
}
