// End-to-end benchmark of the streaming pipeline (fdv::Perception) on simulated data at a chosen
// event rate: per-window latency of each stage (median, p99, max), sustained throughput, whether
// a real-time stream would keep up, and peak memory. A plain program (CLI11), not Google
// Benchmark: one run streams many windows and reports distributions, not a mean per iteration.
//
//   build-perf/bench/pipeline_bench --preset fast_forward --rate 5 --threads 1
//   build-perf/bench/pipeline_bench --preset scene2_ball --rate 20 --threads 2
//   build-perf/bench/pipeline_bench --rate 5 --seconds 60 --sim-seconds 0.4     # memory
//   build-perf/bench/pipeline_bench --rate 5 --burst-rate 50                       # overload
//   build-perf/bench/pipeline_bench ... --windows-csv w.csv   # every window's stage times
//   build-perf/bench/pipeline_bench --rate 5 --seconds 3600 --rss-csv rss.csv --minutes-csv min.csv
//                                                               # soak: an hour of stream
//
// How the event rate is reached (docs/BENCHMARKS.md): the preset is simulated once at its own
// contrast threshold to measure its natural rate, then again with the contrast threshold (mean,
// spread and floor) scaled by natural / target — the event count of an edge sweep is inversely
// proportional to the threshold, so this is a more (or less) sensitive sensor on the same scene —
// with one more correction if the rate is off by more than 10 %. The achieved rate is printed.
// Everything is simulated into memory first; a stream longer than the simulation loops it with
// shifted timestamps (each loop restarts the vehicle's and the ball's motion).
//
// Streaming: 1 ms slices in time order — IMU, odometry and depth samples of the slice, then its
// events — pushed as fast as the pipeline takes them. Latency per window is Perception's own
// stage timing (steady clock); "work per window" is the pipeline's wall time between two window
// results (everything the pipeline did in between: depth registration and segmentation,
// estimation); "real-time lag" replays those work times against the 25 ms window period
// (lag_k = max(0, lag_{k-1} + work_k − Δt)): bounded lag means a live stream keeps up.
// Soak (--minutes-csv, --rss-csv): RSS is read every second of stream time and the window latency
// summarised per minute of it. The per-window samples are then kept for the current minute only
// (their buffers reused), so that the benchmark's own bookkeeping does not grow with the run: the
// closing table and --json then cover the last minute.
// Overload: --burst-rate adds uniformly random events (a flicker-like burst) for --burst-ms every
// --burst-every-s; the windower's decimation keeps each window bounded and reports the dropped
// events.
//
// --threads 1 runs everything on the calling thread (also OpenCV: cv::setNumThreads(1));
// --threads N > 1 splits each window's warp, time images, segmentation and pre-processing into N
// parts (CompensationOptions::threads) and lets OpenCV use N threads.
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "fdv/pipeline/perception.h"
#include "fdv/sim/simulator.h"

namespace fdv {
namespace {

using Clock = std::chrono::steady_clock;
double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

/// The simulated streams, in memory (labels and truth are not kept).
struct SimStream : sim::SimulationSink {
  Calibration calib;
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  std::vector<OdometrySample> odometry;
  std::vector<DepthFrame> depth;
  TimeNs duration = 0;
  double rate_meps() const {
    return static_cast<double>(events.size()) / to_seconds(duration) * 1e-6;
  }
  void on_events(std::span<const Event> e, std::span<const std::int16_t>) override {
    events.insert(events.end(), e.begin(), e.end());
  }
  void on_imu(const ImuSample& s) override { imu.push_back(s); }
  void on_depth(const DepthFrame& f) override { depth.push_back(f); }
  void on_odometry(const OdometrySample& s) override { odometry.push_back(s); }
};

SimStream simulate(const std::string& preset, std::uint64_t seed, double seconds,
                   double threshold_scale) {
  sim::ScenarioConfig c = sim::make_preset(preset, seed);
  if (seconds > 0) c.duration_s = seconds;
  c.event_camera.contrast_threshold_mean *= threshold_scale;
  c.event_camera.contrast_threshold_spread *= threshold_scale;
  c.event_camera.contrast_threshold_min *= threshold_scale;
  sim::Simulator simulator(c);
  SimStream s;
  simulator.run(s);
  s.calib = simulator.calibration();
  s.duration = from_seconds(c.duration_s);
  return s;
}

/// Scales the contrast threshold until the rate is within 10 % of the target (0 = natural): the
/// first step assumes rate ∝ 1/threshold, the next ones interpolate log(rate) against
/// log(scale) between the last two simulations (the relation is steeper than 1/x at high
/// thresholds, where faint edges stop firing at all).
SimStream simulate_at_rate(const std::string& preset, std::uint64_t seed, double seconds,
                           double target_meps, double& scale) {
  scale = 1.0;
  SimStream s = simulate(preset, seed, seconds, scale);
  std::printf("# %s natural rate %.2f M ev/s (contrast threshold x1)\n", preset.c_str(),
              s.rate_meps());
  double prev_scale = 0, prev_rate = 0;
  for (int i = 0; i < 6 && target_meps > 0 && std::abs(s.rate_meps() / target_meps - 1) > 0.1;
       ++i) {
    double next = scale * s.rate_meps() / target_meps;
    if (prev_scale > 0 && prev_rate > 0 && prev_rate != s.rate_meps()) {
      const double slope =
          std::log(s.rate_meps() / prev_rate) / std::log(scale / prev_scale);  // d log r / d log c
      if (slope < -0.2) next = scale * std::exp(std::log(target_meps / s.rate_meps()) / slope);
    }
    prev_scale = scale;
    prev_rate = s.rate_meps();
    scale = std::clamp(next, 0.05, 20.0);
    s = simulate(preset, seed, seconds, scale);
    std::printf("# contrast threshold x%.3f: %.2f M ev/s\n", scale, s.rate_meps());
  }
  return s;
}

struct Distribution {
  std::vector<double> v;
  double quantile(double q) const {
    if (v.empty()) return 0;
    std::vector<double> s = v;
    const auto k = static_cast<std::size_t>(
        std::min<double>(static_cast<double>(s.size() - 1), q * static_cast<double>(s.size())));
    std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(k), s.end());
    return s[k];
  }
  double max() const { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }
  nlohmann::json json() const {
    return {{"median", quantile(0.5)}, {"p99", quantile(0.99)}, {"max", max()}, {"n", v.size()}};
  }
};

long status_kb(const char* key) {  // VmRSS / VmHWM from /proc/self/status, -1 when unavailable
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind(key, 0) == 0) return std::stol(line.substr(std::string(key).size() + 1));
  return -1;
}

struct Args {
  std::string preset = "fast_forward";
  std::uint64_t seed = 1;
  double rate_meps = 5;       // 0 = the preset's natural rate
  double contrast_scale = 0;  // > 0: use this contrast threshold scale, no rate search
  double sim_seconds = 0;     // 0 = the preset's duration
  double seconds = 0;         // stream length; 0 = one pass over the simulation
  int threads = 1;
  std::string method = "rotation_translation";
  double burst_rate_meps = 0;
  double burst_ms = 100;
  double burst_every_s = 1.0;
  int warmup_windows = 8;
  std::string json;
  std::string windows_csv;
  std::string rss_csv;      // soak: RSS every second of stream
  std::string minutes_csv;  // soak: window latency per minute of stream
};

using CsvFile = std::unique_ptr<std::FILE, int (*)(std::FILE*)>;
CsvFile open_csv(const std::string& path, const char* header) {
  CsvFile f(path.empty() ? nullptr : std::fopen(path.c_str(), "w"), &std::fclose);
  if (f) std::fputs(header, f.get());
  return f;
}

int run(const Args& a) {
  cv::setNumThreads(a.threads);
  double scale = a.contrast_scale;
  const SimStream s = scale > 0
                          ? simulate(a.preset, a.seed, a.sim_seconds, scale)
                          : simulate_at_rate(a.preset, a.seed, a.sim_seconds, a.rate_meps, scale);
  const TimeNs period = s.duration;
  const TimeNs total = a.seconds > 0 ? from_seconds(a.seconds) : period;
  // Peak memory from here on: the kernel's high-water mark is reset (Linux ≥ 4.0), so the peak
  // covers the streaming (the simulated input stays resident and is included: see input_mb).
  const long rss_before_kb = status_kb("VmRSS");
  if (std::ofstream clear("/proc/self/clear_refs"); clear) clear << "5";
  const double input_mb =
      static_cast<double>(s.events.size() * sizeof(Event) +
                          s.depth.size() * (s.depth.empty() ? 0 : s.depth[0].depth_m.size() * 4)) /
      1e6;

  PerceptionOptions opt;
  opt.compensation.method = *parse_compensation_method(a.method);
  opt.threads = a.threads;
  std::map<std::string, Distribution> stage;
  Distribution work, work_cpu, depth_ms, estimate_ms;
  std::uint64_t windows = 0, decimated = 0, dropped_burst = 0, detections = 0,
                max_window_events = 0;
  std::map<std::string, int> used;
  // Pipeline wall clock: time spent inside push calls so far (feeding the data is not counted).
  double in_pipeline_ms = 0, in_pipeline_cpu_ms = 0, push_start_cpu = 0;
  Clock::time_point push_start{};
  auto pipeline_clock = [&] { return in_pipeline_ms + ms_between(push_start, Clock::now()); };
  auto pipeline_cpu = [&] { return in_pipeline_cpu_ms + thread_cpu_ms() - push_start_cpu; };
  double last_window_clock = 0, last_window_cpu = 0, lag = 0, max_lag = 0;
  const double window_ms = to_seconds(opt.windows.window_ns) * 1e3;
  PerceptionCallbacks cb;
  const std::vector<RegisteredSource> sources = registered_sources();
  std::string header = "window,events,status,detected,compensation,time_images,segmentation,preprocess,";
  for (const RegisteredSource& source : sources) header += std::string(source.name) + ",";
  const CsvFile windows_csv = open_csv(a.windows_csv, (header + "refine,detection,front_end\n").c_str());
  const CsvFile rss_csv = open_csv(a.rss_csv, "second,rss_mb,windows,lag_ms\n");
  const CsvFile minutes_csv = open_csv(
      a.minutes_csv, "minute,windows,window_total_median_ms,window_total_p99_ms,window_total_max_ms,"
                     "work_median_ms,work_p99_ms,rss_mb\n");
  for (const auto& [path, file] : {std::pair{&a.windows_csv, &windows_csv}, {&a.rss_csv, &rss_csv},
                                   {&a.minutes_csv, &minutes_csv}})
    if (!path->empty() && !*file) {
      std::fprintf(stderr, "cannot write %s\n", path->c_str());
      return 2;
    }
  const bool soak = static_cast<bool>(minutes_csv);
  // Closes a minute of stream for the soak: its latency row, then the samples start afresh.
  auto close_minute = [&](long minute, bool start_afresh) {
    const Distribution& total_ms = stage["window total"];
    std::fprintf(minutes_csv.get(), "%ld,%zu,%.4f,%.4f,%.4f,%.4f,%.4f,%.2f\n", minute, total_ms.v.size(),
                 total_ms.quantile(0.5), total_ms.quantile(0.99), total_ms.max(), work.quantile(0.5),
                 work.quantile(0.99), static_cast<double>(status_kb("VmRSS")) / 1024);
    std::fflush(minutes_csv.get());
    if (!start_afresh) return;
    for (auto& [name, d] : stage) d.v.clear();
    for (Distribution* d : {&work, &work_cpu, &depth_ms, &estimate_ms}) d->v.clear();
  };
  cb.on_window = [&](const WindowResult& w) {
    const double now = pipeline_clock(), now_cpu = pipeline_cpu();
    const double work_ms = now - last_window_clock, cpu_ms = now_cpu - last_window_cpu;
    last_window_clock = now;
    last_window_cpu = now_cpu;
    decimated += w.decimated;
    dropped_burst += w.compensation.dropped_burst;
    max_window_events = std::max<std::uint64_t>(max_window_events, w.events);
    lag = std::max(0.0, lag + work_ms - window_ms);
    max_lag = std::max(max_lag, lag);
    if (windows++ < static_cast<std::uint64_t>(a.warmup_windows)) return;
    detections += w.detections.size();
    ++used[std::string(to_string(w.compensation.used))];
    const DetectionTimings& d = w.timings.detection;
    stage["compensation"].v.push_back(w.timings.compensation_ms);
    stage["time_images"].v.push_back(d.time_images_ms);
    stage["compensation+time_images"].v.push_back(w.timings.compensation_ms + d.time_images_ms);
    stage["segmentation+preprocess"].v.push_back(d.segmentation_ms + d.preprocess_ms);
    double sources_ms = 0;
    for (const RegisteredSource& source : sources) {  // 0 in a window that did not try it
      stage["source " + std::string(source.name)].v.push_back(d.source_ms(source.name));
      sources_ms += d.source_ms(source.name);
    }
    stage["refine"].v.push_back(d.refine_ms);
    // What no stage timer covers: blanking between objects, the detection's mapping to raw pixels.
    stage["detection, other"].v.push_back(d.total_ms - d.time_images_ms - d.segmentation_ms - d.preprocess_ms -
                                          sources_ms - d.refine_ms);
    stage["detection (all)"].v.push_back(d.total_ms);
    stage["front end (comp+detection)"].v.push_back(w.timings.compensation_ms + d.total_ms);
    stage["tracking"].v.push_back(w.timings.tracking_ms);
    stage["window total"].v.push_back(w.timings.total_ms);
    work.v.push_back(work_ms);
    work_cpu.v.push_back(cpu_ms);
    if (windows_csv) {
      std::fprintf(windows_csv.get(), "%llu,%zu,%s,%zu,%.4f,%.4f,%.4f,%.4f,", static_cast<unsigned long long>(w.index),
                   w.events, std::string(to_string(w.status)).c_str(), w.detections.size(), w.timings.compensation_ms,
                   d.time_images_ms, d.segmentation_ms, d.preprocess_ms);
      for (const RegisteredSource& source : sources) std::fprintf(windows_csv.get(), "%.4f,", d.source_ms(source.name));
      std::fprintf(windows_csv.get(), "%.4f,%.4f,%.4f\n", d.refine_ms, d.total_ms,
                   w.timings.compensation_ms + d.total_ms);
    }
  };
  cb.on_depth = [&](const DepthResult& r) { depth_ms.v.push_back(r.ms); };
  cb.on_estimate = [&](const EstimateResult& r) { estimate_ms.v.push_back(r.ms); };
  Perception perception(s.calib, opt, cb);

  std::mt19937_64 rng(a.seed);
  std::vector<Event> slice;
  std::uint64_t events_pushed = 0, burst_events = 0;
  std::size_t ie = 0, ii = 0, io = 0, id = 0;
  auto timed = [&](auto&& push) {
    push_start = Clock::now();
    push_start_cpu = thread_cpu_ms();
    push();
    in_pipeline_ms += ms_between(push_start, Clock::now());
    in_pipeline_cpu_ms += thread_cpu_ms() - push_start_cpu;
  };
  const auto wall0 = Clock::now();
  constexpr TimeNs kNsPerSecond = 1000 * kNsPerMs;
  auto sample_rss = [&](long second) {
    if (rss_csv)
      std::fprintf(rss_csv.get(), "%ld,%.2f,%llu,%.3f\n", second, static_cast<double>(status_kb("VmRSS")) / 1024,
                   static_cast<unsigned long long>(windows), lag);
  };
  for (TimeNs t = 0; t < total; t += kNsPerMs) {
    if (t > 0 && t % kNsPerSecond == 0) {
      const long second = static_cast<long>(t / kNsPerSecond);
      sample_rss(second);
      if (soak && second % 60 == 0) close_minute(second / 60, true);
    }
    const TimeNs loop = t / period, offset = loop * period,
                 t_in = t - offset;  // time within the simulation
    if (t_in == 0) ie = ii = io = id = 0;
    const TimeNs end = std::min(t_in + kNsPerMs, period);
    for (; ii < s.imu.size() && s.imu[ii].t < end; ++ii) {
      ImuSample x = s.imu[ii];
      x.t += offset;
      timed([&] { perception.push_imu(x); });
    }
    for (; io < s.odometry.size() && s.odometry[io].t < end; ++io) {
      OdometrySample x = s.odometry[io];
      x.t += offset;
      timed([&] { perception.push_odometry(x); });
    }
    for (; id < s.depth.size() && s.depth[id].t < end; ++id) {
      DepthFrame x = s.depth[id];  // a copy per frame (30 Hz): outside the timed calls
      x.t += offset;
      timed([&] { perception.push_depth(x); });
    }
    slice.clear();
    for (; ie < s.events.size() && s.events[ie].t < end; ++ie) {
      Event e = s.events[ie];
      e.t += offset;
      slice.push_back(e);
    }
    const bool in_burst =
        a.burst_rate_meps > 0 &&
        std::fmod(to_seconds(t), a.burst_every_s) * 1e3 >= a.burst_every_s * 1e3 - a.burst_ms;
    if (in_burst) {  // extra uniformly random events up to the burst rate, merged in time order
      const auto extra = static_cast<std::size_t>(
          std::max(0.0, a.burst_rate_meps * 1e3 - static_cast<double>(slice.size())));
      const std::size_t n0 = slice.size();
      std::uniform_int_distribution<int> x(0, s.calib.event_camera.width - 1),
          y(0, s.calib.event_camera.height - 1);
      std::uniform_int_distribution<TimeNs> dt(0, kNsPerMs - 1);
      for (std::size_t k = 0; k < extra; ++k)
        slice.push_back({t + dt(rng), static_cast<std::uint16_t>(x(rng)),
                         static_cast<std::uint16_t>(y(rng)), true});
      std::sort(slice.begin() + static_cast<std::ptrdiff_t>(n0), slice.end(),
                [](const Event& p, const Event& q) { return p.t < q.t; });
      std::inplace_merge(slice.begin(), slice.begin() + static_cast<std::ptrdiff_t>(n0),
                         slice.end(), [](const Event& p, const Event& q) { return p.t < q.t; });
      burst_events += extra;
    }
    events_pushed += slice.size();
    timed([&] { perception.push_events(slice); });
  }
  timed([&] { perception.finish(); });
  const long last_second = static_cast<long>((total + kNsPerSecond - 1) / kNsPerSecond);
  sample_rss(last_second);
  if (soak) close_minute((last_second + 59) / 60, false);
  const double wall_s = ms_between(wall0, Clock::now()) / 1e3;
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  const long hwm_kb = status_kb("VmHWM");

  const double stream_s = to_seconds(total);
  if (soak) std::printf("# soak: the per-window statistics below are the last minute's (--minutes-csv has each)\n");
  std::printf(
      "# preset %s seed %llu, %.2f s stream (simulation %.2f s looped), contrast threshold x%.3f\n",
      a.preset.c_str(), static_cast<unsigned long long>(a.seed), stream_s, to_seconds(period),
      scale);
  std::printf("# threads %d (cv::getNumThreads %d), method %s, used:", a.threads,
              cv::getNumThreads(), a.method.c_str());
  for (const auto& [m, n] : used) std::printf(" %s %d", m.c_str(), n);
  std::printf(
      "\n# events %.2f M (%.2f M ev/s stream rate; %.2f M burst events), windows %llu (%d warm-up "
      "excluded), "
      "detections %llu\n",
      static_cast<double>(events_pushed) * 1e-6,
      static_cast<double>(events_pushed) / stream_s * 1e-6,
      static_cast<double>(burst_events) * 1e-6, static_cast<unsigned long long>(windows),
      a.warmup_windows, static_cast<unsigned long long>(detections));
  std::printf("%-30s %10s %10s %10s\n", "per window [ms]", "median", "p99", "max");
  std::vector<std::string> rows = {"compensation", "time_images", "compensation+time_images", "segmentation+preprocess"};
  for (const RegisteredSource& source : sources) rows.push_back("source " + std::string(source.name));
  for (const char* k : {"refine", "detection, other", "detection (all)", "front end (comp+detection)", "tracking",
                        "window total"})
    rows.emplace_back(k);
  for (const std::string& k : rows) {
    const Distribution& d = stage[k];
    std::printf("%-30s %10.3f %10.3f %10.3f\n", k.c_str(), d.quantile(0.5), d.quantile(0.99), d.max());
  }
  std::printf("%-30s %10.3f %10.3f %10.3f\n", "work per window (all stages)", work.quantile(0.5),
              work.quantile(0.99), work.max());
  std::printf("%-30s %10.3f %10.3f %10.3f\n", "  the same in thread CPU time",
              work_cpu.quantile(0.5), work_cpu.quantile(0.99), work_cpu.max());
  std::printf("%-30s %10.3f %10.3f %10.3f  (%zu)\n", "depth segmentation per frame",
              depth_ms.quantile(0.5), depth_ms.quantile(0.99), depth_ms.max(), depth_ms.v.size());
  std::printf("%-30s %10.3f %10.3f %10.3f  (%zu)\n", "estimator solve", estimate_ms.quantile(0.5),
              estimate_ms.quantile(0.99), estimate_ms.max(), estimate_ms.v.size());
  const double throughput = static_cast<double>(events_pushed) / (in_pipeline_ms / 1e3) * 1e-6;
  std::printf(
      "throughput: %.1f M ev/s sustained (%.3f s in the pipeline, %.3f s wall incl. feeding), "
      "%.1fx real time; %.1f M ev/s per CPU second of the calling thread (%.3f s)\n",
      throughput, in_pipeline_ms / 1e3, wall_s, stream_s / (in_pipeline_ms / 1e3),
      static_cast<double>(events_pushed) / (in_pipeline_cpu_ms / 1e3) * 1e-6,
      in_pipeline_cpu_ms / 1e3);
  std::printf("real-time lag: max %.2f ms (bounded = keeps up with a live stream)\n", max_lag);
  std::printf(
      "overload: windower decimated %llu events, compensation burst guard %llu; largest window "
      "%llu events\n",
      static_cast<unsigned long long>(decimated), static_cast<unsigned long long>(dropped_burst),
      static_cast<unsigned long long>(max_window_events));
  std::printf(
      "memory: peak RSS while streaming %.1f MB (VmHWM; ru_maxrss %.1f MB over the whole run incl. "
      "simulation), RSS before streaming %.1f MB, in-memory input %.1f MB\n",
      static_cast<double>(hwm_kb) / 1024, static_cast<double>(ru.ru_maxrss) / 1024,
      static_cast<double>(rss_before_kb) / 1024, input_mb);
  if (!a.json.empty()) {
    nlohmann::json j;
    j["preset"] = a.preset;
    j["seed"] = a.seed;
    j["rate_meps"] = static_cast<double>(events_pushed) / stream_s * 1e-6;
    j["threads"] = a.threads;
    j["contrast_threshold_scale"] = scale;
    for (const auto& [k, d] : stage) j["stages_ms"][k] = d.json();
    j["work_per_window_ms"] = work.json();
    j["work_per_window_cpu_ms"] = work_cpu.json();
    j["pipeline_cpu_s"] = in_pipeline_cpu_ms / 1e3;
    j["depth_ms"] = depth_ms.json();
    j["estimate_ms"] = estimate_ms.json();
    j["throughput_meps"] = throughput;
    j["max_lag_ms"] = max_lag;
    j["decimated"] = decimated;
    j["peak_rss_mb"] = static_cast<double>(hwm_kb) / 1024;
    j["rss_before_mb"] = static_cast<double>(rss_before_kb) / 1024;
    j["input_mb"] = input_mb;
    std::ofstream(a.json) << j.dump(2) << "\n";
  }
  return 0;
}

}  // namespace
}  // namespace fdv

int main(int argc, char** argv) {
  fdv::Args a;
  CLI::App app{"End-to-end pipeline benchmark on simulated data (docs/BENCHMARKS.md)"};
  app.add_option("--preset", a.preset, "simulator preset (fast_forward, scene2_ball, ...)");
  app.add_option("--seed", a.seed, "preset seed");
  app.add_option("--rate", a.rate_meps, "event rate [M events/s]; 0 = the preset's natural rate")
      ->check(CLI::Range(0.0, 200.0));
  app.add_option("--contrast-scale", a.contrast_scale,
                 "use this contrast threshold scale instead of searching for --rate (printed by an "
                 "earlier run)")
      ->check(CLI::Range(0.0, 20.0));
  app.add_option("--sim-seconds", a.sim_seconds, "seconds to simulate (0 = the preset's duration)")
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--seconds", a.seconds, "stream length [s] (loops the simulation; 0 = one pass)")
      ->check(CLI::Range(0.0, 3600.0));
  app.add_option("--threads", a.threads, "front-end and OpenCV threads")->check(CLI::Range(1, 64));
  app.add_option("--method", a.method, "compensation method");
  app.add_option("--burst-rate", a.burst_rate_meps,
                 "overload bursts at this rate [M events/s]; 0 = none")
      ->check(CLI::Range(0.0, 500.0));
  app.add_option("--burst-ms", a.burst_ms, "burst length [ms]")->check(CLI::Range(1.0, 10000.0));
  app.add_option("--burst-every-s", a.burst_every_s, "one burst per this many seconds")
      ->check(CLI::Range(0.01, 3600.0));
  app.add_option("--warmup", a.warmup_windows, "windows excluded from the statistics")
      ->check(CLI::Range(0, 1000));
  app.add_option("--json", a.json, "also write the figures to this JSON file");
  app.add_option("--windows-csv", a.windows_csv,
                 "also write every window's stage times [ms], status and event count to this CSV file (to find what "
                 "makes the slow windows slow)");
  app.add_option("--rss-csv", a.rss_csv, "soak: write the resident memory every second of stream to this CSV file");
  app.add_option("--minutes-csv", a.minutes_csv,
                 "soak: write the window latency of every minute of stream to this CSV file (per-window samples are "
                 "then kept for one minute only)");
  CLI11_PARSE(app, argc, argv);
  return fdv::run(a);
}
