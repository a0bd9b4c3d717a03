// The simulator's scenario YAML in memory, applied over a preset as `fdv simulate --config`
// applies it, then checked as the simulator checks it before it runs.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fdv/sim/scenario_config.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const fdv::sim::ScenarioConfig preset = fdv::sim::make_preset("fast_forward", 1);
  fdv::fuzz::expect_contract([&] {
    fdv::sim::ScenarioConfig config = preset;
    fdv::sim::apply_scenario_yaml_text(config, std::string_view(reinterpret_cast<const char*>(data), size),
                                       fdv::fuzz::kInputName);
    (void)config.find_problem();
    (void)config.validate();
  });
  return 0;
}
