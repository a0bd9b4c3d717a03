// `fdv run INPUT --out DIR`: the whole pipeline over a recording, through the streaming
// fdv::Perception class, writing JSON-lines results, a summary, TUM trajectories and optional PNGs.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <csignal>
#include <filesystem>
#include <optional>
#include <string>
#include <opencv2/imgproc.hpp>

#include "apps/commands.h"
#include "apps/reader_flags.h"
#include "fdv/core/error.h"
#include "fdv/core/field_list.h"
#include "fdv/io/dataset/depth_image.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/pipeline/perception.h"
#include "fdv/results/run.h"

namespace fdv::cli {
namespace fs = std::filesystem;
namespace {

/// The signal that asked `fdv run` to stop (0: none). Set by the handler, read between windows.
volatile std::sig_atomic_t stop_signal = 0;

/// SIGINT and SIGTERM stop the run at the next window's end: the run unwinds, its partial results
/// folder is removed and the folder named by --out is left as it was (fdv/results/run.h). A second
/// signal, when no window ends (a reader blocked on its input), ends the program at once.
void stop_at_next_window_on_signals() {
  for (int s : {SIGINT, SIGTERM})
    std::signal(s, [](int signal_number) {
      if (stop_signal != 0) {
        std::signal(signal_number, SIG_DFL);
        std::raise(signal_number);
      }
      stop_signal = signal_number;
    });
}

struct RunArgs {
  std::string input, calib, config, method, out;
  bool visualize = false;
  bool assume_static = false;
  std::optional<int> threads;  ///< overrides the options' threads
  bool print_config = false;   ///< print the effective options as YAML and exit
  ReaderOptions reader;
};

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
  write_png_bgr8((dir / fmt::format("window_{:06d}.png", w.index)).string(), panel.data, panel.cols,
                 panel.rows, panel.step);
}

/// `fdv run`: the pipeline over a recording, results into args.out (docs/FORMATS.md "`fdv run` outputs").
void run_recording(const RunArgs& args) {
  if (args.print_config) {
    fmt::print("{}", to_yaml(load_options(args)));
    return;
  }
  if (args.input.empty() || args.out.empty()) throw CLI::RequiredError("run needs INPUT and --out");
  RunRequest request;
  request.input = args.input;
  request.reader = args.reader;
  request.options = load_options(args);
  if (!args.calib.empty()) {
    request.calibration = load_calibration(args.calib);
    request.calibration_source = args.calib;
  }
  RecordingRun run(std::move(request));
  const RecordingInfo& info = run.info();
  spdlog::info("{} ({}, {}x{}), calibration {}, compensation '{}'", args.input, info.format, info.width,
               info.height, run.calibration_source(), to_string(run.policy().options.compensation.method));

  fs::path png_dir;  // in the folder being written, known once the recorder exists
  PerceptionCallbacks also;
  also.on_window = [&](const WindowResult& w) {
    if (stop_signal != 0) throw Interrupted(stop_signal);
    if (args.visualize) write_visualization(w, png_dir);
  };
  also.on_warning = [](const std::string& w) { spdlog::warn("{}", w); };
  RunRecorder recorder(args.out, also);
  if (args.visualize) fs::create_directories(png_dir = recorder.folder() / "windows");
  stop_at_next_window_on_signals();
  const RunOutcome outcome = run.into(recorder);
  spdlog::info("{} windows, {} detections; results in {}", outcome.counts.windows, outcome.counts.detections,
               args.out);
}

}  // namespace

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
