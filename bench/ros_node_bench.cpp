// What fdv_ros_node adds per event window over the library, on the same ROS 1 bag (its
// target: at most 0.5 ms). A plain program (CLI11), like pipeline_bench: one pass is many windows.
//
//   build/fdv simulate --scenario hover_headon --seed 1 --out out/headon
//   build/fdv export out/headon --to ros1-bag out/headon.bag
//   build/bench/ros_node_bench --bag out/headon.bag --calib out/headon/calibration.yaml --repeat 5
//
// Three passes over the bag's messages, held in memory as raw bytes (as a subscriber receives
// them), each timed on the steady clock; the median of --repeat runs per pass:
//   library  the messages decoded beforehand (untimed), then Perception alone, in bag order;
//   fdv run  the bag read, decoded and merged by open_recording + replay (fdv run's path);
//   node     NodeCore on the raw bytes (decoding, the time-ordering merge, the rows as JSON), and
//            each result made into its ROS message and serialized (bench/ros_node_publish.h).
// The node's extra work per window is (node − library) / windows, taken per run (the passes of a
// run are back to back, so other load on the machine touches both alike) and then the median. What the node does not do here
// is roscpp's own receiving and sending (its threads, the sockets), which is ROS's, not ours.
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "bench/ros_node_publish.h"
#include "fdv/core/calibration.h"
#include "fdv/io/recording.h"
#include "fdv/io/rosbag/message_decoder.h"
#include "fdv/pipeline/replay.h"
#include "fdv/pipeline/sensor_policy.h"

namespace fdv {
namespace {

using Clock = std::chrono::steady_clock;

struct RawMessage {
  ros_core::Stream stream;
  bag::MessageType type;
  std::string type_name;
  std::vector<std::uint8_t> bytes;
};

std::vector<RawMessage> read_raw(const std::string& path, const std::map<std::string, ros_core::Stream>& topics) {
  rosbag::Bag bag(path);
  rosbag::View view(bag);
  std::vector<RawMessage> out;
  for (const rosbag::MessageInstance& m : view) {
    const auto topic = topics.find(m.getTopic());
    if (topic == topics.end()) continue;
    RawMessage r{topic->second, bag::message_type(m.getDataType()), m.getDataType(), {}};
    r.bytes.resize(m.size());
    ros::serialization::OStream s(r.bytes.data(), static_cast<std::uint32_t>(r.bytes.size()));
    m.write(s);
    out.push_back(std::move(r));
  }
  return out;
}

StreamKind kind(ros_core::Stream s) {
  constexpr StreamKind kinds[] = {StreamKind::kEvents, StreamKind::kImu, StreamKind::kDepth, StreamKind::kOdometry};
  return kinds[static_cast<int>(s)];
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

int run(int argc, char** argv) {
  CLI::App app{"fdv_ros_node's work per window over the library's, on one ROS 1 bag"};
  std::string bag_path, calib_path;
  int repeat = 5;
  app.add_option("--bag", bag_path, "a ROS 1 bag with the node's default topics (fdv export --to ros1-bag)")->required();
  app.add_option("--calib", calib_path, "its calibration")->required();
  app.add_option("--repeat", repeat, "runs per pass (median reported)");
  CLI11_PARSE(app, argc, argv);

  const std::map<std::string, ros_core::Stream> topics = {{"/dvs/events", ros_core::Stream::kEvents},
                                                          {"/mavros/imu/data", ros_core::Stream::kImu},
                                                          {"/camera/depth/image_rect_raw", ros_core::Stream::kDepth},
                                                          {"/mavros/local_position/odom", ros_core::Stream::kOdometry}};
  const std::vector<RawMessage> messages = read_raw(bag_path, topics);
  const Calibration calibration = load_calibration(calib_path);
  auto reader = open_recording(bag_path);
  const SensorPolicy policy = apply_sensor_policy(declared_sensors(reader->info(), calibration), {});

  // The library's input: every message decoded beforehand (timed on its own, in each run).
  std::vector<SensorChunk> decoded(messages.size());
  auto decode_all = [&] {
    bag::MessageDecoder decoder(bag::Dialect::kRos1);
    decoder.set_sensor_size(calibration.event_camera.width, calibration.event_camera.height);
    ReadReport report;
    for (std::size_t i = 0; i < messages.size(); ++i) {
      decoded[i].clear();
      decoder.decode(kind(messages[i].stream), messages[i].type, messages[i].bytes.data(), messages[i].bytes.size(),
                     std::nullopt, decoded[i], report, "bench");
    }
  };

  std::vector<double> decode_ms, library_ms, run_ms, node_ms;
  std::uint64_t windows = 0, events = 0, bytes = 0;
  for (int r = 0; r < repeat; ++r) {
    {
      const Clock::time_point start = Clock::now();
      decode_all();
      decode_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
    {
      std::uint64_t w = 0;
      PerceptionCallbacks c;
      c.on_window = [&](const WindowResult&) { ++w; };
      const Clock::time_point start = Clock::now();
      Perception perception(policy.calibration, policy.options, c);
      for (const SensorChunk& chunk : decoded) {
        if (!chunk.events.empty()) perception.push_events(chunk.events);
        for (const ImuSample& s : chunk.imu) perception.push_imu(s);
        for (const DepthFrame& f : chunk.depth) perception.push_depth(f);
        for (const OdometrySample& s : chunk.odometry) perception.push_odometry(s);
      }
      perception.finish();
      library_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
      windows = w;
      events = perception.counters().events;
    }
    {
      const Clock::time_point start = Clock::now();
      replay(open_recording(bag_path), policy.calibration, policy.options, {});
      run_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
    {
      bytes = 0;
      ros_core::NodeConfig config;
      config.calibration_file = calib_path;
      const Clock::time_point start = Clock::now();
      ros_core::NodeCore core(config, bench::serializing_outputs(bytes));
      for (const RawMessage& m : messages) core.push(m.stream, m.type_name, m.bytes.data(), m.bytes.size());
      core.finish();
      node_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
  }
  const double n = static_cast<double>(windows);
  const double lib = median(library_ms), fdv_run = median(run_ms), node = median(node_ms);
  std::vector<double> over_library, over_decoded, over_run;
  for (int r = 0; r < repeat; ++r) {
    over_library.push_back((node_ms[r] - library_ms[r]) / n);
    over_decoded.push_back((node_ms[r] - library_ms[r] - decode_ms[r]) / n);
    over_run.push_back((node_ms[r] - run_ms[r]) / n);
  }
  std::printf("%zu messages, %llu events, %llu windows, %d runs per pass (median)\n", messages.size(),
              static_cast<unsigned long long>(events), static_cast<unsigned long long>(windows), repeat);
  std::printf("library (Perception on decoded data) %8.1f ms  %6.3f ms/window\n", lib, lib / n);
  std::printf("decoding the messages alone          %8.1f ms  %6.3f ms/window\n", median(decode_ms),
              median(decode_ms) / n);
  std::printf("fdv run (read + decode + merge)      %8.1f ms  %6.3f ms/window\n", fdv_run, fdv_run / n);
  std::printf("node (NodeCore + messages, %6.1f KB) %8.1f ms  %6.3f ms/window\n", static_cast<double>(bytes) / 1e3, node,
              node / n);
  std::printf("per window, median of the runs' differences: node - library %.3f ms; node - library - decoding "
              "%.3f ms; node - fdv run %.3f ms\n",
              median(over_library), median(over_decoded), median(over_run));
  return 0;
}

}  // namespace
}  // namespace fdv

int main(int argc, char** argv) { return fdv::run(argc, argv); }
