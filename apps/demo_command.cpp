// `fdv demo`: the built-in demo. Simulates the paper's real-world experiment (hover_headon: a
// 21 cm ball thrown head-on at a hovering drone), runs the whole pipeline on it, scores it against
// the exact ground truth and prints a short human summary.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "apps/evaluate.h"
#include "fdv/estimation/collision.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/results/reader.h"
#include "fdv/results/run.h"
#include "fdv/sim/dataset_cache.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/tables/closed_loop.h"
#include "fdv/tables/dodge_eval.h"
#include "fdv/tables/experiment.h"

namespace fdv::cli {
namespace {

struct DemoArgs {
  std::string out = "demo_out";
  std::string scenario = "hover_headon";
  std::uint64_t seed = 1;
  std::string config;  ///< `fdv run --config` YAML; empty = the defaults
  bool closed_loop = false;
};

void demo(const DemoArgs& args) {
  namespace fs = std::filesystem;
  const std::string dataset = (fs::path(args.out) / "dataset").string();
  const std::string results = (fs::path(args.out) / "results").string();
  const sim::ScenarioConfig config = sim::make_preset(args.scenario, args.seed);
  const PerceptionOptions options = args.config.empty() ? PerceptionOptions{} : load_perception_options_file(args.config);
  if (args.closed_loop) {
    // The pipeline runs inside the simulation and the vehicle flies its decisions: the dataset
    // written is the flown one (never a cached open-loop one: the folder is replaced).
    fs::remove_all(dataset);
    fly_with_perception(config, options, dataset, results);
  } else {
    // Simulated again only when the folder does not hold this scenario and seed already.
    sim::ensure_simulated(config, dataset);
    PerceptionCallbacks also;
    also.on_warning = [](const std::string& w) { spdlog::warn("{}", w); };
    RunRequest request;
    request.input = dataset;
    request.options = options;
    RecordingRun(std::move(request)).into(results, also);
  }
  const nlohmann::json metrics = evaluate(results, dataset);
  const DatasetTruth truth = load_dataset_truth(dataset);
  // What would have happened without a dodge: the truth itself open loop; the path flown without
  // commands in the closed loop.
  const DatasetTruth unflown = args.closed_loop ? fly_decisions(config, truth, {}) : truth;

  std::cout << "\nfast-dynamic-vision demo: " << args.scenario << ", seed " << args.seed
            << (args.closed_loop ? " (closed loop: the drone flies its decisions, its sensors see it)" : "") << "\n";
  const auto& det = metrics["detection"];
  std::cout << fmt::format(
      "  detection recall {:.0f} % of eligible windows, median centre error {:.1f} px, "
      "{:.2f} false detections per window\n",
      100 * det["recall"].get<double>(), det["median_center_error_px"].get<double>(),
      det["false_detections_per_window"].get<double>());
  if (!truth.radius_m.empty()) {
    // When the ball was released / came into view (truth), and when it was first estimated in 3D.
    const int ball = truth.radius_m.begin()->first;
    const std::vector<WindowDetections> windows = read_detections(results);
    const BallEstimateTiming timing = ball_estimate_timing(truth, windows, read_estimates(results), ball);
    if (timing.in_flight_from)
      std::cout << fmt::format("  ball in flight and in view from   t = {:.3f} s\n",
                               to_seconds(*timing.in_flight_from));
    if (const auto first = first_ball_detection(truth, windows, ball)) {
      const std::string after =
          timing.in_flight_from
              ? fmt::format(" ({:.0f} ms after it was in flight and in view)",
                            1e3 * to_seconds(first->window_end - *timing.in_flight_from))
              : std::string();
      std::cout << fmt::format("  first detected at                t = {:.3f} s{}\n", to_seconds(first->window_end), after);
    } else {
      std::cout << "  the ball was never detected\n";
    }
    if (timing.first) {
      const auto latency = timing.latency_s();
      std::cout << fmt::format(
          "  first usable 3D estimate at      t = {:.3f} s ({})\n", to_seconds(timing.first->t),
          latency ? fmt::format("{:.0f} ms after it was in flight and in view", 1e3 * *latency)
                  : std::string("ball never fully in view"));
    } else {
      std::cout << "  no usable 3D estimate of the ball\n";
    }
    if (timing.closest) {
      std::cout << fmt::format("  true closest approach {:.3f} m at t = {:.3f} s\n",
                               timing.closest->distance_m, to_seconds(timing.closest->t));
      if (timing.first_error_m && timing.final_error_m)
        std::cout << fmt::format(
            "  position error there: {:.3f} m from the first usable estimate, {:.3f} m from the "
            "final one\n",
            *timing.first_error_m, *timing.final_error_m);
    }
  }
  const std::vector<PredictionRow> predictions = read_predictions(results);
  const double safety_radius_m = PredictionOptions{}.safety_radius_m;
  if (!predictions.empty()) {
    const PredictionRow& p = predictions.back();
    std::cout << fmt::format("  predicted miss distance {:.3f} m at t = {:.3f} s (last prediction, made at t = {:.3f} s)\n",
                             p.miss_distance_m, p.closest_t_s, p.t_s);
    if (p.time_to_contact_s)
      std::cout << fmt::format("  predicted contact with the {} m safety sphere at t = {:.3f} s\n", safety_radius_m,
                               p.t_s + *p.time_to_contact_s);
    else
      std::cout << fmt::format("  predicted to pass outside the {} m safety sphere\n", safety_radius_m);
  }
  std::optional<TimeNs> contact;
  if (!truth.radius_m.empty()) {
    contact = true_contact_time(unflown, truth.radius_m.begin()->first, safety_radius_m);
    if (contact)
      std::cout << fmt::format("  true contact with the {} m safety sphere at t = {:.3f} s\n", safety_radius_m,
                               to_seconds(*contact));
    else
      std::cout << fmt::format("  truth: the ball stays outside the {} m safety sphere\n", safety_radius_m);
  }
  // The dodge (docs/AVOIDANCE.md): the first decision to act, and the truth flown with it.
  const std::vector<DodgeDecision> decisions = dodge_decisions(read_dodge(results));
  const auto first = std::find_if(decisions.begin(), decisions.end(),
                                  [](const DodgeDecision& d) { return d.action == DodgeAction::kDodge; });
  if (first == decisions.end()) {
    std::cout << "  no dodge decided\n";
  } else {
    const Eigen::Vector3d& a = first->maneuver->acceleration_W;
    std::cout << fmt::format("  dodge decided at t = {:.3f} s{}: P(contact) {:.2f}, accelerate ({:.1f}, {:.1f}, {:.1f}) "
                             "m/s² for {:.2f} s ({})\n",
                             to_seconds(first->t),
                             contact ? fmt::format(", {:.0f} ms before the true contact", 1e3 * to_seconds(*contact - first->t))
                                     : std::string(),
                             first->probability, a.x(), a.y(), a.z(), first->maneuver->duration_s,
                             decisions.size() == 1 ? std::string("1 decision") : fmt::format("{} decisions", decisions.size()));
  }
  if (!truth.radius_m.empty() && first != decisions.end()) {
    const int ball = truth.radius_m.begin()->first;
    const DodgeOutcome flown = dodge_outcome(truth, ball, decisions, safety_radius_m, !args.closed_loop);
    std::cout << fmt::format("  {}, the true closest approach is {:.3f} m ({:.3f} m without the dodge): {}\n",
                             args.closed_loop ? "flown in the loop" : "replaying the set-points kinematically",
                             flown.miss_with_maneuver_m, dodge_outcome(unflown, ball, {}, safety_radius_m).miss_with_maneuver_m,
                             flown.miss_with_maneuver_m >= safety_radius_m ? "outside the safety sphere"
                                                                          : "still inside the safety sphere");
  }
  for (const auto& a : metrics["ape"])
    std::cout << fmt::format(
        "  APE of track {} ({}): RMSE {:.3f} m, max {:.3f} m over {:.3f}-{:.3f} s{}\n",
        a["track"].get<int>(), a["method"].get<std::string>(), a["rmse"].get<double>(),
        a["max"].get<double>(), a["t_first"].get<double>(), a["t_last"].get<double>(),
        a.value("usable", true) ? ""
                                : " (its final fit, flagged not usable: position too uncertain"
                                  " 0.5 s ahead)");
  std::cout << "  outputs: " << results
            << " (detections, depth, trajectories, predictions, dodge, metrics)\n";
  // The plots are Python's (python/fdv/report.py), built beside the program as build/python/fdv.
  std::cout << fmt::format("  plots: PYTHONPATH=build/python /usr/bin/python3 -m fdv.report {} --truth {}\n"
                           "         (writes {}/report/report.html)\n",
                           results, dataset, results);
}

}  // namespace

void add_demo_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "demo", "simulate a ball thrown at a hovering drone, run everything, print a summary");
  static DemoArgs args;
  cmd->add_option("--out", args.out, "folder for the simulated dataset and the results")
      ->capture_default_str();
  cmd->add_option("--scenario", args.scenario, "simulator preset")->capture_default_str();
  cmd->add_option("--seed", args.seed, "random seed")->capture_default_str();
  cmd->add_option("--config", args.config, "YAML options of the pipeline (as `fdv run --config`)");
  cmd->add_flag("--closed-loop", args.closed_loop,
                "run the pipeline inside the simulation and fly its decisions (the sensors see the dodge)");
  cmd->callback([] { demo(args); });
}

}  // namespace fdv::cli
