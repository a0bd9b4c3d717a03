// `fdv simulate --scenario NAME [--seed N] [--duration S] [--camera FILE] [--resolution WxH]
//  [--config FILE] [--fly DODGE_JSONL] --out DIR`: a simulated dataset folder with exact ground
//  truth, and a JSON summary. --fly: the vehicle flies the decisions' set-points.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <cstdio>

#include "apps/commands.h"
#include "fdv/avoidance/maneuver_playback.h"
#include "fdv/core/error.h"
#include "fdv/eval/ground_truth_box.h"
#include "fdv/results/reader.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/simulator.h"

namespace fdv::cli {
namespace {

struct SimulateArgs {
  std::string scenario, config, out, resolution, camera, fly;
  std::optional<std::uint64_t> seed;
  std::optional<double> duration_s;
  std::optional<int> threads;
  bool print_config = false;
  std::string depth_format = "zstd";
};

/// Writes the dataset and keeps the truth in memory for the visibility summary.
class RecordingSink : public sim::DatasetSink {
 public:
  using DatasetSink::DatasetSink;
  void on_body_truth(const OdometrySample& s) override {
    DatasetSink::on_body_truth(s);
    body.push_back(s);
  }
  void on_unflown_body_truth(const OdometrySample& s) override {
    DatasetSink::on_unflown_body_truth(s);
    body_unflown.push_back(s);
  }
  void on_object_truth(const ObjectState& s) override {
    DatasetSink::on_object_truth(s);
    objects.push_back(s);
  }
  std::vector<OdometrySample> body, body_unflown;
  std::vector<ObjectState> objects;
};

/// The least distance from ball `id`'s centre to the body origin over the truth, and its time.
nlohmann::json closest_approach(const std::vector<OdometrySample>& body,
                                const std::vector<ObjectState>& objects, int id) {
  std::size_t b = 0;
  double best = std::numeric_limits<double>::infinity();
  TimeNs best_t = 0;
  for (const ObjectState& o : objects) {
    if (o.id != id) continue;
    while (b < body.size() && body[b].t < o.t) ++b;
    if (b == body.size() || body[b].t != o.t) continue;
    if (const double d = (o.p_W - body[b].p_W_B).norm(); d < best) best = d, best_t = o.t;
  }
  if (!std::isfinite(best)) return nullptr;
  return {{"distance_m", best}, {"t_s", to_seconds(best_t)}};
}

sim::ScenarioConfig build_config(const SimulateArgs& args) {
  YAML::Node file;
  if (!args.config.empty()) file = sim::load_scenario_yaml(args.config);
  // The preset comes from --scenario, else the file's `name`; its randomisation from --seed,
  // else the file's `seed`, else 1.
  std::string name = args.scenario;
  if (name.empty() && file && file.IsMap() && file["name"]) {
    if (!file["name"].IsScalar()) throw InputError(args.config, "key name", "expected a string");
    name = file["name"].Scalar();
  }
  if (name.empty()) throw ConfigError("no scenario: give --scenario NAME (or `name:` in --config)");
  std::uint64_t seed = 1;
  if (args.seed) {
    seed = *args.seed;
  } else if (file && file.IsMap() && file["seed"]) {
    try {
      seed = file["seed"].as<std::uint64_t>();
    } catch (const YAML::Exception&) {
      throw InputError(args.config, "key seed",
                       "'" + file["seed"].Scalar() + "' is not a non-negative integer");
    }
  }
  const auto presets = sim::preset_names();
  sim::ScenarioConfig config;
  if (std::find(presets.begin(), presets.end(), name) != presets.end() || args.config.empty()) {
    config = sim::make_preset(name, seed);
  } else {
    config.name = name;  // a fully custom scene described by the file
    config.seed = seed;
  }
  if (file) {
    sim::apply_scenario_yaml(config, file, args.config);
    if (const auto p = config.find_problem())
      throw InputError(args.config, "key " + p->first, p->second);
  }
  config.seed = seed;
  if (args.duration_s) config.duration_s = *args.duration_s;
  if (args.threads) config.threads = *args.threads;
  if (!args.camera.empty()) sim::load_event_camera(config, args.camera);
  if (!args.resolution.empty()) {
    int width = 0, height = 0;
    char tail = 0;
    if (std::sscanf(args.resolution.c_str(), "%dx%d%c", &width, &height, &tail) != 2 || width <= 0 || height <= 0)
      throw ConfigError("--resolution must look like 640x480, got '" + args.resolution + "'");
    sim::set_event_resolution(config, width, height);
  }
  if (const auto why = config.validate(); !why.empty()) throw ConfigError(why);
  return config;
}

nlohmann::json vec_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// First and last truth instant at which any part / all of the ball is in the image.
nlohmann::json visibility(const RecordingSink& sink, const sim::ResolvedBall& ball,
                          const Calibration& calib) {
  std::optional<TimeNs> any0, any1, full0, full1;
  for (const auto& s : sink.objects) {
    if (s.id != ball.id) continue;
    GroundTruthBoxOptions options;
    options.view_samples = 256;
    const auto box =
        ground_truth_box(sink.objects, ball.id, ball.radius_m, sink.body, calib, s.t, s.t, options);
    if (box.visible) {
      if (!any0) any0 = s.t;
      any1 = s.t;
    }
    if (box.fraction_in_view_min >= 1.0) {
      if (!full0) full0 = s.t;
      full1 = s.t;
    }
  }
  nlohmann::json j;
  j["visible"] = any0.has_value();
  if (any0) {
    j["visible_from_s"] = to_seconds(*any0);
    j["visible_to_s"] = to_seconds(*any1);
    j["visible_for_s"] = to_seconds(*any1 - *any0);
  }
  if (full0) {
    j["fully_visible_from_s"] = to_seconds(*full0);
    j["fully_visible_to_s"] = to_seconds(*full1);
  }
  return j;
}

void run_simulate(const SimulateArgs& args) {
  const sim::ScenarioConfig config = build_config(args);
  if (args.print_config) {
    std::cout << sim::to_yaml(config) << std::endl;
    return;
  }
  if (args.out.empty()) throw ConfigError("--out DIR is required");
  sim::Simulator simulator(config);
  // Progress on stderr: stdout carries only the JSON summary (pipe it to jq).
  fmt::print(stderr, "simulating {} (seed {}) for {} s at {}x{} into {}\n", config.name,
             config.seed, config.duration_s, config.event_camera.width, config.event_camera.height,
             args.out);
  RecordingSink sink(args.out, simulator.calibration(),
                     args.depth_format == "png" ? DepthEncoding::kPng : DepthEncoding::kZstd);
  std::vector<SetpointChange> schedule;
  if (!args.fly.empty()) schedule = setpoint_schedule(dodge_decisions(read_dodge_file(args.fly)));
  simulator.begin(sink, args.fly.empty() ? sim::Flight::kPath : sim::Flight::kCommanded);
  for (const SetpointChange& c : schedule) simulator.command(c.t, c.acceleration_W);
  while (simulator.step()) {
  }
  const sim::SimulationSummary summary = simulator.finish();

  nlohmann::json balls = nlohmann::json::array();
  YAML::Node manifest = YAML::Load(simulator.manifest_yaml());
  for (std::size_t i = 0; i < summary.balls.size(); ++i) {
    const auto& b = summary.balls[i];
    nlohmann::json jb = visibility(sink, b, simulator.calibration());
    jb["id"] = b.id;
    jb["radius_m"] = b.radius_m;
    jb["release_t_s"] = b.release_t_s;
    jb["origin_W"] = vec_json(b.origin_W);
    jb["velocity_W"] = vec_json(b.velocity_W);
    jb["speed_m_s"] = b.velocity_W.norm();
    jb["closest_approach"] = closest_approach(sink.body, sink.objects, b.id);
    if (!args.fly.empty()) jb["closest_approach_unflown"] = closest_approach(sink.body_unflown, sink.objects, b.id);
    if (jb.contains("visible_from_s")) {
      manifest["balls"][i]["visible_from_s"] = jb["visible_from_s"].get<double>();
      manifest["balls"][i]["visible_to_s"] = jb["visible_to_s"].get<double>();
    }
    balls.push_back(jb);
  }
  YAML::Emitter emitter;
  emitter << manifest;
  sink.finish(emitter.c_str());

  nlohmann::json j;
  j["out"] = args.out;
  j["scenario"] = config.name;
  j["seed"] = config.seed;
  j["duration_s"] = config.duration_s;
  j["resolution"] = {config.event_camera.width, config.event_camera.height};
  j["events"] = summary.events;
  j["events_on"] = summary.events_on;
  j["event_rate_ev_s"] = static_cast<double>(summary.events) / summary.simulated_s;
  j["events_by_label"] = {{"object", summary.events_object},
                          {"scene", summary.events_scene},
                          {"noise", summary.events_noise},
                          {"hot_pixel", summary.events_hot}};
  j["imu"] = summary.imu;
  j["odometry"] = summary.odometry;
  j["depth_frames"] = summary.depth;
  j["truth_samples"] = summary.truth;
  j["balls"] = balls;
  if (!args.fly.empty())
    j["flight"] = {{"decisions", args.fly},
                   {"setpoint_changes", summary.flight.commands},
                   {"tilt_clipped", summary.flight.tilt_clipped},
                   {"late", summary.flight.late},
                   {"floor_holds", summary.flight.floor_holds},
                   {"ceiling_holds", summary.flight.ceiling_holds},
                   {"wall_holds", summary.flight.wall_holds}};
  j["wall_s"] = summary.wall_s;
  j["realtime_factor"] = summary.simulated_s / summary.wall_s;
  j["mean_pixel_sample_rate_hz"] = summary.mean_sample_rate_hz;
  j["max_tile_steps_per_chunk"] = summary.max_tile_steps;
  j["capped_tile_chunks"] = summary.capped_tiles;
  fmt::print(stderr, "{}\n", summary.brief());
  std::cout << j.dump(2) << std::endl;
}

}  // namespace

void add_simulate_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "simulate", "simulate a scene: events, IMU, depth, odometry and exact ground truth");
  static SimulateArgs args;
  std::string names;
  for (const auto& n : sim::preset_names()) names += (names.empty() ? "" : ", ") + n;
  cmd->add_option("--scenario", args.scenario, "preset: " + names);
  cmd->add_option("--seed", args.seed,
                  "randomises the preset (layout, throw, textures, noise); default 1");
  cmd->add_option("--duration", args.duration_s, "simulated seconds (default: the preset's)");
  cmd->add_option("--camera", args.camera,
                  "event camera (resolution, intrinsics, distortion) from a calibration file: "
                  "OpenCV XML/YAML or the project's YAML");
  cmd->add_option("--resolution", args.resolution,
                  "event sensor WxH, same field of view (e.g. 346x260); after --camera");
  cmd->add_option("--config", args.config,
                  "YAML file overriding any parameter (see `--print-config`)");
  cmd->add_option("--threads", args.threads, "worker threads (default: all cores)");
  cmd->add_option("--out", args.out, "output dataset folder");
  cmd->add_option("--fly", args.fly,
                  "a dodge.jsonl (`fdv run`'s decisions): the vehicle flies their set-points through "
                  "its dynamics (docs/SIMULATOR.md); truth/body_unflown.csv keeps the path without them");
  cmd->add_option("--depth-format", args.depth_format,
                  "depth frame files: zstd (default; raw millimetres in a Zstandard frame) or png "
                  "(16-bit, viewable; decodes several times slower)")
      ->check(CLI::IsMember({"zstd", "png"}));
  cmd->add_flag("--print-config", args.print_config,
                "print the resolved configuration as YAML and exit");
  cmd->callback([] { run_simulate(args); });
}

}  // namespace fdv::cli
