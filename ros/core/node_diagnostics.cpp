#include "node_diagnostics.h"

#include <fmt/format.h>

#include "fdv/results/schema.h"

namespace fdv::ros_core {

NodeDiagnostics::NodeDiagnostics(const NodeConfig& config, Warn warn) : warn_(std::move(warn)) {
  for (Stream s : kStreams) subscribed_[index(s)] = subscribed(config, s);
}

std::string NodeDiagnostics::received(Stream stream) {
  return fmt::format("{} message {}", to_string(stream), ++messages_[index(stream)]);
}

void NodeDiagnostics::warn_new_drops() {
  if (report_.total_dropped() == 0) return;
  for (const auto& [reason, entry] : report_.dropped()) {
    std::uint64_t& warned = warned_drops_[reason];
    if (entry.count == warned) continue;
    warned = entry.count;
    warn_(reason, fmt::format("dropped: {} ({} so far; first at {})", reason, entry.count,
                              entry.first_where));
  }
}

void NodeDiagnostics::run_finished(const Perception& perception) {
  finished_run_ = counts_json(perception.counters());
  report_.merge(perception.input_report());
}

nlohmann::json NodeDiagnostics::to_json(const StreamMerger& merger, const LatencyMeter& latency,
                                        const Perception* running) const {
  nlohmann::json streams = nlohmann::json::object();
  for (Stream s : kStreams) {
    const StreamMerger::Progress& p = merger.progress(s);
    streams[to_string(s)] = {
        {"subscribed", subscribed_[index(s)]},
        {"messages", messages_[index(s)]},
        {"dropped", dropped_[index(s)]},
        {"late", p.late},
        {"missing", p.missing},
        {"newest_t", p.seen ? nlohmann::json(to_seconds(p.newest)) : nlohmann::json(nullptr)}};
  }
  // The pipeline's own drops (Perception::input_report) beside the decoders': one report.
  ReadReport dropped = report_;
  if (running) dropped.merge(running->input_report());
  nlohmann::json d = {{"streams", streams},
                      {"windows", windows_},
                      {"runs", runs_},
                      {"dropped_by_reason", dropped.to_json()}};
  if (nlohmann::json l = latency.summary(); !l.is_null()) d["latency_ms"] = std::move(l);
  d["pipeline"] = running ? counts_json(running->counters()) : finished_run_;
  return d;
}

}  // namespace fdv::ros_core
