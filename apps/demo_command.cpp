// `fdv demo`: the built-in demo. Simulates the paper's real-world experiment (hover_headon: a
// 21 cm ball thrown head-on at a hovering drone), runs the whole pipeline on it, scores it against
// the exact ground truth and prints a short human summary.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "apps/experiment.h"
#include "fdv/estimation/collision.h"
#include "fdv/eval/ground_truth_box.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/simulator.h"

namespace fdv::cli {
namespace {

struct DemoArgs {
  std::string out = "demo_out";
  std::string scenario = "hover_headon";
  std::uint64_t seed = 1;
};

std::vector<nlohmann::json> read_lines(const std::string& path) {
  std::vector<nlohmann::json> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) out.push_back(nlohmann::json::parse(line));
  return out;
}

void demo(const DemoArgs& args) {
  namespace fs = std::filesystem;
  const std::string dataset = (fs::path(args.out) / "dataset").string();
  const std::string results = (fs::path(args.out) / "results").string();
  fs::remove_all(dataset);
  {
    sim::Simulator simulator(sim::make_preset(args.scenario, args.seed));
    sim::DatasetSink sink(dataset, simulator.calibration());
    spdlog::info("simulating '{}' (seed {}) into {}", args.scenario, args.seed, dataset);
    simulator.run(sink);
    sink.finish(simulator.manifest_yaml());
  }
  RunArgs run;
  run.input = dataset;
  run.out = results;
  run_recording(run);
  const nlohmann::json metrics = evaluate(results, dataset);
  const DatasetTruth truth = load_dataset_truth(dataset);
  const int ball = truth.radius_m.begin()->first;

  // When the ball entered the view (truth), was first detected, and first estimated in 3D.
  std::optional<TimeNs> in_view;
  for (TimeNs t = truth.body.front().t; t < truth.body.back().t && !in_view; t += kNsPerMs) {
    const GroundTruthBox b = ground_truth_box(truth.objects, ball, truth.radius_m.at(ball), truth.body,
                                              truth.calibration, t, t);
    const auto s = truth.object_at(ball, t);
    const bool moving = s && s->v_W.norm() > 1.0;  // thrown, not yet held or lying still
    if (b.visible && b.fraction_in_view_min >= 0.8 && moving) in_view = t;
  }
  const auto estimates = read_lines(results + "/trajectories.jsonl");
  const auto predictions = read_lines(results + "/predictions.jsonl");
  std::optional<nlohmann::json> first_estimate;
  for (const auto& e : estimates)
    if (e["usable"].get<bool>() && e["method"] == "fusion") {
      first_estimate = e;
      break;
    }
  // True closest approach of the ball to the vehicle.
  TimeNs t_ca = 0;
  double miss_true = std::numeric_limits<double>::infinity();
  for (const ObjectState& s : truth.objects)
    if (s.id == ball && s.t >= truth.body.front().t && s.t <= truth.body.back().t) {
      const double d = (s.p_W - truth.body_at(s.t).p_W_B).norm();
      if (d < miss_true) miss_true = d, t_ca = s.t;
    }

  std::cout << "\nfast-dynamic-vision demo: " << args.scenario << ", seed " << args.seed << "\n";
  if (in_view) std::cout << fmt::format("  ball in flight and in view from   t = {:.3f} s\n", to_seconds(*in_view));
  const auto& det = metrics["detection"];
  std::cout << fmt::format("  detection recall {:.0f} % of eligible windows, median centre error {:.1f} px, "
                           "{:.2f} false detections per window\n",
                           100 * det["recall"].get<double>(), det["median_center_error_px"].get<double>(),
                           det["false_detections_per_window"].get<double>());
  if (first_estimate) {
    const double t = (*first_estimate)["t"].get<double>();
    std::cout << fmt::format("  first 3D estimate at               t = {:.3f} s ({})\n", t,
                             in_view ? fmt::format("{:.0f} ms after the ball entered the view",
                                                   1e3 * (t - to_seconds(*in_view)))
                                     : std::string("ball never fully in view"));
  } else {
    std::cout << "  no usable 3D estimate\n";
  }
  if (!predictions.empty()) {
    const auto& p = predictions.back();
    std::cout << fmt::format("  predicted miss distance {:.2f} m at t = {:.3f} s (truth {:.2f} m at t = {:.3f} s)\n",
                             p["miss_distance"].get<double>(), p["closest_t"].get<double>(), miss_true,
                             to_seconds(t_ca));
    if (p.contains("time_to_contact"))
      std::cout << fmt::format("  predicted time to contact ({} m safety radius): {:.3f} s from t = {:.3f} s\n",
                               PredictionOptions{}.safety_radius_m, p["time_to_contact"].get<double>(),
                               p["t"].get<double>());
  }
  for (const auto& a : metrics["ape"])
    std::cout << fmt::format("  APE of track {} ({}): RMSE {:.3f} m, max {:.3f} m over {:.3f}-{:.3f} s\n",
                             a["track"].get<int>(), a["method"].get<std::string>(), a["rmse"].get<double>(),
                             a["max"].get<double>(), a["t_first"].get<double>(), a["t_last"].get<double>());
  std::cout << "  outputs: " << results << " (detections, depth, trajectories, predictions, metrics)\n";
}

}  // namespace

void add_demo_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo", "simulate a ball thrown at a hovering drone, run everything, print a summary");
  static DemoArgs args;
  cmd->add_option("--out", args.out, "folder for the simulated dataset and the results")->capture_default_str();
  cmd->add_option("--scenario", args.scenario, "simulator preset")->capture_default_str();
  cmd->add_option("--seed", args.seed, "random seed")->capture_default_str();
  cmd->callback([] { demo(args); });
}

}  // namespace fdv::cli
