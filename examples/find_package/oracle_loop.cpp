// The two oracles of `fdv dodge-eval` (docs/AVOIDANCE.md) flown through the simulator's vehicle
// model, next to their kinematic open loop, under one or more pipeline configurations. The oracles
// plan on the true ball and the flown vehicle state, so their closed loop needs no rendering: a
// throw costs its open-loop simulation and runs, not the minutes of `dodge-eval --closed-loop`.
// A use of fdv::tables from a program of one's own (built, not run, by downstream_package_test):
//
//   oracle_loop SEEDS_FILE WORK_DIR CONFIG [CONFIG ...]    (CONFIG: a YAML file, or - for defaults)
//
// SEEDS_FILE lists random_throw seeds (whitespace-separated); each throw is simulated into
// WORK_DIR/SEED, scored under every CONFIG, and removed. One line per throw and configuration, then
// the totals: threats, and the threats escaped open loop and closed loop by each oracle. A token of
// SEEDS_FILE that is not a non-negative integer stops it with the file, the position and the token.
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "fdv/eval/dataset_truth.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/sim/dataset_cache.h"
#include "fdv/sim/random_throw.h"
#include "fdv/tables/closed_loop.h"
#include "fdv/tables/dodge_eval.h"

namespace {

constexpr const char* kOracles[2] = {"oracle", "oracle_visible"};

struct Tally {
  int threats = 0;
  int open_loop[2] = {0, 0}, closed_loop[2] = {0, 0};
};

std::optional<fdv::TimeNs> to_ns(std::optional<double> s) {
  return s ? std::optional(fdv::from_seconds(*s)) : std::nullopt;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s SEEDS_FILE WORK_DIR CONFIG [CONFIG ...]  (CONFIG: YAML file or -)\n", argv[0]);
    return 2;
  }
  std::ifstream seeds_file(argv[1]);
  if (!seeds_file) throw std::runtime_error(std::string("cannot read ") + argv[1]);
  const std::string work_dir = argv[2];
  std::vector<fdv::PerceptionOptions> configs;
  for (int a = 3; a < argc; ++a)
    configs.push_back(std::string(argv[a]) == "-" ? fdv::PerceptionOptions{} : fdv::load_perception_options_file(argv[a]));
  std::vector<std::uint64_t> seeds;
  for (std::string token; seeds_file >> token;) {
    std::size_t used = 0;
    std::uint64_t seed = 0;
    try {
      seed = std::stoull(token, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != token.size() || token[0] == '-')  // stoull takes "-3" as 2^64 - 3
      throw std::runtime_error(std::string(argv[1]) + ": seed " + std::to_string(seeds.size() + 1) + " \"" + token +
                               "\" is not a non-negative integer");
    seeds.push_back(seed);
  }
  std::vector<Tally> tally(configs.size());
  for (const std::uint64_t seed : seeds) {
    fdv::sim::ScenarioConfig scenario = fdv::sim::random_throw_config(fdv::sim::sample_random_throw(seed));
    scenario.threads = 1;  // as dodge-eval simulates it
    const std::string dataset = work_dir + "/" + std::to_string(seed);
    fdv::sim::ensure_simulated(scenario, dataset);
    const fdv::DatasetTruth truth = fdv::load_dataset_truth(dataset);
    const int ball = truth.radius_m.begin()->first;
    for (std::size_t c = 0; c < configs.size(); ++c) {
      fdv::DodgeEvalOptions options;
      options.perception = configs[c];
      const double radius = options.perception.prediction.safety_radius_m;
      fdv::DodgeThrow row = fdv::score_dodge_dataset(dataset, options);
      // oracle starts at ours' first detection, oracle_visible when the ball is first in view.
      const std::optional<fdv::TimeNs> starts[2] = {to_ns(row.first_detection_t_s), to_ns(row.first_in_view_t_s)};
      std::printf("seed %llu config %zu threat %d", static_cast<unsigned long long>(seed), c, row.threat ? 1 : 0);
      for (int m = 0; m < 2; ++m) {
        const fdv::ClosedLoopFlight flown =
            fdv::fly_oracle(scenario, truth, ball, row.window_ends, starts[m], options.perception);
        const fdv::DodgeOutcome closed = fdv::dodge_outcome(flown.truth, ball, flown.decisions, radius, false);
        const fdv::DodgeOutcome& open = row.outcomes[kOracles[m]];
        const bool closed_escaped = row.threat && closed.miss_with_maneuver_m >= radius;
        if (row.threat) tally[c].open_loop[m] += open.escaped, tally[c].closed_loop[m] += closed_escaped;
        std::printf(" | %s miss open %.3f m%s, closed %.3f m%s", kOracles[m], open.miss_with_maneuver_m,
                    open.escaped ? " (escaped)" : "", closed.miss_with_maneuver_m, closed_escaped ? " (escaped)" : "");
      }
      tally[c].threats += row.threat;
      std::printf("\n");
      std::fflush(stdout);
    }
    std::filesystem::remove_all(dataset);
  }
  for (std::size_t c = 0; c < configs.size(); ++c)
    std::printf("config %zu: %d threats; oracle escaped %d open loop, %d closed loop; oracle_visible %d, %d\n", c,
                tally[c].threats, tally[c].open_loop[0], tally[c].closed_loop[0], tally[c].open_loop[1],
                tally[c].closed_loop[1]);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "oracle_loop: %s\n", e.what());
  return 1;
}
