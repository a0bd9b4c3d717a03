#include "fdv/sim/dataset_cache.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/simulator.h"

namespace fdv::sim {
namespace fs = std::filesystem;

namespace {
std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The configuration and the simulator's revision: either changed = another dataset. The vehicle
/// model's response is left out: it acts on commands only, and a cached dataset has none (a run
/// without commands renders the path: SimFlight.ACommandedRunWithoutCommandsRendersExactlyAsThePathRun).
std::string fingerprint(const ScenarioConfig& config) {
  ScenarioConfig uncommanded = config;
  uncommanded.vehicle.response = VehicleResponseConfig{};
  return fmt::format("# fdv simulator revision {}\n{}", kSimulatorRevision, to_yaml(uncommanded));
}

}  // namespace

bool is_simulated(const ScenarioConfig& config, const std::string& dir) {
  const fs::path marker = fs::path(dir) / kSimulationMarker;
  return fs::exists(marker) && read_text(marker) == fingerprint(config);
}

// The marker last, via a rename, so that a folder with a marker is always complete.
void mark_simulated(const ScenarioConfig& config, const std::string& dir) {
  const fs::path marker = fs::path(dir) / kSimulationMarker;
  const fs::path tmp = marker.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << fingerprint(config);
    if (!out) throw InputError(tmp.string(), "", "cannot write the cache marker");
  }
  fs::rename(tmp, marker);
}

std::string ensure_simulated(const ScenarioConfig& config, const std::string& dir) {
  if (is_simulated(config, dir)) {
    spdlog::debug("reusing the simulated dataset {}", dir);
    return dir;
  }
  if (fs::exists(dir))
    spdlog::info(
        "{}: incomplete, or made with another configuration or simulator revision: simulating "
        "again",
        dir);
  fs::remove_all(dir);
  {
    Simulator simulator(config);
    DatasetSink sink(dir, simulator.calibration());
    spdlog::info("simulating '{}' (seed {}) into {}", config.name, config.seed, dir);
    simulator.run(sink);
    sink.finish(simulator.manifest_yaml());
  }
  mark_simulated(config, dir);
  return dir;
}

std::string ensure_simulated(const std::string& preset, std::uint64_t seed,
                             const std::string& cache_dir) {
  const ScenarioConfig config = make_preset(preset, seed);
  return ensure_simulated(config,
                          (fs::path(cache_dir) / fmt::format("{}_seed{}", preset, seed)).string());
}

}  // namespace fdv::sim
