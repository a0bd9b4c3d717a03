#include "fdv/results/writer.h"

#include <fmt/format.h>

#include "fdv/core/error.h"

namespace fdv {

ResultsWriter::ResultsWriter(const std::filesystem::path& dir) : dir_(dir), timing_stages_(window_timing_stages()) {
  std::filesystem::create_directories(dir);
  for (auto [name, stream] : row_files()) {
    stream->open(dir / name);
    if (!*stream) throw InputError((dir / name).string(), "", "cannot create output file");
  }
  timing_csv_ << "window,t_start";
  for (const std::string& stage : timing_stages_) timing_csv_ << "," << stage;
  timing_csv_ << "\n";
}

std::array<std::pair<const char*, std::ofstream*>, 6> ResultsWriter::row_files() {
  return {{{kDetectionsFile, &detections_},
           {kDepthFile, &depth_},
           {kTrajectoriesFile, &trajectories_},
           {kPredictionsFile, &predictions_},
           {kDodgeFile, &dodge_},
           {kTimingFile, &timing_csv_}}};
}

void ResultsWriter::write(const WindowRow& row) { detections_ << nlohmann::json(row).dump() << "\n"; }
void ResultsWriter::write(const DepthRow& row) { depth_ << nlohmann::json(row).dump() << "\n"; }
void ResultsWriter::write(const TrajectoryRow& row) { trajectories_ << nlohmann::json(row).dump() << "\n"; }
void ResultsWriter::write(const PredictionRow& row) { predictions_ << nlohmann::json(row).dump() << "\n"; }
void ResultsWriter::write(const DodgeRow& row) { dodge_ << nlohmann::json(row).dump() << "\n"; }

void ResultsWriter::write(const WindowTimingRow& row) {
  // fmt's "{}" is the shortest text that reads back to the same double.
  timing_csv_ << fmt::format("{},{}", row.window, row.t_start_s);
  for (const std::string& stage : timing_stages_) {
    const auto it = row.stage_ms.find(stage);
    timing_csv_ << (it == row.stage_ms.end() ? "," : fmt::format(",{}", it->second));
  }
  timing_csv_ << "\n";
  for (const auto& [stage, ms] : row.stage_ms) timing_[stage].push_back(ms);
}

void ResultsWriter::window(const WindowResult& w) {
  write(window_row(w));
  write(window_timing_row(w));
}

void ResultsWriter::depth(const DepthResult& d) {
  write(depth_row(d));
  timing_["depth_segmentation"].push_back(d.ms);
}

void ResultsWriter::estimate(const EstimateResult& e) {
  write(trajectory_row(e));
  const bool fusion = e.mode == EstimatorMode::kFusion;
  timing_[fusion ? "estimation_fusion" : "estimation_mono"].push_back(e.ms);
  if (e.estimate->usable) (fusion ? final_fusion_ : final_mono_)[e.track_id] = *e.estimate;
}

void ResultsWriter::prediction(const PredictionResult& p) { write(prediction_row(p)); }
void ResultsWriter::dodge(const DodgeDecision& d) { write(dodge_row(d)); }

std::map<std::string, Summary> ResultsWriter::timing_ms() const {
  std::map<std::string, Summary> out;
  for (const auto& [stage, values] : timing_) out[stage] = summarize(values);
  return out;
}

void ResultsWriter::finish(const RunSummary& summary) {
  for (auto [name, stream] : row_files()) {
    stream->close();
    if (!*stream) throw InputError((dir_ / name).string(), "", "write failed (disk full?)");
  }
  for (const auto& [name, finals] : {std::pair{"fusion", &final_fusion_}, {"mono", &final_mono_}})
    for (const auto& [id, est] : *finals) {
      std::ofstream f(dir_ / fmt::format("track_{}_{}.tum", id, name));
      for (TimeNs t = est.t_first; t <= est.t_last; t += 5 * kNsPerMs) {
        const Eigen::Vector3d p = est.trajectory.position(t);
        f << fmt::format("{:.9f} {:.6f} {:.6f} {:.6f} 0 0 0 1\n", to_seconds(t), p.x(), p.y(), p.z());
      }
    }
  // A path that is not UTF-8 (a folder named in another encoding) is written with U+FFFD in its
  // place: JSON holds only UTF-8, and the summary must not be lost for a name.
  const std::string text = nlohmann::json(summary).dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
  std::ofstream summary_file(dir_ / kSummaryFile);
  summary_file << text << "\n";
  summary_file.close();
  if (!summary_file) throw InputError((dir_ / kSummaryFile).string(), "", "write failed (disk full?)");
}

}  // namespace fdv
