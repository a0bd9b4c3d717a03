// fdv.simulate (as `fdv simulate`) and fdv.load_truth: the simulator's ground truth as arrays.
#include <pybind11/stl.h>

#include <algorithm>
#include <optional>

#include "common.h"
#include "fdv/avoidance/maneuver_playback.h"
#include "fdv/core/error.h"
#include "fdv/results/reader.h"
#include "fdv/eval/dataset_truth.h"
#include "fdv/sim/dataset_sink.h"
#include "fdv/sim/scenario_config.h"
#include "fdv/sim/simulator.h"

namespace fdv::python {
namespace {

py::dict simulate(const std::string& scenario, std::uint64_t seed, const std::string& out,
                  std::optional<double> duration_s, std::optional<std::pair<int, int>> resolution,
                  std::optional<int> threads, const std::string& config_yaml, const std::string& depth_format) {
  if (depth_format != "zstd" && depth_format != "png")
    throw ConfigError("depth_format '" + depth_format + "': expected zstd or png");
  const auto presets = sim::preset_names();
  if (std::find(presets.begin(), presets.end(), scenario) == presets.end()) {
    std::string names;
    for (const auto& n : presets) names += (names.empty() ? "" : ", ") + n;
    throw ConfigError("unknown scenario '" + scenario + "' (" + names + ")");
  }
  sim::SimulationSummary summary;
  {
    py::gil_scoped_release release;
    sim::ScenarioConfig config = sim::make_preset(scenario, seed);
    if (!config_yaml.empty()) {
      sim::apply_scenario_yaml_text(config, config_yaml, "<config>");
      if (const auto p = config.find_problem()) throw InputError("<config>", "key " + p->first, p->second);
    }
    config.seed = seed;
    if (duration_s) config.duration_s = *duration_s;
    if (threads) config.threads = *threads;
    if (resolution) sim::set_event_resolution(config, resolution->first, resolution->second);
    if (const auto why = config.validate(); !why.empty()) throw ConfigError(why);
    sim::Simulator simulator(config);
    sim::DatasetSink sink(out, simulator.calibration(),
                          depth_format == "png" ? DepthEncoding::kPng : DepthEncoding::kZstd);
    summary = simulator.run(sink);
    sink.finish(simulator.manifest_yaml());
  }
  py::dict d;
  d["out"] = out;
  d["events"] = summary.events;
  d["imu"] = summary.imu;
  d["odometry"] = summary.odometry;
  d["depth_frames"] = summary.depth;
  d["truth_samples"] = summary.truth;
  d["wall_s"] = summary.wall_s;
  py::list balls;
  for (const auto& b : summary.balls) {
    py::dict jb;
    jb["id"] = b.id;
    jb["radius_m"] = b.radius_m;
    jb["release_t_s"] = b.release_t_s;
    jb["origin_W"] = std::vector<double>{b.origin_W.x(), b.origin_W.y(), b.origin_W.z()};
    jb["velocity_W"] = std::vector<double>{b.velocity_W.x(), b.velocity_W.y(), b.velocity_W.z()};
    balls.append(jb);
  }
  d["balls"] = balls;
  return d;
}

/// The truth of a simulated dataset: body and object arrays, and per ball its radius, the first
/// instant in flight and in view, and the true closest approach (fdv/eval/dataset_truth.h).
py::dict load_truth(const std::string& dir, const std::string& time_unit) {
  const TimeUnit u = parse_time_unit(time_unit);
  DatasetTruth truth;
  {
    py::gil_scoped_release release;
    truth = load_dataset_truth(dir);
  }
  py::dict d;
  d["scenario"] = truth.scenario;
  d["calibration"] = truth.calibration;
  d["gravity_W"] = std::vector<double>{truth.gravity_W.x(), truth.gravity_W.y(), truth.gravity_W.z()};
  d["body"] = odometry_array(truth.body, u);
  d["objects"] = object_array(truth.objects, u);
  py::dict balls;
  for (const auto& [id, radius] : truth.radius_m) {
    py::dict b;
    b["radius_m"] = radius;
    const auto first = first_in_flight_in_view(truth, id);
    b["first_in_view"] = first ? py::object(py::int_(from_ns(*first, u))) : py::none();
    const auto closest = true_closest_approach(truth, id);
    b["closest_approach_t"] = closest ? py::object(py::int_(from_ns(closest->t, u))) : py::none();
    b["closest_approach_m"] = closest ? py::object(py::float_(closest->distance_m)) : py::none();
    balls[py::int_(id)] = b;
  }
  d["balls"] = balls;
  return d;
}

/// The kinematic replay's displacement of the body at each of `times_s` by a run's decisions.
py::array_t<double> maneuver_offset(const std::string& results_dir, const std::vector<double>& times_s) {
  const std::vector<DodgeDecision> decisions = dodge_decisions(read_dodge(results_dir));
  py::array_t<double> out({static_cast<py::ssize_t>(times_s.size()), py::ssize_t{3}});
  auto o = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < times_s.size(); ++i) {
    const Eigen::Vector3d p = commanded_offset(decisions, from_seconds(times_s[i])).position_W;
    for (int k = 0; k < 3; ++k) o(static_cast<py::ssize_t>(i), k) = p[k];
  }
  return out;
}

}  // namespace

void register_simulation(py::module_& m) {
  m.def("maneuver_offset", &maneuver_offset, py::arg("results"), py::arg("times_s"),
        "The displacement [m] (N x 3, W axes) that a results folder's dodge decisions (dodge.jsonl) add "
        "to the body's path at each time [s], as `fdv dodge-eval` replays them kinematically.");
  m.def("preset_names", &sim::preset_names);
  m.def("simulate", &simulate, py::arg("scenario"), py::kw_only(), py::arg("seed") = 1, py::arg("out"),
        py::arg("duration") = py::none(), py::arg("resolution") = py::none(), py::arg("threads") = py::none(),
        py::arg("config") = "", py::arg("depth_format") = "zstd",
        "Simulates preset `scenario` into the dataset folder `out`, as `fdv simulate` (config: YAML "
        "text overriding any parameter, see `fdv simulate --print-config`; depth_format: 'zstd' or "
        "'png', as --depth-format). Returns a summary dict.");
  m.def("load_truth", &load_truth, py::arg("dataset"), py::kw_only(), py::arg("time_unit") = "us",
        "Ground truth of a simulated dataset: body (fdv.ODOMETRY_DTYPE), objects (fdv.OBJECT_DTYPE), "
        "balls {id: radius_m, first_in_view, closest_approach_t, closest_approach_m}, gravity_W.");
}

}  // namespace fdv::python
