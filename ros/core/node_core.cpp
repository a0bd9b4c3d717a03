#include "node_core.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <deque>
#include <limits>
#include <map>
#include <optional>
#include <tuple>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/eval/statistics.h"
#include "fdv/io/rosbag/message_decoder.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/pipeline/perception.h"
#include "fdv/pipeline/sensor_policy.h"
#include "fdv/results/schema.h"

namespace fdv::ros_core {
namespace {

using Clock = std::chrono::steady_clock;
constexpr TimeNs kNever = std::numeric_limits<TimeNs>::max();
constexpr TimeNs kBeforeAll = std::numeric_limits<TimeNs>::min();
/// Latency is summarized over this many recent windows (a flight runs for hours).
constexpr std::size_t kLatencyWindows = 2000;
constexpr std::array<Stream, 4> kStreams = {Stream::kEvents, Stream::kImu, Stream::kDepth, Stream::kOdometry};

std::size_t index(Stream s) { return static_cast<std::size_t>(s); }

StreamKind kind(Stream s) {
  switch (s) {
    case Stream::kEvents:
      return StreamKind::kEvents;
    case Stream::kImu:
      return StreamKind::kImu;
    case Stream::kDepth:
      return StreamKind::kDepth;
    case Stream::kOdometry:
      return StreamKind::kOdometry;
  }
  return StreamKind::kEvents;
}

TimeNs from_seconds(double s) { return static_cast<TimeNs>(s * 1e9); }

/// The options file with each override set on its key ("section.key" or a top-level "key").
PerceptionOptions load_options(const NodeConfig& config) {
  const std::string name = config.options_file.empty() ? "(node parameters)" : config.options_file;
  YAML::Node root = config.options_file.empty()
                        ? YAML::Node(YAML::NodeType::Map)
                        : parse_config_yaml(read_config_file(config.options_file), config.options_file);
  if (!root.IsMap() && !root.IsNull()) throw InputError(name, "", "the options must be a mapping");
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  for (const auto& [key, value] : config.option_overrides) {
    const auto dot = key.find('.');
    const YAML::Node scalar = parse_config_yaml(value, "parameter " + key);
    if (dot == std::string::npos)
      root[key] = scalar;
    else
      root[key.substr(0, dot)][key.substr(dot + 1)] = scalar;
  }
  return load_perception_options(root, name);
}

nlohmann::json tracks_json(const Tracker& tracker, TimeNs t) {
  nlohmann::json tracks = nlohmann::json::array();
  for (const Track& track : tracker.tracks()) {
    const TrackPrediction p = track.predict(t);
    const Eigen::Matrix2d& c = p.center_covariance_px2;
    tracks.push_back({{"id", track.id()},
                      {"confirmed", track.confirmed()},
                      {"first_t", to_seconds(track.first_time())},
                      {"last_update_t", to_seconds(track.last_update_time())},
                      {"hits", track.hits()},
                      {"misses", track.misses()},
                      {"center", {p.center_px.x(), p.center_px.y()}},
                      {"velocity", {p.velocity_px_s.x(), p.velocity_px_s.y()}},
                      {"center_covariance", {c(0, 0), c(0, 1), c(1, 0), c(1, 1)}},
                      {"box_size", {p.box_size_px.x(), p.box_size_px.y()}}});
  }
  return tracks;
}

struct StreamHealth {
  std::uint64_t messages = 0, dropped = 0, late = 0;
  bool seen = false, missing_reported = false;
  TimeNs newest = kBeforeAll;  ///< newest accepted time
};

}  // namespace

const char* to_string(Stream s) { return fdv::to_string(kind(s)); }

struct NodeCore::Impl {
  NodeConfig config;
  NodeOutputs outputs;
  PerceptionOptions requested;
  std::optional<Calibration> calibration;

  std::unique_ptr<Perception> perception;
  bag::MessageDecoder decoder;
  ReadReport report;
  std::map<std::string, std::uint64_t> warned_drops;  ///< reason -> count already warned about
  SensorChunk chunk;

  // The merge: items held per stream until every awaited stream has passed their time.
  /// Held events, as the messages brought them (each non-decreasing in time, as the decoder's
  /// sanitizer leaves them); the first `events_released` of the front one have gone.
  std::deque<std::vector<Event>> events;
  std::size_t events_released = 0;
  std::deque<ImuSample> imu;
  std::deque<DepthFrame> depth;
  std::deque<OdometrySample> odometry;
  std::array<StreamHealth, 4> health;
  TimeNs first_t = kNever;          ///< first stamp of this run
  TimeNs newest_t = kBeforeAll;     ///< newest stamp of any stream
  TimeNs released_until = kBeforeAll;

  // Latency: the arrival of each event message, by the time its events reach.
  std::deque<std::pair<TimeNs, Clock::time_point>> arrivals;
  std::deque<double> latencies_ms;  ///< the last kLatencyWindows windows'
  bool finishing = false;  ///< inside finish(): the windows it closes have no latency
  std::uint64_t windows = 0, runs = 0;
  nlohmann::json finished_run = nlohmann::json::object();  ///< the pipeline's counters of the last run

  Impl(NodeConfig c, NodeOutputs o)
      : config(std::move(c)), outputs(std::move(o)), decoder(config.cdr ? bag::Dialect::kCdr : bag::Dialect::kRos1) {
    requested = load_options(config);
    if (!config.calibration_file.empty()) calibration = load_calibration(config.calibration_file);
    start_run(true);
  }

  void warn(const std::string& key, const std::string& message) {
    if (outputs.on_warning) outputs.on_warning(key, message);
  }

  bool subscribed(Stream s) const {
    switch (s) {
      case Stream::kEvents:
        return true;
      case Stream::kImu:
        return config.imu;
      case Stream::kDepth:
        return config.depth;
      case Stream::kOdometry:
        return config.odometry;
    }
    return false;
  }

  /// The sensor size from the calibration or the configuration; 0 x 0 when the events must say.
  std::pair<int, int> configured_size() const {
    if (calibration) return {calibration->event_camera.width, calibration->event_camera.height};
    return {std::max(config.width, 0), std::max(config.height, 0)};
  }

  /// Fresh state for a run. Its Perception is built now when `build` (at construction, so that a
  /// configuration the sensors cannot serve fails at once) or else with the run's first message
  /// (a Perception takes tens of ms to build: not at the end of the previous run).
  void start_run(bool build) {
    perception.reset();
    decoder = bag::MessageDecoder(config.cdr ? bag::Dialect::kCdr : bag::Dialect::kRos1);
    if (const auto [width, height] = configured_size(); width > 0 && height > 0) {
      decoder.set_sensor_size(width, height);
      decoder.require_event_message_size(width, height);
      if (build) make_perception(width, height);
    }
    events.clear(), imu.clear(), depth.clear(), odometry.clear(), arrivals.clear();
    events_released = 0;
    for (StreamHealth& h : health) h.newest = kBeforeAll, h.seen = false, h.missing_reported = false;
    first_t = kNever, newest_t = kBeforeAll, released_until = kBeforeAll;
    ++runs;
  }

  /// The sensor policy as `fdv run` applies it, with the subscribed topics as the declared streams.
  void make_perception(int width, int height) {
    DeclaredSensors declared;
    declared.imu = config.imu;
    declared.depth = config.depth;
    declared.odometry = config.odometry;
    declared.calibration = calibration;
    declared.width = width;
    declared.height = height;
    SensorPolicy policy = apply_sensor_policy(declared, requested);
    for (const std::string& w : policy.warnings) warn(w, w);
    PerceptionCallbacks callbacks;
    callbacks.on_window = [this](const WindowResult& w) { window(w); };
    callbacks.on_estimate = [this](const EstimateResult& e) { estimate(e); };
    callbacks.on_prediction = [this](const PredictionResult& p) {
      if (outputs.on_prediction) outputs.on_prediction(nlohmann::json(prediction_row(p)));
    };
    callbacks.on_dodge = [this](const DodgeDecision& d) {
      if (outputs.on_dodge) outputs.on_dodge(nlohmann::json(dodge_row(d)));
    };
    callbacks.on_warning = [this](const std::string& w) { warn(w, w); };
    perception = std::make_unique<Perception>(policy.calibration, policy.options, std::move(callbacks));
  }

  void window(const WindowResult& w) {
    ++windows;
    const Clock::time_point now = Clock::now();
    // The message that completed the window is the first whose events reach its end.
    while (arrivals.size() > 1 && arrivals.front().first < w.t_end) arrivals.pop_front();
    // A window closed by the end of input waited for that end, not for the pipeline: no latency.
    double latency_ms = std::numeric_limits<double>::quiet_NaN();
    if (!finishing && !arrivals.empty()) {
      latency_ms = std::chrono::duration<double, std::milli>(now - arrivals.front().second).count();
      latencies_ms.push_back(latency_ms);
      if (latencies_ms.size() > kLatencyWindows) latencies_ms.pop_front();
    }
    if (!outputs.on_window) return;
    WindowOutput out;
    out.window = window_row(w);
    out.tracks = tracks_json(perception->tracker(), w.t_end);
    out.index = w.index;
    out.processing_ms = w.timings.total_ms;
    out.latency_ms = latency_ms;
    outputs.on_window(out);
  }

  void estimate(const EstimateResult& e) {
    if (!outputs.on_estimate) return;
    nlohmann::json row = trajectory_row(e);
    nlohmann::json path = nlohmann::json::array();
    const BallisticTrajectory& trajectory = e.estimate->trajectory;
    const TimeNs step = std::max<TimeNs>(1, from_seconds(config.path_step_s));
    for (TimeNs t = e.estimate->t_last; t <= e.estimate->t_last + from_seconds(config.path_horizon_s); t += step) {
      const Eigen::Vector3d p = trajectory.position(t);
      path.push_back({to_seconds(t), p.x(), p.y(), p.z()});
    }
    row["path"] = std::move(path);
    outputs.on_estimate(row);
  }

  bool push(Stream stream, const std::string& datatype, const std::uint8_t* data, std::size_t size) {
    StreamHealth& h = health[index(stream)];
    ++h.messages;
    const std::string where = fmt::format("{} message {}", to_string(stream), h.messages);
    const bag::MessageType type = bag::message_type(datatype);
    chunk.clear();
    bool accepted = false;
    if (type == bag::MessageType::kUnsupported || !bag::can_feed(kind(stream), type, true)) {
      report.drop(fmt::format("{}: type {} is not one this stream takes", to_string(stream), datatype), where);
    } else {
      accepted = decoder.decode(kind(stream), type, data, size, std::nullopt, chunk, report, where);
    }
    warn_new_drops();
    if (!accepted) {
      ++h.dropped;
      return false;
    }
    if (!perception) {
      auto [width, height] = configured_size();
      if (width == 0 && stream == Stream::kEvents) {
        std::tie(width, height) = decoder.event_message_size();
        if (width <= 0 || height <= 0) {
          ++h.dropped;
          report.drop("events: no sensor size in the message and none configured", where);
          warn_new_drops();
          return false;
        }
        decoder.set_sensor_size(width, height);
        decoder.require_event_message_size(width, height);
      }
      if (width > 0 && height > 0) make_perception(width, height);
    }
    hold(stream);
    release(false);
    return true;
  }

  /// An item spanning [first, last] of `stream` arrived: the stream's progress, and lateness (the
  /// pipeline has already been given data past `first`: the item is used, but late).
  void note_time(Stream stream, TimeNs first, TimeNs last) {
    StreamHealth& h = health[index(stream)];
    h.seen = true;
    h.newest = std::max(h.newest, last);
    first_t = std::min(first_t, first);
    newest_t = std::max(newest_t, last);
    if (first < released_until) {
      ++h.late;
      warn(std::string("late ") + to_string(stream),
           fmt::format("{} arrived {:.1f} ms behind the streams already processed: used late ({} so far; a stream "
                       "lagging over {} s of stream time is not waited for)",
                       to_string(stream), to_seconds(released_until - first) * 1e3, h.late, config.max_hold_s));
    }
  }

  void hold(Stream stream) {
    switch (stream) {
      case Stream::kEvents:
        if (chunk.events.empty()) return;
        note_time(stream, chunk.events.front().t, chunk.events.back().t);
        arrivals.emplace_back(chunk.events.back().t, Clock::now());
        events.push_back(std::move(chunk.events));
        chunk.events.clear();
        break;
      case Stream::kImu:
        for (const ImuSample& s : chunk.imu) note_time(stream, s.t, s.t), imu.push_back(s);
        break;
      case Stream::kDepth:
        for (DepthFrame& f : chunk.depth) note_time(stream, f.t, f.t), depth.push_back(std::move(f));
        break;
      case Stream::kOdometry:
        for (const OdometrySample& s : chunk.odometry) note_time(stream, s.t, s.t), odometry.push_back(s);
        break;
    }
  }

  /// Every awaited stream has passed this time (stream time): what may be released.
  TimeNs horizon() {
    if (first_t == kNever) return kBeforeAll;  // nothing received yet
    TimeNs h = kNever;
    for (Stream s : kStreams) {
      if (!subscribed(s) || (s == Stream::kDepth && !config.wait_for_depth)) continue;
      StreamHealth& sh = health[index(s)];
      const TimeNs newest = sh.seen ? sh.newest : first_t;
      if (!sh.seen && !sh.missing_reported && newest_t - first_t > from_seconds(config.missing_after_s)) {
        sh.missing_reported = true;
        warn(std::string("missing ") + to_string(s),
             fmt::format("no {} message in the first {} s of stream time: not awaited while it is silent",
                         to_string(s), config.missing_after_s));
      }
      if (newest_t - newest > from_seconds(config.max_hold_s)) continue;  // silent: not awaited
      h = std::min(h, newest);
    }
    return h;
  }

  void release(bool all) {
    if (!perception) return;
    const TimeNs limit = all ? kNever : horizon();
    while (true) {
      // The earliest held item; ties in fdv run's merger order (events, IMU, depth, odometry).
      const std::array<TimeNs, 4> heads = {events.empty() ? kNever : events.front()[events_released].t,
                                           imu.empty() ? kNever : imu.front().t,
                                           depth.empty() ? kNever : depth.front().t,
                                           odometry.empty() ? kNever : odometry.front().t};
      const std::size_t best = std::min_element(heads.begin(), heads.end()) - heads.begin();
      if (heads[best] == kNever || heads[best] > limit) break;
      released_until = std::max(released_until, heads[best]);
      switch (best) {
        case 0: {
          const TimeNs others = std::min({limit, heads[1], heads[2], heads[3]});
          // The front message's events up to that time (at least one), handed over in place.
          const std::vector<Event>& front = events.front();
          const auto first = front.begin() + static_cast<std::ptrdiff_t>(events_released);
          auto last = std::upper_bound(first, front.end(), others, [](TimeNs t, const Event& e) { return t < e.t; });
          if (last == first) ++last;
          released_until = std::max(released_until, (last - 1)->t);
          perception->push_events(std::span<const Event>(&*first, static_cast<std::size_t>(last - first)));
          events_released = static_cast<std::size_t>(last - front.begin());
          if (events_released == front.size()) {
            events.pop_front();
            events_released = 0;
          }
          break;
        }
        case 1:
          perception->push_imu(imu.front());
          imu.pop_front();
          break;
        case 2:
          perception->push_depth(depth.front());
          depth.pop_front();
          break;
        case 3:
          perception->push_odometry(odometry.front());
          odometry.pop_front();
          break;
      }
    }
  }

  void warn_new_drops() {
    if (report.total_dropped() == 0) return;
    for (const auto& [reason, entry] : report.dropped()) {
      std::uint64_t& warned = warned_drops[reason];
      if (entry.count == warned) continue;
      warned = entry.count;
      warn(reason, fmt::format("dropped: {} ({} so far; first at {})", reason, entry.count, entry.first_where));
    }
  }

  void finish() {
    finishing = true;
    release(true);
    if (perception) {
      perception->finish();
      finished_run = counts_json(perception->counters());
    }
    finishing = false;
    start_run(false);
  }

  nlohmann::json diagnostics() const {
    nlohmann::json streams = nlohmann::json::object();
    for (Stream s : kStreams) {
      const StreamHealth& h = health[index(s)];
      streams[to_string(s)] = {{"subscribed", subscribed(s)},
                               {"messages", h.messages},
                               {"dropped", h.dropped},
                               {"late", h.late},
                               {"missing", h.missing_reported},
                               {"newest_t", h.seen ? nlohmann::json(to_seconds(h.newest)) : nlohmann::json(nullptr)}};
    }
    nlohmann::json d = {{"streams", streams}, {"windows", windows}, {"runs", runs}, {"dropped_by_reason", report.to_json()}};
    if (!latencies_ms.empty()) {
      const std::vector<double> recent(latencies_ms.begin(), latencies_ms.end());
      const Summary l = summarize(recent);
      d["latency_ms"] = {{"count", latencies_ms.size()}, {"median", l.median}, {"p99", l.p99}, {"max", l.max}};
    }
    d["pipeline"] = perception ? counts_json(perception->counters()) : finished_run;
    return d;
  }
};

NodeCore::NodeCore(NodeConfig config, NodeOutputs outputs)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(outputs))) {}
NodeCore::~NodeCore() = default;

bool NodeCore::push(Stream stream, const std::string& datatype, const std::uint8_t* data, std::size_t size) {
  return impl_->push(stream, datatype, data, size);
}
void NodeCore::finish() { impl_->finish(); }
nlohmann::json NodeCore::diagnostics() const { return impl_->diagnostics(); }

}  // namespace fdv::ros_core
