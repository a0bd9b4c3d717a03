// The pipeline's options YAML in memory, as `fdv run --config` loads it.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fdv/pipeline/options_yaml.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fdv::fuzz::expect_contract([&] {
    (void)fdv::load_perception_options_text(std::string_view(reinterpret_cast<const char*>(data), size),
                                            fdv::fuzz::kInputName);
  });
  return 0;
}
