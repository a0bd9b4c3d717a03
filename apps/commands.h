#pragma once
// Each `fdv` sub-command registers its options on the CLI11 app and runs when selected.
#include <CLI/CLI.hpp>

namespace fdv::cli {

void add_info_command(CLI::App& app);
// [command slot: simulate]
// [command slot: run]
// [command slot: eval]
// [command slot: bench]

}  // namespace fdv::cli
