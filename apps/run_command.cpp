// `fdv run INPUT --out DIR`: the whole pipeline over a recording, through the streaming
// fdv::Perception class, writing JSON-lines results, a summary, TUM trajectories and optional PNGs.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "apps/commands.h"
#include "apps/experiment.h"
#include "apps/reader_flags.h"
#include "fdv/core/error.h"
#include "fdv/eval/statistics.h"
#include "fdv/io/config/backend_config.h"
#include "fdv/pipeline/perception.h"
#include "fdv/pipeline/replay.h"
#include "fdv/tables/experiment.h"

namespace fdv::cli {
namespace fs = std::filesystem;
namespace {

nlohmann::json box_json(const Box2D& b) { return {b.x0, b.y0, b.x1, b.y1}; }
nlohmann::json vec_json(const Eigen::Vector2d& v) { return {v.x(), v.y()}; }
nlohmann::json vec_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// A calibration for inputs that come without one: an ideal camera of the sensor's size. Pixel
/// coordinates then pass through unchanged (no distortion), and only "none" compensation is possible.
Calibration pixel_only_calibration(int width, int height) {
  Calibration c;
  const double f = std::max(width, height);
  c.event_camera = {width, height, f, f, 0.5 * (width - 1), 0.5 * (height - 1), {}};
  return c;
}

PerceptionOptions load_options(const RunArgs& args) {
  PerceptionOptions o;
  if (!args.config.empty()) o = load_perception_options_file(args.config);
  // Command-line flags override the file.
  if (!args.method.empty()) {
    if (!parse_compensation_method(args.method))
      throw ConfigError("unknown --method '" + args.method +
                        "' (none, rotation, rotation_translation, contrast_max)");
    o.compensation.method = args.method;
  }
  if (args.threads) o.compensation.threads = *args.threads;
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
  if (w.detection) {
    const Box2D& b = w.detection->box_undistorted;
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

class Outputs {
 public:
  explicit Outputs(const fs::path& dir, bool visualize) : dir_(dir), visualize_(visualize) {
    fs::create_directories(dir);
    if (visualize) fs::create_directories(dir / "windows");
    for (auto [name, stream] : {std::pair{"detections.jsonl", &detections_}, {"depth.jsonl", &depth_},
                                {"trajectories.jsonl", &trajectories_}, {"predictions.jsonl", &predictions_}}) {
      stream->open(dir / name);
      if (!*stream) throw InputError((dir / name).string(), "", "cannot create output file");
    }
  }

  void window(const WindowResult& w) {
    nlohmann::json j = {{"t_start", to_seconds(w.t_start)},
                        {"t_end", to_seconds(w.t_end)},
                        {"events", w.events},
                        {"method", to_string(w.compensation.used)},
                        {"status", to_string(w.status)},
                        {"detections", nlohmann::json::array()}};
    if (w.compensation.used != w.compensation.requested)
      j["method_requested"] = to_string(w.compensation.requested);
    if (w.detection) {
      const Detection2D& d = *w.detection;
      j["detections"].push_back({{"box", box_json(d.box_raw)},
                                 {"center", vec_json(d.center_raw)},
                                 {"box_undistorted", box_json(d.box_undistorted)},
                                 {"center_undistorted", vec_json(d.center_undistorted)},
                                 {"t", to_seconds(d.t_ns)},
                                 {"events", d.events},
                                 {"score", d.score},
                                 {"event_density", d.event_density},
                                 {"track_aided", d.track_aided},
                                 {"source", to_string(d.source)},
                                 {"track", w.track_id}});
      ++detections_count_;
    }
    detections_ << j.dump() << "\n";
    ++windows_;
    windows_skipped_ += w.skipped_before;
    events_ += w.events;
    events_read_ += w.events + w.decimated;
    ++methods_used_[std::string(to_string(w.compensation.used))];
    const CompensationReport& r = w.compensation;
    dropped_["decimated (overload policy)"] += w.decimated + r.dropped_burst;
    dropped_["outside the window"] += r.dropped_outside_window;
    dropped_["outside the sensor"] += r.dropped_outside_sensor;
    dropped_["no lens-model inverse at the pixel"] += r.dropped_no_inverse;
    dropped_["warped outside the image"] += r.dropped_left_image;
    flags_["imu missing"] += r.imu_missing;
    flags_["imu gap"] += r.imu_gap;
    flags_["odometry missing"] += r.odometry_missing;
    flags_["depth missing"] += r.depth_missing;
    flags_["depth stale"] += r.depth_stale;
    flags_["depth wrong size"] += r.depth_wrong_size;
    ++statuses_[std::string(to_string(w.status))];
    const auto& t = w.timings;
    timing_["compensation"].push_back(t.compensation_ms);
    timing_["time_images"].push_back(t.detection.time_images_ms);
    timing_["segmentation"].push_back(t.detection.segmentation_ms);
    timing_["preprocess"].push_back(t.detection.preprocess_ms);
    timing_["gaussian_fit"].push_back(t.detection.fit_ms);
    // Stages that run only in some windows: timed where they ran ("count" says in how many).
    if (t.detection.retrieval_ms > 0) timing_["region_retrieval"].push_back(t.detection.retrieval_ms);
    if (t.detection.count_cue_ms > 0) timing_["count_cue"].push_back(t.detection.count_cue_ms);
    timing_["detection_total"].push_back(t.detection.total_ms);
    timing_["tracking"].push_back(t.tracking_ms);
    timing_["window_total"].push_back(t.total_ms);
    if (visualize_) write_visualization(w, dir_ / "windows");
  }

  void depth(const DepthResult& d) {
    nlohmann::json j = {{"t", to_seconds(d.t)}, {"track", d.track_id},
                        {"accepted", d.segmentation.observation.has_value()},
                        {"roi_pixels", d.segmentation.roi_pixels}, {"valid_pixels", d.segmentation.valid_pixels}};
    if (const auto& o = d.segmentation.observation) {
      j["depth"] = o->depth_m;
      j["surface_depth"] = o->surface_depth_m;
      j["sigma"] = o->sigma_m;
      j["pixels"] = o->pixel_count;
      j["spread"] = o->spread_m;
      j["center"] = vec_json(o->centre_px);
    } else {
      j["rejection"] = to_string(d.segmentation.rejection);
      j["reason"] = d.segmentation.reason;
    }
    depth_ << j.dump() << "\n";
    timing_["depth_segmentation"].push_back(d.ms);
  }

  void estimate(const EstimateResult& e) {
    const TrajectoryEstimate& est = *e.estimate;
    const bool fusion = e.mode == EstimatorMode::kFusion;
    nlohmann::json j = {{"t", to_seconds(e.t)},
                        {"track", e.track_id},
                        {"method", fusion ? "fusion" : "mono"},
                        {"fit", to_string(est.method)},
                        {"usable", est.usable},
                        {"converged", est.converged},
                        {"t0", to_seconds(est.trajectory.t0)},
                        {"p0", vec_json(est.trajectory.p0_W)},
                        {"v0", vec_json(est.trajectory.v0_W)},
                        {"gravity", vec_json(est.trajectory.gravity_W)},
                        {"t_first", to_seconds(est.t_first)},
                        {"t_last", to_seconds(est.t_last)},
                        {"event_observations", est.event_observations},
                        {"depth_observations", est.depth_observations},
                        {"outliers", est.outliers},
                        {"cost", est.final_cost},
                        {"iterations", est.iterations},
                        {"message", est.message}};
    if (est.covariance) {
      nlohmann::json cov = nlohmann::json::array();
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) cov.push_back((*est.covariance)(r, c));
      j["covariance"] = cov;
      j["position_sigma"] = est.position_sigma_m;
      j["horizon_sigma"] = est.horizon_sigma_m;
    }
    trajectories_ << j.dump() << "\n";
    timing_[fusion ? "estimation_fusion" : "estimation_mono"].push_back(e.ms);
    if (est.usable) (fusion ? final_fusion_ : final_mono_)[e.track_id] = est;
  }

  void prediction(const PredictionResult& p) {
    const CollisionPrediction& c = p.prediction;
    nlohmann::json j = {{"t", to_seconds(p.t)},
                        {"track", p.track_id},
                        {"closest_t", to_seconds(c.closest.t)},
                        {"closest_in_s", c.closest.time_from_now_s},
                        {"miss_distance", c.closest.miss_distance_m},
                        {"object_W", vec_json(c.closest.object_W)},
                        {"passage_B", vec_json(c.closest.offset_B)},
                        {"receding", c.closest.receding}};
    if (c.contact) j["time_to_contact"] = c.time_to_contact_s;
    predictions_ << j.dump() << "\n";
  }

  /// The final usable estimate of each track, sampled every 5 ms over its observed interval, in
  /// TUM format (t x y z qx qy qz qw; orientation identity: a ball has none) for tools like evo.
  void write_tum() const {
    for (const auto& [name, finals] : {std::pair{"fusion", &final_fusion_}, {"mono", &final_mono_}})
      for (const auto& [id, est] : *finals) {
        std::ofstream f(dir_ / fmt::format("track_{}_{}.tum", id, name));
        for (TimeNs t = est.t_first; t <= est.t_last; t += 5 * kNsPerMs) {
          const Eigen::Vector3d p = est.trajectory.position(t);
          f << fmt::format("{:.9f} {:.6f} {:.6f} {:.6f} 0 0 0 1\n", to_seconds(t), p.x(), p.y(), p.z());
        }
      }
  }

  nlohmann::json summary() const {
    nlohmann::json timing = nlohmann::json::object();
    for (const auto& [stage, values] : timing_) {
      const Summary s = summarize(values);
      timing[stage] = {{"count", s.count}, {"min", s.min}, {"median", s.median}, {"p99", s.p99},
                       {"max", s.max}, {"mean", s.mean}};
    }
    std::uint64_t dropped_total = 0;
    for (const auto& [_, n] : dropped_) dropped_total += n;
    return {{"counts", {{"events_read", events_read_}, {"events", events_}, {"windows", windows_}, {"windows_skipped_in_gaps", windows_skipped_},
                        {"detections", detections_count_},
                        {"events_dropped", dropped_total}, {"events_dropped_by_reason", dropped_},
                        {"windows_by_status", statuses_}, {"windows_by_method", methods_used_},
                        {"windows_with_fallback_flag", flags_}}},
            {"timing_ms", timing}};
  }

  /// What the run counted without saying it while running (fallback flags, overload decimation): a
  /// line each. With "none" the compensation uses no sensor, and its flags say nothing of the results.
  std::vector<std::string> after_run_warnings(bool compensation_uses_sensors) const {
    std::vector<std::string> lines;
    for (const auto& [flag, n] : flags_)
      if (n > 0 && compensation_uses_sensors)
        lines.push_back(fmt::format("{} of {} windows flagged '{}' by the compensation (windows_with_fallback_flag)",
                                    n, windows_, flag));
    if (const auto it = dropped_.find("decimated (overload policy)"); it != dropped_.end() && it->second > 0)
      lines.push_back(fmt::format("{} of {} events decimated by the overload policy", it->second, events_read_));
    return lines;
  }

 private:
  fs::path dir_;
  bool visualize_;
  std::ofstream detections_, depth_, trajectories_, predictions_;
  std::uint64_t windows_ = 0, windows_skipped_ = 0, events_ = 0, events_read_ = 0, detections_count_ = 0;
  std::map<std::string, std::uint64_t> dropped_, flags_, statuses_, methods_used_;
  std::map<std::string, std::vector<double>> timing_;
  std::map<int, TrajectoryEstimate> final_fusion_, final_mono_;
};

}  // namespace

void run_recording(const RunArgs& args) {
  auto reader = open_recording(args.input, args.reader);
  const RecordingInfo info = reader->info();
  std::vector<std::string> warnings;
  auto warn = [&](const std::string& w) {
    spdlog::warn("{}", w);
    warnings.push_back(w);
  };
  Calibration calib;
  std::string calib_source;
  bool pixel_only = false;  // no calibration at all: the camera's rays are unknown
  if (!args.calib.empty()) {
    calib = load_calibration(args.calib);
    calib_source = args.calib;
  } else if (info.calibration) {
    calib = *info.calibration;
    calib_source = "from the recording";
  } else {
    if (info.width <= 0 || info.height <= 0)
      throw InputError(args.input, "", "no calibration and no sensor size: pass --calib FILE");
    calib = pixel_only_calibration(info.width, info.height);
    calib_source = "none (pixel coordinates, no compensation)";
    pixel_only = true;
    warn("no calibration: detecting in pixel coordinates with no motion compensation and no 3D estimation");
  }
  if (info.width > 0 && (calib.event_camera.width != info.width || calib.event_camera.height != info.height))
    throw InputError(args.calib.empty() ? args.input : args.calib, "",
                     fmt::format("calibration is {}x{} but the recording is {}x{}", calib.event_camera.width,
                                 calib.event_camera.height, info.width, info.height));

  PerceptionOptions options = load_options(args);
  auto declares = [&](StreamKind k) {
    return std::find(info.streams.begin(), info.streams.end(), k) != info.streams.end();
  };
  // The best method the available sensors allow, and say which.
  const auto requested = *parse_compensation_method(options.compensation.method);
  if (pixel_only) {
    // No 3D estimate, even for a vehicle declared static.
    options.estimate_trajectories = false;
    if (args.assume_static) warn("--assume-static ignored: no calibration, so no 3D estimation");
  }
  if (pixel_only && requested != CompensationMethod::kNone) {
    options.compensation.method = "none";
  } else if (!declares(StreamKind::kImu) &&
             (requested == CompensationMethod::kRotation || requested == CompensationMethod::kRotationTranslation)) {
    warn(fmt::format("no IMU in the input: '{}' compensation impossible, using 'none'", to_string(requested)));
    options.compensation.method = "none";
  } else if (requested == CompensationMethod::kRotationTranslation &&
             (!declares(StreamKind::kDepth) || !declares(StreamKind::kOdometry) || !calib.depth_camera)) {
    warn("no depth frames, depth camera or odometry: translational compensation impossible, using 'rotation'");
    options.compensation.method = "rotation";
  }
  spdlog::info("{} ({}, {}x{}), calibration {}, compensation '{}'", args.input, info.format, info.width,
               info.height, calib_source, options.compensation.method);

  Outputs out(args.out, args.visualize);
  PerceptionCallbacks callbacks;
  callbacks.on_window = [&](const WindowResult& w) { out.window(w); };
  callbacks.on_depth = [&](const DepthResult& d) { out.depth(d); };
  callbacks.on_estimate = [&](const EstimateResult& e) { out.estimate(e); };
  callbacks.on_prediction = [&](const PredictionResult& p) { out.prediction(p); };
  callbacks.on_warning = warn;
  ReadReport reader_report;
  const PerceptionCounters c = replay(std::move(reader), calib, options, callbacks, &reader_report);
  out.write_tum();
  for (const std::string& w : out.after_run_warnings(options.compensation.method != "none")) warn(w);
  for (const auto& [reason, e] : reader_report.dropped())
    warn(fmt::format("the reader dropped {} record(s): {} (first at {})", e.count, reason, e.first_where));

  nlohmann::json summary = out.summary();
  summary["input"] = args.input;
  summary["format"] = info.format;
  summary["resolution"] = {info.width, info.height};
  summary["calibration"] = calib_source;
  summary["method_requested"] = to_string(requested);
  summary["method"] = options.compensation.method;
  summary["threads"] = options.compensation.threads;
  summary["reader_report"] = reader_report.to_json();
  summary["counts"]["imu"] = c.imu;
  summary["counts"]["odometry"] = c.odometry;
  summary["counts"]["depth_frames"] = c.depth_frames;
  summary["counts"]["depth_frames_rejected"] = c.depth_rejected_registration;
  summary["counts"]["depth_observations"] = c.depth_observations;
  summary["counts"]["estimates"] = c.estimates;
  summary["counts"]["imu_out_of_order"] = c.imu_out_of_order;
  summary["counts"]["odometry_out_of_order"] = c.odometry_out_of_order;
  summary["warnings"] = warnings;
  std::ofstream(fs::path(args.out) / "summary.json") << summary.dump(2) << "\n";
  spdlog::info("{} windows, {} detections; results in {}", summary["counts"]["windows"].get<std::uint64_t>(),
               summary["counts"]["detections"].get<std::uint64_t>(), args.out);
}

void add_run_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "detect, track and estimate 3D trajectories over a recording");
  static RunArgs args;
  cmd->add_option("input", args.input, "recording file or dataset folder")->required();
  cmd->add_option("--calib", args.calib, "calibration file (project YAML or OpenCV XML/YAML)");
  cmd->add_option("--config", args.config,
                  "YAML options of every stage (docs/DETECTION.md, docs/ESTIMATION.md)");
  cmd->add_option("--method", args.method, "compensation: none, rotation, rotation_translation, contrast_max");
  cmd->add_option("--out", args.out, "output folder")->required();
  cmd->add_flag("--visualize", args.visualize, "write a PNG per window (N, segmentation, detection)");
  cmd->add_flag("--assume-static", args.assume_static, "no odometry: treat the camera as static");
  cmd->add_option("--threads", args.threads,
                  "threads per window for the warp, time images, segmentation and pre-processing "
                  "(compensation.threads; same results for any count)")
      ->check(CLI::Range(1, 64));
  add_reader_flags(cmd, args.reader);
  cmd->callback([] { run_recording(args); });
}

}  // namespace fdv::cli
