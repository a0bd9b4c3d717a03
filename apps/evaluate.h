#pragma once
// `fdv eval`'s scoring, which `fdv demo` prints from too.
#include <nlohmann/json.hpp>
#include <string>

namespace fdv::cli {

/// Scores a results folder against a simulated dataset; writes and returns metrics.json
/// (docs/RESULTS.md, "Detection metrics").
nlohmann::json evaluate(const std::string& results_dir, const std::string& dataset_dir);

}  // namespace fdv::cli
