// Decode throughput of the readers that aedat4_decode_bench and prophesee_decode_bench do not
// cover, in events/s, through the whole RecordingReader path (open_recording: file reads, parsing,
// EventSanitizer, chunks), with the input in the page cache after the first iteration:
//  - the project's dataset folder (events.bin, 16-byte records), 2 M events written here with
//    DatasetWriter at 640x480;
//  - the RPG text layout (events.txt, "t x y p" per line), 1 M events written here at 240x180;
//  - ROS 1 bags with dvs_msgs/EventArray messages of 5000 events (1 M events), plain and LZ4,
//    written here with ROS's own library (the tests' writer; only when the tests are built);
//  - ROS 2 bags: the two real recordings in ../shared/data/real (libcaer packets of a DVXplorer,
//    and event_camera_msgs EVT 3.0 packets);
//  - HDF5 against EVT 3.0 on the same events: the real `gen41_street_evt3.raw`, and its events
//    written here with Hdf5EventWriter (Metavision layout), uncompressed and gzip level 4.
//  - depth frames: the simulator's (`fast_forward` seed 1, 640x480 depth camera, 31 frames)
//    decoded from PNG (written by OpenCV, as the simulator wrote them) with OpenCV's codec (the reader's decoder before libpng), PNG with libpng,
//    and Zstandard, through decode_dataset_depth (bytes to metres).
// The synthetic inputs are written once per run into a temporary folder, removed at exit.
// Run: build-*/bench/reader_bench [--benchmark_repetitions=3]
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/io/dataset/dataset_writer.h"
#include "fdv/io/dataset/depth_image.h"
#include "fdv/io/hdf5/hdf5_writer.h"
#include "fdv/io/recording.h"
#include "fdv/sim/simulator.h"
#ifdef FDV_BENCH_ROS1
#include "tests/io/rosbag/ros1_bag_writer.h"
#endif

namespace {

namespace fs = std::filesystem;

/// A temporary folder for the generated inputs, removed when the program ends.
const fs::path& scratch_dir() {
  struct Dir {
    fs::path path = fs::temp_directory_path() / ("fdv_reader_bench_" + std::to_string(::getpid()));
    Dir() { fs::create_directories(path); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  };
  static const Dir dir;
  return dir.path;
}

/// Time-ordered events spread uniformly over a width × height sensor, 1 µs apart on average.
std::vector<fdv::Event> synthetic_events(std::size_t n, int width, int height) {
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> x(0, width - 1), y(0, height - 1), dt_ns(0, 2000);
  std::vector<fdv::Event> events(n);
  fdv::TimeNs t = 0;
  for (fdv::Event& e : events) {
    t += dt_ns(rng);
    e.t = t;
    e.x = static_cast<std::uint16_t>(x(rng));
    e.y = static_cast<std::uint16_t>(y(rng));
    e.polarity = (rng() & 1) != 0;
  }
  return events;
}

/// Reads the whole recording at `path` in every iteration; reports events/s and the file size
/// read per second.
void read_all(benchmark::State& state, const std::string& path) {
  if (!fs::exists(path)) {
    state.SkipWithError(("input not found: " + path).c_str());
    return;
  }
  std::uintmax_t bytes = 0;
  if (fs::is_directory(path)) {
    for (const auto& f : fs::recursive_directory_iterator(path))
      if (f.is_regular_file()) bytes += f.file_size();
  } else {
    bytes = fs::file_size(path);
  }
  std::size_t events = 0;
  fdv::SensorChunk chunk;
  for (auto _ : state) {
    auto reader = fdv::open_recording(path);
    while (reader->read(chunk)) events += chunk.events.size();
    benchmark::DoNotOptimize(events);
  }
  state.counters["events/s"] =
      benchmark::Counter(static_cast<double>(events), benchmark::Counter::kIsRate);
  state.counters["bytes/s"] =
      benchmark::Counter(static_cast<double>(bytes) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate, benchmark::Counter::kIs1024);
  state.counters["events"] =
      static_cast<double>(events) /
      static_cast<double>(std::max<benchmark::IterationCount>(1, state.iterations()));
}

void BM_DatasetReader(benchmark::State& state) {
  static const std::string dir = [] {
    const fs::path d = scratch_dir() / "dataset";
    fdv::Calibration calib;
    calib.event_camera = fdv::PinholeCamera{640, 480, 536.3, 536.3, 320.9, 234.0, {}};
    fdv::DatasetWriter w(d.string(), calib);
    const std::vector<fdv::Event> events = synthetic_events(2'000'000, 640, 480);
    w.add_events(events);
    w.finish();
    return d.string();
  }();
  read_all(state, dir);
}
BENCHMARK(BM_DatasetReader)->Unit(benchmark::kMillisecond);

/// The simulator's depth frames in millimetres, as DatasetWriter rounds them.
struct DepthFrames {
  int width = 0, height = 0;
  std::vector<std::vector<std::uint16_t>> millimetres;
};
const DepthFrames& simulated_depth() {
  static const DepthFrames frames = [] {
    struct DepthSink : fdv::sim::SimulationSink {
      void on_depth(const fdv::DepthFrame& f) override { frames.push_back(f); }
      std::vector<fdv::DepthFrame> frames;
    } sink;
    fdv::sim::ScenarioConfig config = fdv::sim::make_preset("fast_forward", 1);
    fdv::sim::set_event_resolution(config, 64, 48);  // the events are not the subject here
    fdv::sim::Simulator(config).run(sink);
    DepthFrames out;
    out.width = sink.frames.at(0).width;
    out.height = sink.frames.at(0).height;
    for (const fdv::DepthFrame& f : sink.frames) {
      fdv::metres_to_millimetres(f.depth_m, out.millimetres.emplace_back(f.depth_m.size()));
    }
    return out;
  }();
  return frames;
}

/// One depth frame a iteration, bytes to metres: arg 0 OpenCV's PNG decoder, 1 libpng, 2 Zstandard.
void BM_DepthDecode(benchmark::State& state) {
  const DepthFrames& frames = simulated_depth();
  const int codec = static_cast<int>(state.range(0));
  std::vector<std::vector<std::uint8_t>> files;
  std::size_t bytes = 0;
  for (const auto& mm : frames.millimetres) {
    if (codec == 2) {
      files.push_back(fdv::encode_depth_zstd(mm));
    } else {  // as the simulator wrote them before the Zstandard layout: OpenCV's PNG writer
      files.emplace_back();
      cv::imencode(".png", cv::Mat(frames.height, frames.width, CV_16UC1, const_cast<std::uint16_t*>(mm.data())),
                   files.back());
    }
    bytes += files.back().size();
  }
  const fdv::PinholeCamera camera{frames.width, frames.height, 385.7, 385.7, 320, 240, {}};
  fdv::ReadReport report;
  std::size_t i = 0;
  for (auto _ : state) {
    const std::vector<std::uint8_t>& file = files[i++ % files.size()];
    if (codec == 0) {
      const cv::Mat mm = cv::imdecode(cv::Mat(1, static_cast<int>(file.size()), CV_8UC1,
                                              const_cast<std::uint8_t*>(file.data())),
                                      cv::IMREAD_UNCHANGED);
      fdv::DepthFrame f;
      f.width = mm.cols;
      f.height = mm.rows;
      f.depth_m.resize(mm.total());
      for (int v = 0; v < mm.rows; ++v)
        for (int u = 0; u < mm.cols; ++u)
          f.depth_m[static_cast<std::size_t>(v) * mm.cols + u] = static_cast<float>(mm.at<std::uint16_t>(v, u)) * 0.001f;
      benchmark::DoNotOptimize(f.depth_m.data());
    } else {
      auto f = fdv::decode_dataset_depth(file, 0, camera, "bench", report);
      if (!f) state.SkipWithError("a frame did not decode");
      benchmark::DoNotOptimize(f);
    }
  }
  state.counters["file_kB"] = static_cast<double>(bytes) / static_cast<double>(files.size()) / 1000.0;
}
BENCHMARK(BM_DepthDecode)->ArgName("codec")->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_RpgTextReader(benchmark::State& state) {
  static const std::string dir = [] {
    const fs::path d = scratch_dir() / "rpg";
    fs::create_directories(d);
    std::FILE* f = std::fopen((d / "events.txt").c_str(), "w");
    for (const fdv::Event& e : synthetic_events(1'000'000, 240, 180))
      std::fprintf(f, "%.9f %d %d %d\n", static_cast<double>(e.t) * 1e-9, e.x, e.y,
                   e.polarity ? 1 : 0);
    std::fclose(f);
    return d.string();
  }();
  read_all(state, dir);
}
BENCHMARK(BM_RpgTextReader)->Unit(benchmark::kMillisecond);

#ifdef FDV_BENCH_ROS1
/// A ROS 1 bag of 200 dvs_msgs/EventArray messages of 5000 events each (346x260).
std::string ros1_bag(fdv::test::ros1::BagWriter::Compression compression, const std::string& name) {
  using fdv::test::ros1::BagWriter;
  const std::string path = (scratch_dir() / name).string();
  BagWriter bag(path, compression);
  const std::vector<fdv::Event> events = synthetic_events(1'000'000, 346, 260);
  constexpr std::size_t kPerMessage = 5000;
  std::vector<fdv::test::ros1::RawEvent> message;
  for (std::size_t first = 0; first < events.size(); first += kPerMessage) {
    message.clear();
    for (std::size_t i = first; i < std::min(events.size(), first + kPerMessage); ++i) {
      const fdv::Event& e = events[i];
      message.push_back({e.x,
                         e.y,
                         {static_cast<std::uint32_t>(1 + e.t / 1'000'000'000),
                          static_cast<std::uint32_t>(e.t % 1'000'000'000)},
                         e.polarity});
    }
    const fdv::test::ros1::Stamp stamp = message.back().ts;
    bag.event_array("/dvs/events", stamp, stamp, 346, 260, message);
  }
  bag.close();
  return path;
}

void BM_Ros1BagReader(benchmark::State& state) {
  using Compression = fdv::test::ros1::BagWriter::Compression;
  static const std::string plain = ros1_bag(Compression::kNone, "plain.bag");
  static const std::string lz4 = ros1_bag(Compression::kLz4, "lz4.bag");
  read_all(state, state.range(0) == 0 ? plain : lz4);
}
BENCHMARK(BM_Ros1BagReader)->ArgName("lz4")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
#endif

void BM_Ros2BagReader(benchmark::State& state) {
  const char* file = state.range(0) == 0 ? "dvxplorer_libcaer_ros2.db3" : "evt3_trigger_ros2.db3";
  read_all(state, std::string(FDV_REAL_DATA_DIR) + "/" + file);
}
// 0: libcaer packets (DVXplorer), 1: event_camera_msgs EVT 3.0.
BENCHMARK(BM_Ros2BagReader)->ArgName("evt3")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

void BM_Evt3VsHdf5(benchmark::State& state) {
  const std::string raw = std::string(FDV_REAL_DATA_DIR) + "/gen41_street_evt3.raw";
  if (state.range(0) == 0) return read_all(state, raw);
  const bool gzip = state.range(0) == 2;
  const fs::path h5 = scratch_dir() / (gzip ? "street_gzip.h5" : "street.h5");
  if (!fs::exists(h5) && fs::exists(raw)) {
    auto reader = fdv::open_recording(raw);
    fdv::Hdf5EventWriter w(h5.string(), reader->info().width, reader->info().height,
                           {.gzip_level = gzip ? 4 : 0, .chunk_rows = 16384});
    fdv::SensorChunk chunk;
    while (reader->read(chunk)) w.add(chunk.events);
    w.close();
  }
  read_all(state, h5.string());
}
// 0: the EVT 3.0 RAW file; 1: the same events in HDF5; 2: in HDF5 with gzip.
BENCHMARK(BM_Evt3VsHdf5)->ArgName("hdf5")->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
