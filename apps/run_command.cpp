// `fdv run INPUT --out DIR`: the whole pipeline over a recording, through the streaming
// fdv::Perception class, writing JSON-lines results, a summary, TUM trajectories and optional PNGs.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "apps/commands.h"
#include "apps/experiment.h"
#include "apps/reader_flags.h"
#include "fdv/core/error.h"
#include "fdv/core/field_list.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/pipeline/perception.h"
#include "fdv/pipeline/replay.h"
#include "fdv/pipeline/sensor_policy.h"
#include "fdv/results/writer.h"
#include "fdv/tables/experiment.h"

namespace fdv::cli {
namespace fs = std::filesystem;
namespace {

PerceptionOptions load_options(const RunArgs& args) {
  PerceptionOptions o;
  if (!args.config.empty()) o = load_perception_options_file(args.config);
  // Command-line flags override the file.
  if (!args.method.empty()) {
    const auto method = parse_compensation_method(args.method);
    if (!method) throw ConfigError("unknown --method '" + args.method + "' (" + enum_choices(CompensationMethod{}) + ")");
    o.compensation.method = *method;
  }
  if (args.threads) o.threads = *args.threads;
  o.assume_static_vehicle = args.assume_static;
  return o;
}

/// Three panels on the undistorted grid: normalised mean-time image N (colour map), segmentation
/// S, and the event count image with the detection box.
void write_visualization(const WindowResult& w, const fs::path& dir) {
  const Detector& d = *w.detector;
  const TimeImages& ti = d.time_images();
  if (ti.normalized.empty()) return;
  cv::Mat n8, n_color, s8, s_color, c8, c_color;
  ti.normalized.convertTo(n8, CV_8U, 255.0);
  cv::applyColorMap(n8, n_color, cv::COLORMAP_JET);
  n_color.setTo(cv::Scalar(0, 0, 0), ti.count == 0);
  d.segmentation().convertTo(s8, CV_8U, 255.0);
  cv::cvtColor(s8, s_color, cv::COLOR_GRAY2BGR);
  ti.count.convertTo(c8, CV_8U, 64.0);
  cv::cvtColor(c8, c_color, cv::COLOR_GRAY2BGR);
  for (const TrackedDetection& found : w.detections) {
    const Box2D& b = found.detection.box_undistorted;
    const cv::Rect r(cv::Point(static_cast<int>(b.x0), static_cast<int>(b.y0)),
                     cv::Point(static_cast<int>(b.x1) + 1, static_cast<int>(b.y1) + 1));
    for (cv::Mat* m : {&n_color, &s_color, &c_color}) cv::rectangle(*m, r, cv::Scalar(0, 255, 0), 1);
  }
  cv::Mat panel;
  cv::hconcat(std::vector<cv::Mat>{n_color, s_color, c_color}, panel);
  cv::putText(panel, fmt::format("window {} t={:.3f}s {}", w.index, to_seconds(w.t_start), to_string(w.status)),
              cv::Point(4, 14), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1);
  cv::imwrite((dir / fmt::format("window_{:06d}.png", w.index)).string(), panel);
}

/// What the run counted without saying it while running (fallback flags, overload decimation): a
/// line each. With "none" the compensation uses no sensor, and its flags say nothing of the results.
std::vector<std::string> after_run_warnings(const PerceptionCounters& c, bool compensation_uses_sensors) {
  std::vector<std::string> lines;
  for (const auto& [flag, n] : windows_by_fallback_flag(c))
    if (n > 0 && compensation_uses_sensors)
      lines.push_back(fmt::format("{} of {} windows flagged '{}' by the compensation (windows_with_fallback_flag)",
                                  n, c.windows, flag));
  if (c.events_dropped.overload > 0)
    lines.push_back(fmt::format("{} of {} events decimated by the overload policy", c.events_dropped.overload, c.events));
  return lines;
}

}  // namespace

void run_recording(const RunArgs& args) {
  if (args.print_config) {
    fmt::print("{}", to_yaml(load_options(args)));
    return;
  }
  if (args.input.empty() || args.out.empty()) throw CLI::RequiredError("run needs INPUT and --out");
  auto reader = open_recording(args.input, args.reader);
  const RecordingInfo info = reader->info();
  std::vector<std::string> warnings;
  auto warn = [&](const std::string& w) {
    spdlog::warn("{}", w);
    warnings.push_back(w);
  };
  // What the input's sensors allow of the requested options (fdv/pipeline/sensor_policy.h).
  std::optional<Calibration> calib_file;
  if (!args.calib.empty()) calib_file = load_calibration(args.calib);
  const PerceptionOptions requested_options = load_options(args);
  SensorPolicy policy;
  try {
    policy = apply_sensor_policy(declared_sensors(info, std::move(calib_file)), requested_options);
  } catch (const ConfigError& e) {  // a missing or mismatched sensor size: name where it came from
    throw InputError(args.calib.empty() ? args.input : args.calib, "", e.what());
  }
  for (const std::string& w : policy.warnings) warn(w);
  const Calibration& calib = policy.calibration;
  const PerceptionOptions& options = policy.options;
  const CompensationMethod requested = requested_options.compensation.method;
  const std::string calib_source = !args.calib.empty() ? args.calib
                                   : policy.pixel_only ? "none (pixel coordinates, no compensation)"
                                                       : "from the recording";
  spdlog::info("{} ({}, {}x{}), calibration {}, compensation '{}'", args.input, info.format, info.width,
               info.height, calib_source, to_string(options.compensation.method));

  ResultsWriter out(args.out);
  const fs::path png_dir = fs::path(args.out) / "windows";
  if (args.visualize) fs::create_directories(png_dir);
  PerceptionCallbacks callbacks;
  callbacks.on_window = [&](const WindowResult& w) {
    out.window(w);
    if (args.visualize) write_visualization(w, png_dir);
  };
  callbacks.on_depth = [&](const DepthResult& d) { out.depth(d); };
  callbacks.on_estimate = [&](const EstimateResult& e) { out.estimate(e); };
  callbacks.on_prediction = [&](const PredictionResult& p) { out.prediction(p); };
  callbacks.on_dodge = [&](const DodgeDecision& d) { out.dodge(d); };
  callbacks.on_warning = warn;
  ReadReport reader_report;
  const PerceptionCounters c = replay(std::move(reader), calib, options, callbacks, &reader_report);
  for (const std::string& w : after_run_warnings(c, options.compensation.method != CompensationMethod::kNone)) warn(w);
  for (const auto& [reason, e] : reader_report.dropped())
    warn(fmt::format("the reader dropped {} record(s): {} (first at {})", e.count, reason, e.first_where));

  RunSummary summary;
  summary.input = args.input;
  summary.format = info.format;
  summary.width = info.width;
  summary.height = info.height;
  summary.calibration = calib_source;
  summary.method_requested = to_string(requested);
  summary.method = to_string(options.compensation.method);
  summary.threads = options.threads;
  summary.reader_report = reader_report.to_json();
  summary.counts = c;
  summary.timing_ms = out.timing_ms();
  summary.warnings = warnings;
  summary.options = to_json(options);
  summary.detector_in_use = detector_in_use(options, calib.event_camera);
  out.finish(summary);
  spdlog::info("{} windows, {} detections; results in {}", c.windows, c.detections, args.out);
}

void add_run_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "detect, track and estimate 3D trajectories over a recording");
  static RunArgs args;
  cmd->add_option("input", args.input, "recording file or dataset folder (required unless --print-config)");
  cmd->add_option("--calib", args.calib, "calibration file (project YAML or OpenCV XML/YAML)");
  cmd->add_option("--config", args.config,
                  "YAML options of every stage (docs/DETECTION.md, docs/ESTIMATION.md)");
  cmd->add_option("--method", args.method, "compensation: none, rotation, rotation_translation, contrast_max");
  cmd->add_option("--out", args.out, "output folder (required unless --print-config)");
  cmd->add_flag("--print-config", args.print_config,
                "print the effective options (--config and the flags above) as YAML, and exit");
  cmd->add_flag("--visualize", args.visualize, "write a PNG per window (N, segmentation, detection)");
  cmd->add_flag("--assume-static", args.assume_static, "no odometry: treat the camera as static");
  cmd->add_option("--threads", args.threads,
                  "threads per window for the warp, time images, segmentation and pre-processing "
                  "(YAML threads; same results for any count)")
      ->check(CLI::Range(1, 64));
  add_reader_flags(cmd, args.reader);
  cmd->callback([] { run_recording(args); });
}

}  // namespace fdv::cli
