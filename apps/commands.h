#pragma once
// Each `fdv` sub-command registers its options on the CLI11 app and runs when selected.
#include <CLI/CLI.hpp>
#include <stdexcept>
#include <string>

namespace fdv::cli {

/// A command stopped by SIGINT or SIGTERM; main exits with 128 + signal, as a shell reports it.
struct Interrupted : std::runtime_error {
  explicit Interrupted(int signal_number)
      : std::runtime_error("interrupted by signal " + std::to_string(signal_number)), signal(signal_number) {}
  int signal;
};

void add_info_command(CLI::App& app);
void add_simulate_command(CLI::App& app);
void add_run_command(CLI::App& app);
void add_eval_command(CLI::App& app);
void add_demo_command(CLI::App& app);
void add_table_commands(CLI::App& app);  ///< table1, table2
void add_dodge_eval_command(CLI::App& app);
void add_convert_command(CLI::App& app);  ///< alias export; --to ros1-bag needs FDV_ROS1

}  // namespace fdv::cli
