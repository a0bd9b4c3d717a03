// `fdv eval RESULTS_DIR --truth DATASET`: scores a `fdv run` against a simulated dataset's ground
// truth and writes RESULTS_DIR/metrics.json: detection metrics (Table I's, and per apparent-size
// bin, for balls cut by the border and per ball: `objects`), relative contrast η (paper §V-B),
// APE of each track's final estimate (paper Table II), and the prediction error at the true
// closest-approach time as a function of the time since the track's first detection.
#include <spdlog/spdlog.h>

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "apps/evaluate.h"
#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/eval/statistics.h"
#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/results/reader.h"
#include "fdv/tables/experiment.h"

namespace fdv::cli {
namespace {

const char* mode_name(EstimatorMode m) { return m == EstimatorMode::kFusion ? "fusion" : "mono"; }

/// η of the run's compensation method, re-run in memory (the results folder has no images).
nlohmann::json relative_contrast_of(const DatasetTruth& truth, const std::string& method) {
  ExperimentOptions options;
  options.perception.compensation.method = *parse_compensation_method(method);
  options.relative_contrast = true;
  const Summary s = summarize(run_experiment(truth, options).relative_contrast);
  return {
      {"method", method}, {"windows", s.count}, {"min", s.min}, {"mean", s.mean}, {"max", s.max}};
}

/// The truth must be of the scene the results were run on: the same camera size, and the same
/// dataset.yaml when the run's input is still there. Scoring another scene gives figures that
/// look like results.
void require_same_scene(const RunSummary& summary, const DatasetTruth& truth, const std::string& dataset) {
  const PinholeCamera& camera = truth.calibration.event_camera;
  if (summary.width != camera.width || summary.height != camera.height)
    throw InputError(dataset, "",
                     fmt::format("its camera is {}x{}, the results' {}x{}: not the scene the results were run on",
                                 camera.width, camera.height, summary.width, summary.height));
  namespace fs = std::filesystem;
  const fs::path ran_on = fs::path(summary.input) / kDatasetManifest, given = fs::path(dataset) / kDatasetManifest;
  std::error_code ec;
  if (fs::is_regular_file(ran_on, ec) && fs::is_regular_file(given, ec) &&
      read_config_file(ran_on.string()) != read_config_file(given.string()))
    throw InputError(dataset, "", "not the dataset the results were run on (" + summary.input + ")");
}

}  // namespace

nlohmann::json evaluate(const std::string& results, const std::string& dataset) {
  const DatasetTruth truth = load_dataset_truth(dataset);
  const RunSummary summary = read_summary(results);
  require_same_scene(summary, truth, dataset);
  nlohmann::json metrics;
  metrics["results"] = results;
  metrics["truth"] = dataset;
  metrics["scenario"] = truth.scenario;
  const std::vector<WindowDetections> windows = read_detections(results);
  const DetectionMetrics detection = detection_metrics(truth, windows);
  metrics["detection"] = detection.to_json();
  metrics["objects"] = detection.objects_json();
  {
    std::ofstream csv(results + "/detection_windows.csv");
    write_window_outcomes_csv(csv, detection.per_window);
    if (!csv) throw InputError(results + "/detection_windows.csv", "", "cannot write");
    std::ofstream pairs(results + "/detection_pairs.csv");
    write_pair_outcomes_csv(pairs, detection.per_pair);
    if (!pairs) throw InputError(results + "/detection_pairs.csv", "", "cannot write");
  }
  metrics["relative_contrast"] =
      relative_contrast_of(truth, summary.method);

  // APE of each (track, method)'s final converged estimate over its observed interval (Table II).
  const std::vector<EstimateRecord> estimates = read_estimates(results);
  metrics["ape"] = nlohmann::json::array();
  for (const auto& [key, e] : final_estimates(estimates)) {
    const int id = match_object(truth, e);
    if (id < 0) continue;
    const Summary s = summarize(ape_samples(truth, e, id));
    metrics["ape"].push_back({{"track", key.first},
                              {"method", mode_name(key.second)},
                              {"object", id},
                              {"t_first", to_seconds(e.t_first)},
                              {"t_last", to_seconds(e.t_last)},
                              {"mean", s.mean},
                              {"min", s.min},
                              {"max", s.max},
                              {"rmse", s.rmse},
                              {"samples", s.count},
                              {"usable", e.usable}});
  }

  // Prediction error at the true closest approach vs time since the track's first detection (the
  // earliest detection assigned to it; its estimates' earliest observation if none is listed).
  std::map<int, TimeNs> first_detection;
  for (const WindowDetections& w : windows)
    for (const WindowDetections::Det& d : w.detections)
      if (d.track >= 0 && (!first_detection.count(d.track) || d.t < first_detection[d.track]))
        first_detection[d.track] = d.t;
  for (const EstimateRecord& e : estimates)
    if (!first_detection.count(e.track)) first_detection[e.track] = e.t_first;
  metrics["prediction_error"] = nlohmann::json::array();
  for (const EstimateRecord& e : estimates) {
    const int id = match_object(truth, e);
    if (id < 0) continue;
    const auto closest = true_closest_approach(truth, id);
    const auto error = closest ? prediction_error(truth, e, id, closest->t) : std::nullopt;
    if (!error) continue;
    metrics["prediction_error"].push_back(
        {{"track", e.track},
         {"method", mode_name(e.mode)},
         {"since_first_detection_s", to_seconds(e.t - first_detection[e.track])},
         {"t_closest_true", to_seconds(closest->t)},
         {"error_m", *error},
         {"usable", e.usable}});
  }
  std::ofstream(results + "/metrics.json") << metrics.dump(2) << "\n";
  spdlog::info("metrics written to {}/metrics.json", results);
  return metrics;
}

void add_eval_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "eval", "score a `fdv run` output against a simulated dataset's ground truth");
  static std::string results, truth;
  cmd->add_option("results", results, "output folder of `fdv run`")->required();
  cmd->add_option("--truth", truth, "the simulated dataset folder the run was made on")->required();
  cmd->callback([] { std::cout << evaluate(results, truth)["detection"].dump() << "\n"; });
}

}  // namespace fdv::cli
