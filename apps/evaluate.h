#pragma once
// Shared by the CLI's run, eval and demo commands. The reusable experiment code (replay, dataset
// truth, metrics, the dataset cache, the paper's tables) lives in the library, src/fdv/eval.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "fdv/io/recording.h"

namespace fdv::cli {

/// `fdv run`'s arguments.
struct RunArgs {
  std::string input, calib, config, method, out;
  bool visualize = false;
  bool assume_static = false;
  std::optional<int> threads;  ///< overrides the options' threads
  bool print_config = false;   ///< print the effective options as YAML and exit
  ReaderOptions reader;
};
/// `fdv run`: the pipeline over a recording, results into args.out (README, docs/OUTPUTS.md).
void run_recording(const RunArgs& args);
/// `fdv eval`: scores results against a simulated dataset; writes and returns metrics.json.
nlohmann::json evaluate(const std::string& results_dir, const std::string& dataset_dir);

}  // namespace fdv::cli
