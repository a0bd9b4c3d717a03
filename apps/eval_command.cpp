// `fdv eval RESULTS_DIR --truth DATASET`: scores a `fdv run` against a simulated dataset's ground
// truth and writes RESULTS_DIR/metrics.json: detection metrics, relative contrast η (paper eq. 17),
// APE of each track's final estimate (paper Table II), and the prediction error at the true
// closest-approach time as a function of the time since the track's first detection.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "apps/experiment.h"
#include "fdv/core/error.h"
#include "fdv/eval/relative_contrast.h"
#include "fdv/eval/statistics.h"
#include "fdv/eval/trajectory_error.h"

namespace fdv::cli {
namespace {

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, "", e.what());
  }
}

struct Estimate {
  int track = -1;
  std::string method;
  TimeNs t = 0, t_first = 0, t_last = 0;
  BallisticTrajectory trajectory;
};

std::vector<Estimate> read_estimates(const std::string& dir) {
  const std::string path = dir + "/trajectories.jsonl";
  std::ifstream in(path);
  std::vector<Estimate> out;
  if (!in) return out;
  std::string line;
  auto vec = [](const nlohmann::json& j) { return Eigen::Vector3d(j[0], j[1], j[2]); };
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    try {
      const auto j = nlohmann::json::parse(line);
      if (!j.at("usable").get<bool>()) continue;
      Estimate e;
      e.track = j.at("track");
      e.method = j.at("method");
      e.t = from_seconds(j.at("t").get<double>());
      e.t_first = from_seconds(j.at("t_first").get<double>());
      e.t_last = from_seconds(j.at("t_last").get<double>());
      e.trajectory = {from_seconds(j.at("t0").get<double>()), vec(j.at("p0")), vec(j.at("v0")), vec(j.at("gravity"))};
      out.push_back(e);
    } catch (const nlohmann::json::exception& ex) {
      throw InputError(path, "line " + std::to_string(n), ex.what());
    }
  }
  return out;
}

/// The ball a trajectory estimate follows: the one closest to it on average over its interval.
int match_object(const DatasetTruth& truth, const Estimate& e) {
  int best = -1;
  double best_err = std::numeric_limits<double>::infinity();
  for (const auto& [id, r] : truth.radius_m) {
    const Summary s = absolute_position_error([&](TimeNs t) { return e.trajectory.position(t); }, truth.objects,
                                              id, e.t_first, e.t_last);
    if (s.count && s.mean < best_err) best_err = s.mean, best = id;
  }
  return best;
}

/// Time of the true closest approach of ball `id` to the vehicle body origin.
std::optional<TimeNs> true_closest_approach(const DatasetTruth& truth, int id) {
  std::optional<TimeNs> best;
  double best_d = std::numeric_limits<double>::infinity();
  for (const ObjectState& s : truth.objects) {
    if (s.id != id || s.t < truth.body.front().t || s.t > truth.body.back().t) continue;
    const double d = (s.p_W - truth.body_at(s.t).p_W_B).norm();
    if (d < best_d) best_d = d, best = s.t;
  }
  return best;
}

nlohmann::json relative_contrast_of(const DatasetTruth& truth, const std::string& method) {
  PerceptionOptions options;
  options.compensation.method = method;
  std::vector<double> etas;
  PerceptionCallbacks callbacks;
  callbacks.on_window = [&](const WindowResult& w) {
    for (const auto& [id, r] : truth.radius_m) {
      const cv::Rect M = undistorted_truth_rect(truth, id, w.t_start, w.t_end - 1);
      if (M.area() == 0) continue;
      const cv::Mat clean = denoise_for_contrast(w.detector->time_images().mean_time_s);
      if (const auto eta = relative_contrast(clean, M)) etas.push_back(*eta);
    }
  };
  replay(open_recording(truth.dir), truth.calibration, options, callbacks);
  const Summary s = summarize(etas);
  return {{"method", method}, {"windows", s.count}, {"min", s.min}, {"mean", s.mean}, {"max", s.max}};
}

}  // namespace

nlohmann::json evaluate(const std::string& results, const std::string& dataset) {
  const DatasetTruth truth = load_dataset_truth(dataset);
  const nlohmann::json summary = read_json_file(results + "/summary.json");
  nlohmann::json metrics;
  metrics["results"] = results;
  metrics["truth"] = dataset;
  metrics["scenario"] = truth.scenario;
  metrics["detection"] = detection_metrics(truth, read_detections(results)).to_json();
  metrics["relative_contrast"] = relative_contrast_of(truth, summary.value("method", "rotation_translation"));

  // APE of each (track, method)'s final usable estimate over its observed interval.
  const std::vector<Estimate> estimates = read_estimates(results);
  std::map<std::pair<int, std::string>, Estimate> finals;
  for (const Estimate& e : estimates) finals[{e.track, e.method}] = e;
  metrics["ape"] = nlohmann::json::array();
  for (const auto& [key, e] : finals) {
    const int id = match_object(truth, e);
    if (id < 0) continue;
    const Summary s = absolute_position_error([&](TimeNs t) { return e.trajectory.position(t); }, truth.objects, id,
                                              e.t_first, e.t_last);
    metrics["ape"].push_back({{"track", key.first}, {"method", key.second}, {"object", id},
                              {"t_first", to_seconds(e.t_first)}, {"t_last", to_seconds(e.t_last)},
                              {"mean", s.mean}, {"min", s.min}, {"max", s.max}, {"rmse", s.rmse},
                              {"samples", s.count}});
  }

  // Prediction error at the true closest approach vs time since the track's first detection.
  std::map<int, TimeNs> first_detection;
  for (const Estimate& e : estimates)
    if (!first_detection.count(e.track) || e.t_first < first_detection[e.track]) first_detection[e.track] = e.t_first;
  metrics["prediction_error"] = nlohmann::json::array();
  for (const Estimate& e : estimates) {
    const int id = match_object(truth, e);
    if (id < 0) continue;
    const auto t_ca = true_closest_approach(truth, id);
    const auto s = t_ca ? truth.object_at(id, *t_ca) : std::nullopt;
    if (!s) continue;
    metrics["prediction_error"].push_back({{"track", e.track}, {"method", e.method},
                                           {"since_first_detection_s", to_seconds(e.t - first_detection[e.track])},
                                           {"t_closest_true", to_seconds(*t_ca)},
                                           {"error_m", (e.trajectory.position(*t_ca) - s->p_W).norm()}});
  }
  std::ofstream(results + "/metrics.json") << metrics.dump(2) << "\n";
  spdlog::info("metrics written to {}/metrics.json", results);
  return metrics;
}

void add_eval_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("eval", "score a `fdv run` output against a simulated dataset's ground truth");
  static std::string results, truth;
  cmd->add_option("results", results, "output folder of `fdv run`")->required();
  cmd->add_option("--truth", truth, "the simulated dataset folder the run was made on")->required();
  cmd->callback([] { std::cout << evaluate(results, truth)["detection"].dump() << "\n"; });
}

}  // namespace fdv::cli
