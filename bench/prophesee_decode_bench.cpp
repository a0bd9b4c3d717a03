// Prophesee EVT 2.0 / EVT 3.0 decode throughput on the two real recordings, in events/s.
//   decode: the decoder alone over the file's words already in memory (slices of 8192 events);
//   reader: the whole RecordingReader path (file reads, decode, EventSanitizer, chunks).
// Run: build-*/bench/prophesee_decode_bench [--benchmark_repetitions=5]
#include <benchmark/benchmark.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fdv/io/prophesee/evt_decoder.h"
#include "fdv/io/prophesee/prophesee_raw_reader.h"

namespace {

constexpr std::size_t kSlice = 8192;

std::string real(const char* name) { return std::string(FDV_REAL_DATA_DIR) + "/" + name; }

template <typename Word>
bool load_words(const std::string& path, std::vector<Word>& words) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  const std::size_t offset = fdv::read_prophesee_raw_header(path).data_offset;
  words.resize((bytes.size() - offset) / sizeof(Word));
  std::memcpy(words.data(), bytes.data() + offset, words.size() * sizeof(Word));
  return true;
}

template <typename Decoder>
void decode_bench(benchmark::State& state, const char* file) {
  std::vector<typename Decoder::Word> words;
  if (!load_words(real(file), words)) {
    state.SkipWithError("real recording not found");
    return;
  }
  std::vector<fdv::Event> out(kSlice + Decoder::kMaxEventsPerWord - 1);
  std::size_t events = 0;
  for (auto _ : state) {
    Decoder decoder;
    fdv::DecodeCounts counts;
    events = 0;
    for (std::size_t pos = 0; pos < words.size();) {
      std::size_t consumed = 0;
      events += decoder.decode(words.data() + pos, words.size() - pos, out.data(), kSlice, consumed,
                               counts);
      pos += consumed;
      benchmark::DoNotOptimize(out.data());
    }
    benchmark::ClobberMemory();
  }
  state.counters["events"] = static_cast<double>(events);
  state.counters["events/s"] = benchmark::Counter(static_cast<double>(events),
                                                  benchmark::Counter::kIsIterationInvariantRate);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * words.size() *
                                                    sizeof(typename Decoder::Word)));
}

void reader_bench(benchmark::State& state, const char* file) {
  const std::string path = real(file);
  if (!std::ifstream(path)) {
    state.SkipWithError("real recording not found");
    return;
  }
  std::size_t events = 0;
  fdv::SensorChunk chunk;
  for (auto _ : state) {
    auto reader = fdv::open_prophesee_raw(path);
    events = 0;
    while (reader->read(chunk)) events += chunk.events.size();
    benchmark::DoNotOptimize(chunk.events.data());
  }
  state.counters["events"] = static_cast<double>(events);
  state.counters["events/s"] = benchmark::Counter(static_cast<double>(events),
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

void BM_Evt2Decode(benchmark::State& s) {
  decode_bench<fdv::Evt2Decoder>(s, "gen3_sparks_evt2.raw");
}
void BM_Evt3Decode(benchmark::State& s) {
  decode_bench<fdv::Evt3Decoder>(s, "gen41_street_evt3.raw");
}
void BM_Evt2Reader(benchmark::State& s) { reader_bench(s, "gen3_sparks_evt2.raw"); }
void BM_Evt3Reader(benchmark::State& s) { reader_bench(s, "gen41_street_evt3.raw"); }

BENCHMARK(BM_Evt2Decode)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Evt3Decode)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Evt2Reader)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Evt3Reader)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
