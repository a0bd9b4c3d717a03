#pragma once
/// A cache of simulated datasets: a dataset folder is simulated once and reused while its
/// configuration and the simulator's revision stay the same.
///
///   const std::string dir = sim::ensure_simulated("scene2_ball", 101, "out/cache");
#include <cstdint>
#include <string>

#include "fdv/sim/scenario_config.h"

namespace fdv::sim {

/// The dataset folder of simulator preset `preset` at `seed` under `cache_dir`
/// (CACHE/PRESET_seedSEED), simulated (make_preset + DatasetSink, as `fdv simulate`)
/// only when the folder is missing or incomplete. Complete = the marker file kSimulationMarker,
/// written last, holds the preset's full configuration as it is now and kSimulatorRevision; a
/// folder from an interrupted run, a since-changed preset or another simulator revision is
/// simulated again. Not safe against two processes filling the same folder at once. Throws ConfigError for an unknown preset.
std::string ensure_simulated(const std::string& preset, std::uint64_t seed,
                             const std::string& cache_dir);
/// The same for any configuration, into `dir`.
std::string ensure_simulated(const ScenarioConfig& config, const std::string& dir);
/// Whether `dir` holds a complete simulation of `config` at this simulator revision (its marker).
bool is_simulated(const ScenarioConfig& config, const std::string& dir);
/// Marks `dir`, just written whole by a DatasetSink from `config`'s simulation without commands, as
/// complete, for ensure_simulated to reuse. Throws InputError when the marker cannot be written.
void mark_simulated(const ScenarioConfig& config, const std::string& dir);
inline constexpr const char* kSimulationMarker = "simulation_complete.yaml";

}  // namespace fdv::sim
