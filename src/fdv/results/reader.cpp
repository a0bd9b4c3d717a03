#include "fdv/results/reader.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/io/text_fields.h"

namespace fdv {
namespace {

/// The rows of a JSON-lines file; `required`: a missing file is an error (else no rows).
template <typename Row>
std::vector<Row> read_lines(const std::string& path, bool required) {
  std::ifstream in(path);
  std::vector<Row> out;
  if (!in) {
    if (required) throw InputError(path, "", "cannot open (run `fdv run ... --out DIR` first)");
    return out;
  }
  std::string line;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    try {
      out.push_back(nlohmann::json::parse(line).get<Row>());
    } catch (const std::exception& e) {  // nlohmann's, or a value the schema does not allow
      throw InputError(path, "line " + std::to_string(n), e.what());
    }
  }
  return out;
}

}  // namespace

std::vector<WindowRow> read_windows(const std::string& results_dir) {
  return read_lines<WindowRow>(results_dir + "/" + kDetectionsFile, true);
}

std::vector<DepthRow> read_depth(const std::string& results_dir) {
  return read_lines<DepthRow>(results_dir + "/" + kDepthFile, false);
}

std::vector<TrajectoryRow> read_trajectories(const std::string& results_dir) {
  const std::string path = results_dir + "/" + kTrajectoriesFile;
  std::vector<TrajectoryRow> rows = read_lines<TrajectoryRow>(path, false);
  for (std::size_t i = 0; i < rows.size(); ++i)
    if (rows[i].method != "fusion" && rows[i].method != "mono")
      throw InputError(path, "line " + std::to_string(i + 1),
                       "method '" + rows[i].method + "' is neither fusion nor mono");
  return rows;
}

std::vector<PredictionRow> read_predictions(const std::string& results_dir) {
  return read_lines<PredictionRow>(results_dir + "/" + kPredictionsFile, false);
}

std::vector<DodgeRow> read_dodge(const std::string& results_dir) {
  return read_lines<DodgeRow>(results_dir + "/" + kDodgeFile, false);
}

std::vector<DodgeRow> read_dodge_file(const std::string& path) { return read_lines<DodgeRow>(path, true); }

std::vector<TumPose> read_tum(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open");
  std::vector<TumPose> out;
  std::string line;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    std::istringstream fields(line);
    TumPose p;
    double q[4];
    if (!(fields >> p.t_s >> p.p_W.x() >> p.p_W.y() >> p.p_W.z() >> q[0] >> q[1] >> q[2] >> q[3]))
      throw InputError(path, "line " + std::to_string(n), "not 8 numbers (t x y z qx qy qz qw)");
    out.push_back(p);
  }
  return out;
}

RunSummary read_summary(const std::string& results_dir) {
  const std::string path = results_dir + "/" + kSummaryFile;
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open (run `fdv run ... --out DIR` first)");
  try {
    return nlohmann::json::parse(in).get<RunSummary>();
  } catch (const std::exception& e) {
    throw InputError(path, "", e.what());
  }
}

std::vector<WindowTimingRow> read_timing(const std::string& results_dir) {
  const std::string path = results_dir + "/" + kTimingFile;
  std::vector<WindowTimingRow> out;
  if (!std::filesystem::exists(path)) return out;
  LineReader in(path);
  std::string_view line;
  std::vector<std::string_view> cells;
  if (!in.next(line)) return out;
  split_fields(line, ',', cells);
  if (cells.size() < 2 || cells[0] != "window" || cells[1] != "t_start")
    throw InputError(path, in.where(), "header does not start with \"window,t_start\"");
  const std::vector<std::string> columns(cells.begin(), cells.end());
  while (in.next(line)) {
    split_fields(line, ',', cells);
    if (cells.size() != columns.size())
      throw InputError(path, in.where(),
                       fmt::format("{} cells, the header has {}", cells.size(), columns.size()));
    WindowTimingRow row;
    std::int64_t window = 0;
    if (!parse_int64(cells[0], window) || window < 0)
      throw InputError(path, in.where(), fmt::format("window '{}' is not an index", cells[0]));
    row.window = static_cast<std::uint64_t>(window);
    for (std::size_t c = 1; c < cells.size(); ++c) {
      if (cells[c].empty() && c > 1) continue;  // the stage did not run in this window
      double value = 0;
      if (!parse_double(cells[c], value))
        throw InputError(path, in.where(), fmt::format("{} '{}' is not a number", columns[c], cells[c]));
      (c == 1 ? row.t_start_s : row.stage_ms[columns[c]]) = value;
    }
    out.push_back(std::move(row));
  }
  return out;
}

std::vector<WindowDetections> window_detections(const std::vector<WindowRow>& rows) {
  std::vector<WindowDetections> out;
  out.reserve(rows.size());
  for (const WindowRow& r : rows) {
    WindowDetections w;
    w.t_start = from_seconds(r.t_start_s);
    w.t_end = from_seconds(r.t_end_s);
    w.status = r.status;
    for (const DetectionRow& d : r.detections)
      w.detections.push_back({from_seconds(d.t_s), d.center, d.track, d.partial,
                              d.visible_fraction, d.center_full});
    out.push_back(std::move(w));
  }
  return out;
}

std::vector<DodgeDecision> dodge_decisions(const std::vector<DodgeRow>& rows) {
  constexpr DodgeAction kActions[] = {DodgeAction::kDodge, DodgeAction::kReplan, DodgeAction::kCommit,
                                      DodgeAction::kCancel, DodgeAction::kRefused};
  std::vector<DodgeDecision> out;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const DodgeRow& r = rows[i];
    DodgeDecision d;
    const auto* action = std::find_if(std::begin(kActions), std::end(kActions),
                                      [&](DodgeAction a) { return r.action == to_string(a); });
    if (action == std::end(kActions))
      throw InputError(kDodgeFile, "line " + std::to_string(i + 1), "unknown action '" + r.action + "'");
    d.t = from_seconds(r.t_s);
    d.effective_t = from_seconds(r.effective_t_s);
    d.track_id = r.track;
    d.action = *action;
    d.probability = r.probability;
    d.time_to_contact_s = r.time_to_contact_s.value_or(std::numeric_limits<double>::infinity());
    d.miss_distance_m = r.miss_distance_m;
    d.committed = r.committed;
    d.reason = r.reason;
    if (const auto& m = r.maneuver)
      d.maneuver = DodgeManeuver{m->acceleration_W, from_seconds(m->start_t_s), m->duration_s,
                                 m->expected_clearance_m, m->probability_after};
    out.push_back(d);
  }
  return out;
}

std::vector<EstimateRecord> estimate_records(const std::vector<TrajectoryRow>& rows) {
  std::vector<EstimateRecord> out;
  for (const TrajectoryRow& r : rows) {
    if (!r.converged) continue;
    EstimateRecord e;
    e.usable = r.usable;
    e.track = r.track;
    e.mode = r.method == "fusion" ? EstimatorMode::kFusion : EstimatorMode::kMonocular;
    e.t = from_seconds(r.t_s);
    e.t_first = from_seconds(r.t_first_s);
    e.t_last = from_seconds(r.t_last_s);
    e.trajectory = {from_seconds(r.t0_s), r.p0_W, r.v0_W, r.gravity_W};
    out.push_back(e);
  }
  return out;
}

std::vector<WindowDetections> read_detections(const std::string& results_dir) {
  return window_detections(read_windows(results_dir));
}

std::vector<EstimateRecord> read_estimates(const std::string& results_dir) {
  return estimate_records(read_trajectories(results_dir));
}

}  // namespace fdv
