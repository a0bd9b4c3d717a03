// Simulator speed: simulated seconds per wall-clock second for the `fast_forward` preset (one
// full default scene: 1 s with the ball crossing the view), event camera at 640x480 and at
// 346x260, depth camera, IMU, odometry and truth included, all cores, output kept in memory
// (counted, not stored); and `random_throw` throws as `fdv dodge-eval` simulates them (one
// thread, whole throw) at two sampling steps (`max_motion_px` 0.5, the default, and 1.0), in one
// run. Run: build/bench/sim_bench [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <chrono>

#include "fdv/sim/simulator.h"

namespace {

class CountingSink : public fdv::sim::SimulationSink {
 public:
  void on_events(std::span<const fdv::Event> events, std::span<const std::int16_t>) override {
    count += events.size();
  }
  std::uint64_t count = 0;
};

void simulate(benchmark::State& state, const fdv::sim::ScenarioConfig& config) {
  double simulated = 0, wall = 0;
  fdv::sim::SimulationSummary summary;
  for (auto _ : state) {
    fdv::sim::Simulator sim(config);
    CountingSink sink;
    const auto t0 = std::chrono::steady_clock::now();
    summary = sim.run(sink);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(seconds);
    simulated += summary.simulated_s;
    wall += seconds;
    benchmark::DoNotOptimize(sink.count);
  }
  state.counters["sim_s_per_wall_s"] = simulated / wall;
  state.counters["events"] = static_cast<double>(summary.events);
  state.counters["event_rate_Mev_s"] =
      static_cast<double>(summary.events) / summary.simulated_s * 1e-6;
  state.counters["pixel_sample_rate_hz"] = summary.mean_sample_rate_hz;
}

void BM_SimulateFastForward(benchmark::State& state) {
  fdv::sim::ScenarioConfig config = fdv::sim::make_preset("fast_forward", 1);
  fdv::sim::set_event_resolution(config, static_cast<int>(state.range(0)),
                                 static_cast<int>(state.range(1)));
  config.threads = 0;  // all cores
  simulate(state, config);
}

/// Args: seed (1: 640x480 forward flight, 4: 1280x720 hover, 6: 346x260 hover), max_motion_px × 10.
void BM_SimulateRandomThrow(benchmark::State& state) {
  fdv::sim::ScenarioConfig config =
      fdv::sim::make_preset("random_throw", static_cast<std::uint64_t>(state.range(0)));
  config.event_camera.max_motion_px = static_cast<double>(state.range(1)) / 10.0;
  config.threads = 1;  // dodge-eval runs one throw per core
  simulate(state, config);
}
BENCHMARK(BM_SimulateRandomThrow)
    ->ArgsProduct({{1, 4, 6}, {5, 10}})
    ->UseManualTime()
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

BENCHMARK(BM_SimulateFastForward)
    ->Args({640, 480})
    ->Args({346, 260})
    ->UseManualTime()
    ->Unit(benchmark::kSecond)
    ->Iterations(2);

}  // namespace

BENCHMARK_MAIN();
