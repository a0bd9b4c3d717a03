#include "fdv/tables/experiment.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <charconv>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fdv/core/error.h"
#include "fdv/eval/relative_contrast.h"
#include "fdv/pipeline/replay.h"

namespace fdv {
namespace fs = std::filesystem;

GroundTruthBoxOptions compensated_image_frame(CompensationMethod used, TimeNs t_start) {
  GroundTruthBoxOptions frame;
  switch (used) {
    case CompensationMethod::kNone:
      break;  // the raw image: the camera at each event's time
    case CompensationMethod::kRotation:
      frame.rotation_time = t_start;  // rotation undone, translation not
      break;
    case CompensationMethod::kRotationTranslation:
    case CompensationMethod::kContrastMax:
      frame.rotation_time = frame.position_time = t_start;
      break;
  }
  return frame;
}

std::vector<double> window_relative_contrast(const DatasetTruth& truth, const cv::Mat& mean_time_s,
                                             TimeNs t_start, TimeNs t_end, CompensationMethod used,
                                             const DetectorOptions& detector) {
  std::vector<double> etas;
  cv::Mat clean;  // denoised once per window, only if some ball needs it
  const GroundTruthBoxOptions frame = compensated_image_frame(used, t_start);
  for (const auto& [id, r] : truth.radius_m) {
    if (!truth.in_flight(id, (t_start + t_end) / 2)) continue;
    const cv::Rect M = undistorted_truth_rect(truth, id, t_start, t_end - 1, frame);
    if (M.area() == 0) continue;
    if (clean.empty())
      clean = denoise_for_contrast(mean_time_s, detector.mean_filter_px, detector.opening_px);
    if (const auto eta = relative_contrast(clean, M)) etas.push_back(*eta);
  }
  return etas;
}

WindowDetections window_detections(const WindowResult& w) {
  WindowDetections d{w.t_start, w.t_end, {}, std::string(to_string(w.status))};
  for (const auto& [found, track_id] : w.detections)
    d.detections.push_back({found.t, found.center_raw, track_id, found.partial,
                            found.visible_fraction, found.center_full_raw});
  return d;
}

ExperimentRun run_experiment(const DatasetTruth& truth, const ExperimentOptions& options) {
  ExperimentRun run;
  PerceptionCallbacks callbacks;
  callbacks.on_window = [&](const WindowResult& w) {
    run.windows.push_back(window_detections(w));
    run.compensation_ms.push_back(w.timings.compensation_ms);
    run.front_end_ms.push_back(w.timings.compensation_ms + w.timings.detection.total_ms);
    if (options.relative_contrast && w.detector) {
      const auto etas =
          window_relative_contrast(truth, w.detector->time_images().mean_time_s, w.t_start, w.t_end,
                                   w.compensation.used, options.perception.detection);
      run.relative_contrast.insert(run.relative_contrast.end(), etas.begin(), etas.end());
    }
  };
  callbacks.on_estimate = [&](const EstimateResult& e) {
    if (!e.estimate || !e.estimate->converged) return;
    run.estimates.push_back({e.t, e.track_id, e.mode, e.estimate->t_first, e.estimate->t_last,
                             e.estimate->trajectory, e.estimate->usable});
  };
  callbacks.on_warning = [&](const std::string& w) { spdlog::warn("{}: {}", truth.dir, w); };
  run.counters =
      replay(open_recording(truth.dir), truth.calibration, options.perception, callbacks);
  return run;
}

std::vector<std::uint64_t> parse_seed_list(const std::string& text) {
  std::vector<std::uint64_t> seeds;
  auto number = [&](std::string_view s, const std::string& part) {
    std::uint64_t v = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size() || s.empty())
      throw ConfigError("seeds '" + text + "': '" + part + "' is not a seed or a range A-B");
    return v;
  };
  std::istringstream in(text);
  for (std::string part; std::getline(in, part, ',');) {
    const std::string_view p(part);
    if (const auto dash = p.find('-'); dash != std::string_view::npos) {
      const std::uint64_t a = number(p.substr(0, dash), part), b = number(p.substr(dash + 1), part);
      if (b < a) throw ConfigError("seeds '" + text + "': range '" + part + "' runs backwards");
      if (b - a >= 10000)
        throw ConfigError("seeds '" + text + "': range '" + part + "' has over 10000 seeds");
      for (std::uint64_t s = a; s <= b; ++s) seeds.push_back(s);
    } else {
      seeds.push_back(number(p, part));
    }
  }
  if (seeds.empty()) throw ConfigError("seeds '" + text + "': no seed given");
  return seeds;
}

}  // namespace fdv
