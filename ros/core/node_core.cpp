#include "node_core.h"

#include <fmt/format.h>

#include <algorithm>
#include <tuple>

#include "fdv/core/time.h"
#include "fdv/io/rosbag/message_decoder.h"
#include "fdv/pipeline/perception.h"
#include "fdv/results/schema.h"
#include "latency_meter.h"
#include "node_diagnostics.h"
#include "run_setup.h"
#include "stream_merger.h"
#include "streams.h"

namespace fdv::ros_core {
namespace {

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

}  // namespace

const char* to_string(Stream s) { return fdv::to_string(kind(s)); }

/// Composes the node's jobs: RunSetup starts each run, NodeDiagnostics counts, StreamMerger puts
/// the streams into time order, LatencyMeter times the windows. What remains here is the run in
/// progress and turning the pipeline's results into the node's outputs.
struct NodeCore::Impl {
  NodeOutputs outputs;
  TimeNs path_step, path_horizon;
  RunSetup setup;
  NodeDiagnostics diagnostics;
  StreamMerger merger;
  LatencyMeter latency;

  // The run in progress.
  bag::MessageDecoder decoder;
  /// Built at construction when the sensor size is configured (so that a configuration the
  /// sensors cannot serve fails at once), else with the run's first message that tells the size
  /// (a Perception takes tens of ms to build: not at the end of the previous run).
  std::unique_ptr<Perception> perception;
  SensorChunk chunk;  ///< the message being decoded

  Impl(const NodeConfig& config, NodeOutputs o)
      : outputs(std::move(o)),
        path_step(std::max<TimeNs>(1, from_seconds(config.path_step_s))),
        path_horizon(from_seconds(config.path_horizon_s)),
        setup(config),
        diagnostics(config, warning_output()),
        merger(config, warning_output()),
        decoder(setup.new_decoder()) {
    start_run(true);
  }

  /// Warnings of the pieces, to NodeOutputs::on_warning.
  Warn warning_output() {
    return [this](const std::string& key, const std::string& message) {
      if (outputs.on_warning) outputs.on_warning(key, message);
    };
  }

  /// Fresh state for a run; its Perception now only when `build`.
  void start_run(bool build) {
    perception.reset();
    decoder = setup.new_decoder();
    merger.clear();
    latency.new_run();
    diagnostics.run_started();
    if (const auto [width, height] = setup.configured_size(); build && width > 0 && height > 0)
      make_perception(width, height);
  }

  void make_perception(int width, int height) {
    PerceptionCallbacks callbacks;
    callbacks.on_window = [this](const WindowResult& w) { window(w); };
    callbacks.on_estimate = [this](const EstimateResult& e) { estimate(e); };
    callbacks.on_prediction = [this](const PredictionResult& p) {
      if (outputs.on_prediction) outputs.on_prediction(nlohmann::json(prediction_row(p)));
    };
    callbacks.on_dodge = [this](const DodgeDecision& d) {
      if (outputs.on_dodge) outputs.on_dodge(nlohmann::json(dodge_row(d)));
    };
    const Warn warn = warning_output();
    callbacks.on_warning = [warn](const std::string& w) { warn(w, w); };
    perception = setup.new_perception(width, height, std::move(callbacks), warn);
  }

  /// The run's Perception once the sensor size is known: configured, or from the first event
  /// message (then required of the later ones). False when an event message cannot tell it.
  bool ensure_perception(Stream stream, const std::string& where) {
    if (perception) return true;
    auto [width, height] = setup.configured_size();
    if (width == 0 && stream == Stream::kEvents) {
      std::tie(width, height) = decoder.event_message_size();
      if (width <= 0 || height <= 0) {
        diagnostics.report().drop("events: no sensor size in the message and none configured",
                                  where);
        diagnostics.warn_new_drops();
        return false;
      }
      decoder.set_sensor_size(width, height);
      decoder.require_event_message_size(width, height);
    }
    if (width > 0 && height > 0) make_perception(width, height);
    return true;
  }

  bool push(Stream stream, const std::string& datatype, const std::uint8_t* data,
            std::size_t size) {
    const std::string where = diagnostics.received(stream);
    const bag::MessageType type = bag::message_type(datatype);
    chunk.clear();
    bool accepted = false;
    if (type == bag::MessageType::kUnsupported || !bag::can_feed(kind(stream), type, true)) {
      diagnostics.report().drop(
          fmt::format("{}: type {} is not one this stream takes", to_string(stream), datatype),
          where);
    } else {
      accepted = decoder.decode(kind(stream), type, data, size, std::nullopt, chunk,
                                diagnostics.report(), where);
    }
    diagnostics.warn_new_drops();
    if (!accepted || !ensure_perception(stream, where)) {
      diagnostics.dropped(stream);
      return false;
    }
    if (!chunk.events.empty()) latency.arrived(chunk.events.back().t);
    merger.hold(stream, chunk);
    if (perception) merger.release(*perception, false);
    return true;
  }

  void finish() {
    latency.end_of_input();
    if (perception) {
      merger.release(*perception, true);
      perception->finish();
      diagnostics.run_finished(*perception);
    }
    start_run(false);
  }

  void window(const WindowResult& w) {
    diagnostics.window_done();
    const double latency_ms = latency.window_done(w.t_end);
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
    for (TimeNs t = e.estimate->t_last; t <= e.estimate->t_last + path_horizon; t += path_step) {
      const Eigen::Vector3d p = trajectory.position(t);
      path.push_back({to_seconds(t), p.x(), p.y(), p.z()});
    }
    row["path"] = std::move(path);
    outputs.on_estimate(row);
  }
};

NodeCore::NodeCore(NodeConfig config, NodeOutputs outputs)
    : impl_(std::make_unique<Impl>(config, std::move(outputs))) {}
NodeCore::~NodeCore() = default;

bool NodeCore::push(Stream stream, const std::string& datatype, const std::uint8_t* data,
                    std::size_t size) {
  return impl_->push(stream, datatype, data, size);
}
void NodeCore::finish() { impl_->finish(); }
nlohmann::json NodeCore::diagnostics() const {
  return impl_->diagnostics.to_json(impl_->merger, impl_->latency, impl_->perception.get());
}

}  // namespace fdv::ros_core
