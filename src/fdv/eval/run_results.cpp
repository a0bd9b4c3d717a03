#include "fdv/eval/run_results.h"

#include <fstream>
#include <nlohmann/json.hpp>

#include "fdv/core/error.h"

namespace fdv {

std::vector<WindowDetections> read_detections(const std::string& results_dir) {
  const std::string path = results_dir + "/detections.jsonl";
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open (run `fdv run ... --out DIR` first)");
  std::vector<WindowDetections> out;
  std::string line;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    try {
      const auto j = nlohmann::json::parse(line);
      WindowDetections w;
      w.t_start = from_seconds(j.at("t_start").get<double>());
      w.t_end = from_seconds(j.at("t_end").get<double>());
      for (const auto& d : j.at("detections"))
        w.detections.push_back({from_seconds(d.at("t").get<double>()),
                                {d.at("center")[0].get<double>(), d.at("center")[1].get<double>()},
                                d.value("track", -1)});
      out.push_back(std::move(w));
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path, "line " + std::to_string(n), e.what());
    }
  }
  return out;
}

std::vector<EstimateRecord> read_estimates(const std::string& results_dir) {
  const std::string path = results_dir + "/trajectories.jsonl";
  std::ifstream in(path);
  std::vector<EstimateRecord> out;
  if (!in) return out;
  std::string line;
  auto vec = [](const nlohmann::json& j) { return Eigen::Vector3d(j.at(0), j.at(1), j.at(2)); };
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    try {
      const auto j = nlohmann::json::parse(line);
      // "converged" is absent from results written before it existed: usable implied it.
      const bool usable = j.at("usable").get<bool>();
      if (!j.value("converged", usable)) continue;
      EstimateRecord e;
      e.usable = usable;
      e.track = j.at("track");
      const std::string method = j.at("method");
      if (method != "fusion" && method != "mono")
        throw InputError(path, "line " + std::to_string(n),
                         "method '" + method + "' is neither fusion nor mono");
      e.mode = method == "fusion" ? EstimatorMode::kFusion : EstimatorMode::kMonocular;
      e.t = from_seconds(j.at("t").get<double>());
      e.t_first = from_seconds(j.at("t_first").get<double>());
      e.t_last = from_seconds(j.at("t_last").get<double>());
      e.trajectory = {from_seconds(j.at("t0").get<double>()), vec(j.at("p0")), vec(j.at("v0")),
                      vec(j.at("gravity"))};
      out.push_back(e);
    } catch (const nlohmann::json::exception& ex) {
      throw InputError(path, "line " + std::to_string(n), ex.what());
    }
  }
  return out;
}

}  // namespace fdv
