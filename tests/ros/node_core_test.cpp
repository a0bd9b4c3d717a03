// NodeCore (ros/core) without a ROS master: ROS 1 messages written into a bag by ROS's own
// library (the test writer of tests/io/rosbag), read back as raw bytes, pushed as a subscriber
// would, and compared with `fdv run`'s path through the same bag (open_recording + replay).
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>

#include "fdv/core/calibration.h"
#include "fdv/io/recording.h"
#include "fdv/pipeline/replay.h"
#include "fdv/pipeline/sensor_policy.h"
#include "fdv/results/schema.h"
#include "fdv/sim/dataset_cache.h"
#include "io/rosbag/ros1_bag_writer.h"
#include "node_core.h"
#include "test_support.h"

namespace fdv {
namespace {

namespace ros1 = test::ros1;
using ros_core::NodeConfig;
using ros_core::NodeCore;
using ros_core::NodeOutputs;
using ros_core::Stream;
using nlohmann::json;

constexpr const char* kEvents = "/dvs/events";
constexpr const char* kImu = "/mavros/imu/data";
constexpr const char* kDepth = "/camera/depth/image_rect_raw";
constexpr const char* kOdometry = "/mavros/local_position/odom";

/// A bag's times are at least ros::TIME_MIN and a zero header stamp means "none": the
/// simulation's times, which start at 0, are moved by a second.
ros1::Stamp stamp(TimeNs t) {
  t += kNsPerS;
  return {static_cast<std::uint32_t>(t / kNsPerS), static_cast<std::uint32_t>(t % kNsPerS)};
}

/// The dataset as a ROS 1 bag with the node's default topics, a second later: events in 1 ms
/// messages, depth as 32FC1 (the dataset's float metres, bit for bit), odometry's twist in the
/// child frame.
void write_bag(const std::string& dataset, const std::string& bag_path) {
  auto reader = open_recording(dataset);
  const int width = reader->info().width, height = reader->info().height;
  ros1::BagWriter bag(bag_path);
  std::vector<ros1::RawEvent> batch;
  TimeNs batch_start = 0;
  auto flush_events = [&] {
    if (batch.empty()) return;
    bag.event_array(kEvents, batch.front().ts, batch.front().ts, static_cast<std::uint32_t>(width),
                    static_cast<std::uint32_t>(height), batch);
    batch.clear();
  };
  SensorChunk chunk;
  while (reader->read(chunk)) {
    for (const Event& e : chunk.events) {
      if (!batch.empty() && e.t >= batch_start + kNsPerMs) flush_events();
      if (batch.empty()) batch_start = e.t;
      batch.push_back({e.x, e.y, stamp(e.t), e.polarity > 0});
    }
    for (const ImuSample& s : chunk.imu)
      bag.imu(kImu, stamp(s.t), stamp(s.t), {s.gyro_rad_s.x(), s.gyro_rad_s.y(), s.gyro_rad_s.z()},
              {s.accel_m_s2.x(), s.accel_m_s2.y(), s.accel_m_s2.z()});
    for (const DepthFrame& f : chunk.depth) {
      std::vector<std::uint8_t> bytes(f.depth_m.size() * sizeof(float));
      std::memcpy(bytes.data(), f.depth_m.data(), bytes.size());
      bag.image(kDepth, stamp(f.t), stamp(f.t), static_cast<std::uint32_t>(f.width),
                static_cast<std::uint32_t>(f.height), "32FC1", static_cast<std::uint32_t>(f.width * 4), bytes);
    }
    for (const OdometrySample& s : chunk.odometry) {
      const Eigen::Vector3d v_B = s.q_W_B.conjugate() * s.v_W;
      bag.odometry(kOdometry, stamp(s.t), stamp(s.t),
                   {{s.p_W_B.x(), s.p_W_B.y(), s.p_W_B.z()}, {s.q_W_B.x(), s.q_W_B.y(), s.q_W_B.z(), s.q_W_B.w()}},
                   {v_B.x(), v_B.y(), v_B.z()}, {s.omega_B.x(), s.omega_B.y(), s.omega_B.z()});
    }
  }
  flush_events();
  bag.close();
}

struct RawMessage {
  Stream stream;
  std::string type;
  TimeNs t = 0;  ///< bag time
  std::vector<std::uint8_t> bytes;
};

std::vector<RawMessage> raw_messages(const std::string& bag_path) {
  const std::map<std::string, Stream> streams = {
      {kEvents, Stream::kEvents}, {kImu, Stream::kImu}, {kDepth, Stream::kDepth}, {kOdometry, Stream::kOdometry}};
  rosbag::Bag bag(bag_path);
  rosbag::View view(bag);
  std::vector<RawMessage> out;
  for (const rosbag::MessageInstance& m : view) {
    RawMessage r{streams.at(m.getTopic()), m.getDataType(), static_cast<TimeNs>(m.getTime().toNSec()), {}};
    r.bytes.resize(m.size());
    ros::serialization::OStream s(r.bytes.data(), static_cast<std::uint32_t>(r.bytes.size()));
    m.write(s);
    out.push_back(std::move(r));
  }
  return out;
}

/// The messages in the order they would arrive if those of `late` streams came `by` (stream time)
/// after the others of their time, as over separate, slower connections.
std::vector<const RawMessage*> arrival_order(const std::vector<RawMessage>& messages, const std::set<Stream>& late,
                                             TimeNs by) {
  std::vector<const RawMessage*> order;
  std::deque<const RawMessage*> held;
  for (const RawMessage& m : messages) {
    if (late.count(m.stream)) {
      held.push_back(&m);
      continue;
    }
    for (; !held.empty() && held.front()->t + by <= m.t; held.pop_front()) order.push_back(held.front());
    order.push_back(&m);
  }
  order.insert(order.end(), held.begin(), held.end());
  return order;
}

struct Rows {
  std::vector<json> windows, tracks, estimates, predictions, dodge;
  std::vector<std::string> warnings;
  std::vector<double> latencies_ms;
};

NodeOutputs collect(Rows& rows) {
  NodeOutputs o;
  o.on_window = [&](const ros_core::WindowOutput& w) {
    rows.windows.push_back(w.window);
    rows.tracks.push_back(w.tracks);
    rows.latencies_ms.push_back(w.latency_ms);
  };
  o.on_estimate = [&](const json& e) {
    json row = e;
    row.erase("path");  // not in trajectories.jsonl; checked on its own
    rows.estimates.push_back(row);
  };
  o.on_prediction = [&](const json& p) { rows.predictions.push_back(p); };
  o.on_dodge = [&](const json& d) { rows.dodge.push_back(d); };
  o.on_warning = [&](const std::string& key, const std::string&) { rows.warnings.push_back(key); };
  return o;
}

/// `fdv run`'s path: the bag through the reader, the merger and Perception.
Rows replay_rows(const std::string& bag_path, const std::string& calibration) {
  Rows rows;
  auto reader = open_recording(bag_path);
  const SensorPolicy policy = apply_sensor_policy(declared_sensors(reader->info(), load_calibration(calibration)), {});
  PerceptionCallbacks c;
  c.on_window = [&](const WindowResult& w) { rows.windows.push_back(window_row(w)); };
  c.on_estimate = [&](const EstimateResult& e) { rows.estimates.push_back(trajectory_row(e)); };
  c.on_prediction = [&](const PredictionResult& p) { rows.predictions.push_back(prediction_row(p)); };
  c.on_dodge = [&](const DodgeDecision& d) { rows.dodge.push_back(dodge_row(d)); };
  replay(std::move(reader), policy.calibration, policy.options, c);
  return rows;
}

/// One simulated scene (cached across runs of the test), its bag, the bag's raw messages and
/// `fdv run`'s rows of it, shared by the tests.
struct Scene {
  std::string dataset, bag;
  std::vector<RawMessage> messages;
  Rows reference;
};

const Scene& scene() {
  static const Scene shared = [] {
    Scene s;
    s.dataset = sim::ensure_simulated("hover_headon", 1, std::string(FDV_TEST_TMP_DIR) + "/node_core_cache");
    s.bag = test::scratch_dir("node_core") + "/hover_headon.bag";
    write_bag(s.dataset, s.bag);
    s.messages = raw_messages(s.bag);
    s.reference = replay_rows(s.bag, s.dataset + "/calibration.yaml");
    return s;
  }();
  return shared;
}

class NodeCoreReplay : public ::testing::Test {
 protected:
  void SetUp() override {
    messages_ = &scene().messages;
    reference_ = &scene().reference;
    dataset_ = scene().dataset;
  }
  static NodeConfig config() {
    NodeConfig c;
    c.calibration_file = dataset_ + "/calibration.yaml";
    c.wait_for_depth = true;
    return c;
  }
  static void expect_same_as_reference(const Rows& rows) {
    ASSERT_GT(reference_->windows.size(), 10u);
    ASSERT_GT(reference_->estimates.size(), 3u) << "the scene must exercise the estimators";
    EXPECT_EQ(rows.windows.size(), reference_->windows.size());
    for (std::size_t i = 0; i < std::min(rows.windows.size(), reference_->windows.size()); ++i)
      ASSERT_EQ(rows.windows[i], reference_->windows[i]) << "window " << i;
    EXPECT_EQ(rows.estimates, reference_->estimates);
    EXPECT_EQ(rows.predictions, reference_->predictions);
    EXPECT_EQ(rows.dodge, reference_->dodge);
  }
  static inline std::string dataset_;
  static inline const std::vector<RawMessage>* messages_ = nullptr;
  static inline const Rows* reference_ = nullptr;
};

TEST_F(NodeCoreReplay, BagOrderGivesFdvRunsResults) {
  Rows rows;
  NodeCore core(config(), collect(rows));
  for (const RawMessage& m : *messages_) ASSERT_TRUE(core.push(m.stream, m.type, m.bytes.data(), m.bytes.size()));
  core.finish();
  expect_same_as_reference(rows);
  const json d = core.diagnostics();
  EXPECT_EQ(d["streams"]["events"]["dropped"], 0);
  EXPECT_EQ(d["pipeline"]["windows"], reference_->windows.size()) << "the finished run's counters stay";
  // Latency: measured for the windows the input completed; none for those finish() closed.
  const auto measured = std::count_if(rows.latencies_ms.begin(), rows.latencies_ms.end(),
                                      [](double ms) { return std::isfinite(ms) && ms >= 0; });
  EXPECT_EQ(d["latency_ms"]["count"], measured);
  EXPECT_GT(measured, 0);
  EXPECT_TRUE(std::isnan(rows.latencies_ms.back())) << "the last window is closed by finish()";
  EXPECT_EQ(d["streams"]["imu"]["messages"],
            std::count_if(messages_->begin(), messages_->end(), [](const RawMessage& m) { return m.stream == Stream::kImu; }));
}

/// Separate connections deliver streams out of step: here IMU, odometry and depth each arrive
/// 30 ms (stream time) after the events of their time. The merge restores fdv run's order.
TEST_F(NodeCoreReplay, StreamsArrivingOutOfStepGiveTheSameResults) {
  const auto order = arrival_order(*messages_, {Stream::kImu, Stream::kDepth, Stream::kOdometry}, 30 * kNsPerMs);
  Rows rows;
  NodeCore core(config(), collect(rows));
  for (const RawMessage* m : order) core.push(m->stream, m->type, m->bytes.data(), m->bytes.size());
  core.finish();
  expect_same_as_reference(rows);
}

TEST_F(NodeCoreReplay, FinishEndsARunAndTheNextStartsAfresh) {
  Rows rows;
  NodeCore core(config(), collect(rows));
  for (int run = 0; run < 2; ++run) {
    for (const RawMessage& m : *messages_) core.push(m.stream, m.type, m.bytes.data(), m.bytes.size());
    core.finish();
  }
  ASSERT_EQ(rows.windows.size(), 2 * reference_->windows.size());
  for (std::size_t i = 0; i < reference_->windows.size(); ++i)
    ASSERT_EQ(rows.windows[reference_->windows.size() + i], reference_->windows[i]) << "second run, window " << i;
  EXPECT_EQ(core.diagnostics()["runs"], 3);  // the two replays, and the one now waiting
}

TEST_F(NodeCoreReplay, EstimatesCarryTheirPredictedPath) {
  NodeConfig c = config();
  c.path_horizon_s = 0.5;
  c.path_step_s = 0.1;
  std::vector<json> estimates;
  NodeOutputs o;
  o.on_estimate = [&](const json& e) { estimates.push_back(e); };
  NodeCore core(c, std::move(o));
  for (const RawMessage& m : *messages_) core.push(m.stream, m.type, m.bytes.data(), m.bytes.size());
  core.finish();
  ASSERT_FALSE(estimates.empty());
  for (const json& e : estimates) {
    ASSERT_EQ(e["path"].size(), 6u);  // t_last, +0.1, ..., +0.5 s
    const double t0 = e["t0"], t = e["path"][3][0];
    EXPECT_NEAR(t, e["t_last"].get<double>() + 0.3, 1e-9);
    // p(t) = p0 + v0 (t - t0) + g (t - t0)^2 / 2, from the row's own parameters.
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(e["path"][3][k + 1].get<double>(),
                  e["p0"][k].get<double>() + e["v0"][k].get<double>() * (t - t0) +
                      0.5 * e["gravity"][k].get<double>() * (t - t0) * (t - t0),
                  1e-6);
  }
}

// --- Bad input: each a counted drop and a warning, never a crash -------------------------------

class NodeCoreBadInput : public NodeCoreReplay {
 protected:
  /// The first message of a stream at least `later` after the stream's first.
  static const RawMessage& first(Stream s, TimeNs later = 0) {
    std::optional<TimeNs> start;
    for (const RawMessage& m : *messages_) {
      if (m.stream != s) continue;
      if (!start) start = m.t;
      if (m.t >= *start + later) return m;
    }
    throw std::runtime_error("no such message");
  }
  static std::uint64_t dropped(const NodeCore& core, const char* stream) {
    return core.diagnostics()["streams"][stream]["dropped"];
  }
  /// The raw bytes of the one message `write` puts into a bag (ROS's own serialization).
  static RawMessage single_message(const std::string& name, const std::function<void(ros1::BagWriter&)>& write) {
    const std::string bag = test::scratch_dir("node_core_bad_" + name) + "/one.bag";
    {
      ros1::BagWriter w(bag);
      write(w);
      w.close();
    }
    return raw_messages(bag).at(0);
  }
  static bool warned(const Rows& rows, const std::string& key) {
    return std::find(rows.warnings.begin(), rows.warnings.end(), key) != rows.warnings.end();
  }
};

TEST_F(NodeCoreBadInput, ATypeTheStreamDoesNotTake) {
  Rows rows;
  NodeCore core(config(), collect(rows));
  const RawMessage& imu = first(Stream::kImu);
  EXPECT_FALSE(core.push(Stream::kEvents, imu.type, imu.bytes.data(), imu.bytes.size()));
  EXPECT_FALSE(core.push(Stream::kImu, "std_msgs/String", imu.bytes.data(), imu.bytes.size()));
  EXPECT_EQ(dropped(core, "events"), 1u);
  EXPECT_EQ(dropped(core, "imu"), 1u);
  EXPECT_TRUE(warned(rows, "events: type sensor_msgs/Imu is not one this stream takes"));
}

TEST_F(NodeCoreBadInput, StampsGoingBackwards) {
  Rows rows;
  NodeCore core(config(), collect(rows));
  const RawMessage& later = first(Stream::kImu, 50 * kNsPerMs);
  const RawMessage& earlier = first(Stream::kImu);
  EXPECT_TRUE(core.push(Stream::kImu, later.type, later.bytes.data(), later.bytes.size()));
  EXPECT_FALSE(core.push(Stream::kImu, earlier.type, earlier.bytes.data(), earlier.bytes.size()));
  EXPECT_EQ(dropped(core, "imu"), 1u);
  EXPECT_TRUE(warned(rows, "imu: timestamp went backwards"));
}

TEST_F(NodeCoreBadInput, ADepthImageOfTheWrongType) {
  const RawMessage m = single_message("depth_type", [](ros1::BagWriter& w) {
    w.image(kDepth, {1, 0}, {1, 0}, 4, 2, "mono8", 4, std::vector<std::uint8_t>(8, 7));
  });
  Rows rows;
  NodeCore core(config(), collect(rows));
  EXPECT_FALSE(core.push(Stream::kDepth, m.type, m.bytes.data(), m.bytes.size()));
  EXPECT_EQ(dropped(core, "depth"), 1u);
  EXPECT_TRUE(warned(rows, "depth: image encoding is neither 16UC1 nor 32FC1"));
}

TEST_F(NodeCoreBadInput, ADepthImageOfTheWrongSizeIsRejectedByTheRegistration) {
  const RawMessage small = single_message("depth_size", [](ros1::BagWriter& w) {
    w.image(kDepth, {0, 1000}, {0, 1000}, 4, 2, "32FC1", 16, std::vector<std::uint8_t>(32, 0));
  });
  Rows rows;
  NodeCore core(config(), collect(rows));
  EXPECT_TRUE(core.push(Stream::kDepth, small.type, small.bytes.data(), small.bytes.size()));
  for (const RawMessage& m : *messages_)
    if (m.t > 1000) core.push(m.stream, m.type, m.bytes.data(), m.bytes.size());
  core.finish();
  // Counted by the pipeline as a rejected frame (the size is the depth camera's to judge).
  EXPECT_EQ(rows.windows.size(), reference_->windows.size());
  EXPECT_TRUE(std::any_of(rows.warnings.begin(), rows.warnings.end(),
                          [](const std::string& k) { return k.find("depth frame") != std::string::npos; }));
}

TEST_F(NodeCoreBadInput, EventsThatDoNotFitTheCalibration) {
  const RawMessage m = single_message("event_size", [](ros1::BagWriter& w) {
    w.event_array(kEvents, {1, 0}, {1, 0}, 346, 260, {{10, 10, {1, 0}, true}});
  });
  Rows rows;
  NodeCore core(config(), collect(rows));  // the calibration is 640 x 480
  EXPECT_FALSE(core.push(Stream::kEvents, m.type, m.bytes.data(), m.bytes.size()));
  EXPECT_EQ(dropped(core, "events"), 1u);
  EXPECT_TRUE(warned(rows, "events: the message's sensor size is not the calibration's"));
}

TEST_F(NodeCoreBadInput, AnUnknownEventEncoding) {
  // event_camera_msgs/EventPacket by the ROS 1 serialization rules: header (seq, stamp,
  // frame_id), height, width, seq (u64), time_base (u64), encoding, is_bigendian, events.
  std::vector<std::uint8_t> b;
  auto u32 = [&](std::uint32_t v) { for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i))); };
  auto u64 = [&](std::uint64_t v) { u32(static_cast<std::uint32_t>(v)); u32(static_cast<std::uint32_t>(v >> 32)); };
  auto str = [&](const std::string& s) { u32(static_cast<std::uint32_t>(s.size())); b.insert(b.end(), s.begin(), s.end()); };
  u32(0), u32(1), u32(0), str("cam");
  u32(480), u32(640), u64(1), u64(0), str("evt9"), b.push_back(0);
  u32(8), b.insert(b.end(), 8, 0);
  Rows rows;
  NodeCore core(config(), collect(rows));
  core.push(Stream::kEvents, "event_camera_msgs/EventPacket", b.data(), b.size());
  EXPECT_EQ(core.diagnostics()["dropped_by_reason"]["dropped"].size(), 1u);
  EXPECT_TRUE(warned(rows, "event packet: unsupported encoding"));
}

TEST_F(NodeCoreBadInput, ATopicThatNeverArrives) {
  Rows rows;
  NodeCore core(config(), collect(rows));
  for (const RawMessage& m : *messages_)
    if (m.stream != Stream::kOdometry) core.push(m.stream, m.type, m.bytes.data(), m.bytes.size());
  core.finish();
  EXPECT_TRUE(warned(rows, "missing odometry"));
  // Not awaited while silent: the windows still come, all of them.
  EXPECT_EQ(rows.windows.size(), reference_->windows.size());
  EXPECT_TRUE(rows.estimates.empty()) << "no odometry, no camera poses: no 3D";
}

TEST_F(NodeCoreBadInput, AStreamArrivingLate) {
  // The IMU 200 ms behind the other streams, beyond max_hold_s (0.1 s): not waited for, used late.
  const auto order = arrival_order(*messages_, {Stream::kImu}, 200 * kNsPerMs);
  Rows rows;
  NodeCore core(config(), collect(rows));
  for (const RawMessage* m : order) EXPECT_TRUE(core.push(m->stream, m->type, m->bytes.data(), m->bytes.size()));
  core.finish();
  EXPECT_GT(core.diagnostics()["streams"]["imu"]["late"].get<int>(), 100);
  EXPECT_TRUE(warned(rows, "late imu"));
  EXPECT_EQ(rows.windows.size(), reference_->windows.size());
}

TEST(NodeCoreConfig, AnUnknownOptionKeyIsAnErrorNamingIt) {
  NodeConfig c;
  c.option_overrides = {{"detector.min_peek", "0.3"}};
  try {
    NodeCore core(c, {});
    FAIL() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("detector.min_peek"), std::string::npos) << e.what();
  }
}

/// A dvs_msgs/EventArray serialized by hand (ROS 1 rules): `n` events at (5, 5), the k-th at
/// sec + k ms, in a message declaring width x height.
std::vector<std::uint8_t> event_array_bytes(std::uint32_t width, std::uint32_t height, std::uint32_t n,
                                            std::uint32_t sec, std::uint32_t nsec = 0) {
  std::vector<std::uint8_t> b;
  auto u32 = [&](std::uint32_t v) { for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i))); };
  u32(0), u32(sec), u32(0), u32(0);  // header: seq, stamp, frame_id ""
  u32(height), u32(width), u32(n);
  for (std::uint32_t k = 0; k < n; ++k) {
    b.push_back(5), b.push_back(0), b.push_back(5), b.push_back(0);  // x, y
    u32(sec), u32(nsec + k * 1'000'000);                             // ts
    b.push_back(1);
  }
  return b;
}

std::uint64_t dropped_for(const NodeCore& core, const std::string& reason) {
  const json diagnostics = core.diagnostics();
  const json& dropped = diagnostics["dropped_by_reason"]["dropped"];
  return dropped.contains(reason) ? dropped[reason]["count"].get<std::uint64_t>() : 0;
}

TEST(NodeCoreBadMessage, ASensorSizeAboveTheCapIsADropNotAnAllocation) {
  NodeCore core(NodeConfig{}, {});  // no calibration, no size: the first event message's size
  for (const std::uint32_t side : {65535u, 0xFFFFFFFFu}) {
    const auto b = event_array_bytes(side, side, 3, 1);
    EXPECT_FALSE(core.push(Stream::kEvents, "dvs_msgs/EventArray", b.data(), b.size())) << side;
  }
  EXPECT_EQ(dropped_for(core, "events: sensor size above the cap 4096"), 2u);
  // The run still takes its size from the first message that has a usable one.
  const auto ok = event_array_bytes(64, 48, 3, 1);
  EXPECT_TRUE(core.push(Stream::kEvents, "dvs_msgs/EventArray", ok.data(), ok.size()));
}

TEST(NodeCoreBadMessage, AStampNearTheEndOfRosTimeIsADrop) {
  // 4294967295.999999999 s: ros::Time would abort the node on the window ending after it.
  std::vector<json> windows;
  NodeOutputs o;
  o.on_window = [&](const ros_core::WindowOutput& w) { windows.push_back(w.window); };
  NodeCore core(NodeConfig{}, std::move(o));
  const auto ok = event_array_bytes(64, 48, 3, 1);
  EXPECT_TRUE(core.push(Stream::kEvents, "dvs_msgs/EventArray", ok.data(), ok.size()));
  const auto late = event_array_bytes(64, 48, 2, 0xFFFFFFFFu, 999'000'000u);
  EXPECT_FALSE(core.push(Stream::kEvents, "dvs_msgs/EventArray", late.data(), late.size()));
  EXPECT_EQ(dropped_for(core, "events: stamp beyond ROS time's range (2106)"), 2u);
  // It moved no stream time: the next events are not taken for going backwards.
  const auto next = event_array_bytes(64, 48, 3, 2);
  EXPECT_TRUE(core.push(Stream::kEvents, "dvs_msgs/EventArray", next.data(), next.size()));
  core.finish();
  for (const json& w : windows) EXPECT_LT(w["t_end"].get<double>(), 10.0) << "no window at the late stamp";
}

TEST(NodeCoreConfig, OverridesReachTheOptions) {
  NodeConfig c;
  c.width = 64, c.height = 48;
  c.option_overrides = {{"window_ms", "10"}};
  std::vector<json> windows;
  NodeOutputs o;
  o.on_window = [&](const ros_core::WindowOutput& w) { windows.push_back(w.window); };
  NodeCore core(c, std::move(o));
  // Events without a calibration, serialized as dvs_msgs/EventArray by hand: 30 ms of them.
  std::vector<std::uint8_t> b;
  auto u32 = [&](std::uint32_t v) { for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i))); };
  u32(0), u32(0), u32(0), u32(0);  // header: seq, stamp, frame_id ""
  u32(48), u32(64), u32(31);
  for (std::uint32_t k = 0; k <= 30; ++k) {
    b.push_back(5), b.push_back(0), b.push_back(5), b.push_back(0);  // x, y
    u32(1), u32(k * 1'000'000);                                      // ts
    b.push_back(1);
  }
  ASSERT_TRUE(core.push(Stream::kEvents, "dvs_msgs/EventArray", b.data(), b.size()));
  core.finish();
  ASSERT_GE(windows.size(), 3u);
  EXPECT_NEAR(windows[0]["t_end"].get<double>() - windows[0]["t_start"].get<double>(), 0.010, 1e-9);
}

}  // namespace
}  // namespace fdv
