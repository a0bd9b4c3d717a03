// AEDAT 4.0 decode throughput on the real DAVIS346 recording davis346_ball_throw_person.aedat4
// (LZ4, 237,073 events, 740 IMU samples, 19 frame and 75 trigger packets skipped), in events/s:
// the whole RecordingReader path (file reads, LZ4 frame decode, FlatBuffers verification,
// µs -> ns conversion, EventSanitizer, chunks), with the file in the page cache after the first
// iteration. Argument: ReaderOptions::chunk_events.
// Run: build-*/bench/aedat4_decode_bench [--benchmark_repetitions=5]
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>

#include "fdv/io/aedat4/aedat4_reader.h"

namespace {

void BM_Aedat4Reader(benchmark::State& state) {
  const std::string path = std::string(FDV_REAL_DATA_DIR) + "/davis346_ball_throw_person.aedat4";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("real recording not found");
    return;
  }
  fdv::ReaderOptions options;
  options.chunk_events = static_cast<std::size_t>(state.range(0));
  std::size_t events = 0, imu = 0;
  fdv::SensorChunk chunk;
  for (auto _ : state) {
    auto reader = fdv::open_aedat4(path, options);
    while (reader->read(chunk)) {
      events += chunk.events.size();
      imu += chunk.imu.size();
    }
    benchmark::DoNotOptimize(events);
    benchmark::DoNotOptimize(imu);
  }
  state.counters["events/s"] =
      benchmark::Counter(static_cast<double>(events), benchmark::Counter::kIsRate);
  state.counters["file_bytes/s"] =
      benchmark::Counter(static_cast<double>(std::filesystem::file_size(path)) *
                             static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate, benchmark::Counter::kIs1024);
  state.counters["events"] = static_cast<double>(events) /
                             static_cast<double>(std::max<std::int64_t>(1, state.iterations()));
}
BENCHMARK(BM_Aedat4Reader)->Arg(1 << 16)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
