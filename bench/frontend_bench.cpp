// Throughput of the detection front end on a synthetic 25 ms window at 5 M events/s, 640x480:
// each compensation method (events/s), compensation + time images against the plain reference
// implementations (reference_warp.h, reference_time_images.h: the speed-up of the optimised code,
// measured in the same run, is printed at the end), the detector's stages one by one
// (segmentation + pre-processing, Gaussian fit, region retrieval), and the detector and the whole
// front end per window (median, p99, max). Targets: compensation + time images
// rotation ≥ 100 M ev/s, rotation_translation ≥ 60 M ev/s; whole detection per window median
// ≤ 2 ms, p99 ≤ 3 ms on one thread, median ≤ 1 ms on both cores. "/threads:2" runs split the
// per-event stages in two (CompensationOptions::threads, CompensatedEventsView::threads) and let
// OpenCV use two threads; every other benchmark runs with cv::setNumThreads(1). BM_MemoryBandwidth
// and BM_TimeImagesFrame give the memory bound of the per-pixel passes at 1280x720.
//
//   cmake --build build-perf --target frontend_bench && build-perf/bench/frontend_bench
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <random>
#include <vector>

#include <cstdio>
#include <map>
#include <opencv2/core.hpp>
#include <string>

#include "fdv/compensation/compensator.h"
#include "fdv/compensation/reference_warp.h"
#include "fdv/compensation/undistortion_map.h"
#include "fdv/detection/detector.h"
#include "fdv/detection/event_refinement.h"
#include "fdv/detection/gaussian_fit_source.h"
#include "fdv/detection/hot_pixels.h"
#include "fdv/detection/reference_time_images.h"
#include "fdv/detection/segmentation.h"
#include "fdv/pipeline/detector_input.h"
#include "fdv/pipeline/event_windower.h"
#include "fdv/pipeline/perception.h"
#include "tests/detection/synthetic_scene.h"

namespace fdv {
namespace {

constexpr TimeNs kWindow = 25 * kNsPerMs;
constexpr int kEventsPerWindow = 125'000;  // 5 M ev/s

Calibration bench_calibration() {
  Calibration c;
  c.event_camera = {640, 480, 400.0, 401.0, 318.0, 243.0, {-0.1, 0.01, 0.0005, -0.0003, 0.0}};
  return c;
}

struct BenchWindow {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  OdometrySample odometry;
  RegisteredDepth depth;
};

// Uniformly random pixels and times (the worst case for the lookup tables' caches: real events
// cluster on edges), time-sorted; IMU at 1 kHz, a moving vehicle, depth everywhere 2-8 m.
const BenchWindow& bench_window() {
  static const BenchWindow w = [] {
    BenchWindow b;
    std::mt19937 rng(42);
    std::uniform_int_distribution<TimeNs> t(0, kWindow - 1);
    std::uniform_int_distribution<int> x(0, 639), y(0, 479);
    for (int i = 0; i < kEventsPerWindow; ++i)
      b.events.push_back({t(rng), static_cast<std::uint16_t>(x(rng)), static_cast<std::uint16_t>(y(rng)), true});
    std::sort(b.events.begin(), b.events.end(), [](const Event& a, const Event& c) { return a.t < c.t; });
    for (TimeNs s = -5 * kNsPerMs; s <= kWindow + 5 * kNsPerMs; s += kNsPerMs) b.imu.push_back({s, {0.5, -1.0, 2.0}, {0, 0, 9.81}});
    b.odometry.v_W = {2.0, 0.5, 0.0};
    b.depth.width = 640;
    b.depth.height = 480;
    std::uniform_real_distribution<float> z(2.0f, 8.0f);
    for (int i = 0; i < 640 * 480; ++i) b.depth.depth_m.push_back(z(rng));
    return b;
  }();
  return w;
}

test::BlobScene bench_scene(bool noisy);

// uniform = random pixels (worst case for the lookup tables), textured = the textured scene below
// (events concentrated on edges, as in real recordings).
/// OpenCV's thread count for one benchmark (restored after it).
struct CvThreads {
  int saved = cv::getNumThreads();
  explicit CvThreads(int n) { cv::setNumThreads(n); }
  ~CvThreads() { cv::setNumThreads(saved); }
};

/// The benchmark window's events: uniformly random pixels, or the textured scene.
std::span<const Event> bench_events(bool textured) {
  static const std::vector<Event> scene = test::make_scene(bench_calibration().event_camera, bench_scene(false));
  return textured ? std::span<const Event>(scene) : std::span<const Event>(bench_window().events);
}

void BM_Compensate(benchmark::State& state, const char* method, bool textured, int threads = 1) {
  const CvThreads cv_threads(threads);
  const BenchWindow& w = bench_window();
  CompensationOptions opt;
  opt.method = *parse_compensation_method(method);
  opt.threads = threads;
  auto comp = make_compensator(bench_calibration(), opt);
  const std::span<const Event> events = bench_events(textured);
  const CompensationInput in{events, 0, kWindow, w.imu, w.odometry, &w.depth};
  comp->compensate(in);  // warm-up: buffers, depth preparation
  for (auto _ : state) benchmark::DoNotOptimize(comp->compensate(in).size());
  const auto& r = comp->compensate(in).report;
  if (r.used != r.requested) state.SkipWithError(("fell back: " + r.brief()).c_str());
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(events.size()));
  state.counters["kept"] = static_cast<double>(r.events_kept);
}
BENCHMARK_CAPTURE(BM_Compensate, none_uniform, "none", false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Compensate, rotation_uniform, "rotation", false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Compensate, rotation_translation_uniform, "rotation_translation", false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Compensate, contrast_max_uniform, "contrast_max", false)->Unit(benchmark::kMillisecond)->Iterations(10);
BENCHMARK_CAPTURE(BM_Compensate, none_textured, "none", true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Compensate, rotation_textured, "rotation", true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Compensate, rotation_translation_textured, "rotation_translation", true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Compensate, contrast_max_textured, "contrast_max", true)->Unit(benchmark::kMillisecond)->Iterations(10);
BENCHMARK_CAPTURE(BM_Compensate, rotation_uniform/threads:2, "rotation", false, 2)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Compensate, rotation_translation_uniform/threads:2, "rotation_translation", false, 2)
    ->Unit(benchmark::kMillisecond);

/// The compensated window of `method` over `events` (uniform or textured), optimised or reference,
/// then its time images: the stage pair the first target is about.
void BM_CompensateAndTimeImages(benchmark::State& state, const char* method, bool textured, bool reference,
                                int threads) {
  const CvThreads cv_threads(threads);
  const BenchWindow& w = bench_window();
  CompensationOptions opt;
  opt.method = *parse_compensation_method(method);
  opt.threads = threads;
  auto comp = make_compensator(bench_calibration(), opt);
  const std::span<const Event> events = bench_events(textured);
  const CompensationInput in{events, 0, kWindow, w.imu, w.odometry, &w.depth};
  const CompensatedWindow& warm = comp->compensate(in);
  const ReferenceMotion motion = reference_motion(warm.report, opt);
  const PinholeCamera& cam = bench_calibration().event_camera;
  TimeImages ti;
  for (auto _ : state) {
    if (reference) {
      const ReferenceWarpResult r = reference_warp(cam, motion, in);
      CompensatedEventsView v{0, kWindow, cam.width, cam.height, r.pixel, r.t_s};
      reference_time_images(v, ti);
    } else {
      CompensatedEventsView v = detector_input(comp->compensate(in));
      v.threads = threads;
      build_time_images(v, ti);
    }
    benchmark::DoNotOptimize(ti.mean_normalized);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(events.size()));
}
#define FDV_PAIR(method, textured, label)                                                                         \
  BENCHMARK_CAPTURE(BM_CompensateAndTimeImages, label, method, textured, false, 1)->Unit(benchmark::kMillisecond); \
  BENCHMARK_CAPTURE(BM_CompensateAndTimeImages, label/threads:2, method, textured, false, 2)                       \
      ->Unit(benchmark::kMillisecond);                                                                            \
  BENCHMARK_CAPTURE(BM_CompensateAndTimeImages, label/reference, method, textured, true, 1)->Unit(benchmark::kMillisecond)
FDV_PAIR("rotation", false, rotation_uniform);
FDV_PAIR("rotation", true, rotation_textured);
FDV_PAIR("rotation_translation", false, rotation_translation_uniform);
FDV_PAIR("rotation_translation", true, rotation_translation_textured);
#undef FDV_PAIR

// Depth preparation (inverse depth, hole fill, median) when a new depth frame arrives; and, as bad
// input, a frame that is all invalid (every pixel 0, a hole).
void BM_DepthPreparation(benchmark::State& state, bool all_invalid) {
  const BenchWindow& w = bench_window();
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  auto comp = make_compensator(bench_calibration(), opt);
  RegisteredDepth depth = w.depth;
  if (all_invalid) std::fill(depth.depth_m.begin(), depth.depth_m.end(), 0.0f);
  const std::vector<Event> one{{0, 1, 1, true}};
  for (auto _ : state) {
    depth.t += 1;  // a "new" frame each time
    benchmark::DoNotOptimize(comp->compensate({one, 0, kWindow, w.imu, w.odometry, &depth}).size());
  }
}
BENCHMARK_CAPTURE(BM_DepthPreparation, valid, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthPreparation, all_invalid, true)->Unit(benchmark::kMillisecond);

// The lens inverse per raw pixel that every compensator builds when it is made (UndistortionMap):
// part of each new Perception's cost, not of a window's. The benchmark camera's lens (640x480).
void BM_UndistortionMap(benchmark::State& state) {
  const PinholeCamera camera = bench_calibration().event_camera;
  for (auto _ : state) benchmark::DoNotOptimize(UndistortionMap(camera).pixels_without_inverse());
}
BENCHMARK(BM_UndistortionMap)->Unit(benchmark::kMillisecond);

// Cutting the stream into windows (EventWindower, the pipeline's first stage): 40 windows of the
// benchmark window's events (5 M ev/s, 1 s) pushed in 1 ms slices, as a driver delivers them.
void BM_EventWindower(benchmark::State& state) {
  const std::vector<Event>& window = bench_window().events;
  std::vector<Event> stream;
  for (int k = 0; k < 40; ++k)
    for (Event e : window) {
      e.t += k * kWindow;
      stream.push_back(e);
    }
  std::vector<std::size_t> slice_starts;  // first event of each 1 ms slice
  for (std::size_t i = 0; i < stream.size(); ++i)
    if (i == 0 || stream[i].t / kNsPerMs != stream[i - 1].t / kNsPerMs) slice_starts.push_back(i);
  slice_starts.push_back(stream.size());
  std::size_t events_out = 0;
  const EventWindower::Callback on_window = [&](const EventWindow& w) { events_out += w.events.size(); };
  for (auto _ : state) {
    EventWindower windower({.window_ns = kWindow});
    for (std::size_t s = 0; s + 1 < slice_starts.size(); ++s)
      windower.push(std::span(stream).subspan(slice_starts[s], slice_starts[s + 1] - slice_starts[s]), on_window);
    windower.flush(on_window);
  }
  benchmark::DoNotOptimize(events_out);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * stream.size()));
}
BENCHMARK(BM_EventWindower)->Unit(benchmark::kMillisecond);

// Time images alone. Two windows alternate (as in a stream, where each window blanks what the
// previous one wrote), uniform pixels.
void BM_TimeImages(benchmark::State& state, bool reference, int threads) {
  const CvThreads cv_threads(threads);
  const BenchWindow& w = bench_window();
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotation;
  auto comp = make_compensator(bench_calibration(), opt);
  const std::size_t half = w.events.size() / 2;
  std::vector<std::int32_t> px[2];
  std::vector<float> t[2];
  for (int k = 0; k < 2; ++k) {  // two different windows: the events' pixels with shifted times
    const CompensatedWindow& cw = comp->compensate({w.events, 0, kWindow, w.imu});
    px[k].assign(cw.pixel().begin(), cw.pixel().end());
    t[k].assign(cw.t_s().begin(), cw.t_s().end());
    if (k == 1) std::rotate(px[k].begin(), px[k].begin() + static_cast<std::ptrdiff_t>(half), px[k].end());
  }
  TimeImages ti;
  std::size_t k = 0;
  for (auto _ : state) {
    CompensatedEventsView v{0, kWindow, 640, 480, px[k], t[k]};
    v.threads = threads;
    if (reference) reference_time_images(v, ti);
    else build_time_images(v, ti);
    benchmark::DoNotOptimize(ti.mean_normalized);
    k ^= 1;
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(px[0].size()));
}
BENCHMARK_CAPTURE(BM_TimeImages, optimised, false, 1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_TimeImages, optimised/threads:2, false, 2)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_TimeImages, reference, true, 1)->Unit(benchmark::kMillisecond);

// A sparse window: `events` events in a 32x32 patch of a width x height grid, alternating with
// a window at another place (a far ball, a quiet scene, a gap's windows). Its cost should follow
// the events, not the frame.
void BM_TimeImagesSparse(benchmark::State& state, int width, int height) {
  const auto events = static_cast<std::size_t>(state.range(0));
  std::vector<std::int32_t> px[2];
  std::vector<float> t[2];
  std::uint64_t lcg = 1;
  auto next = [&lcg](int n) {
    lcg = lcg * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<int>((lcg >> 33) % static_cast<std::uint64_t>(n));
  };
  for (int k = 0; k < 2; ++k) {
    const int u0 = k == 0 ? width / 4 : 3 * width / 4, v0 = k == 0 ? height / 4 : 3 * height / 4;
    for (std::size_t i = 0; i < events; ++i) {
      px[k].push_back((v0 + next(32)) * width + u0 + next(32));
      t[k].push_back(static_cast<float>(to_seconds(kWindow)) * static_cast<float>(i) / static_cast<float>(events));
    }
  }
  TimeImages ti;
  prepare_time_images(ti, width, height);
  std::size_t k = 0;
  for (auto _ : state) {
    const CompensatedEventsView v{0, kWindow, width, height, px[k], t[k]};
    build_time_images(v, ti);
    benchmark::DoNotOptimize(ti.mean_normalized);
    k ^= 1;
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(events));
}
BENCHMARK_CAPTURE(BM_TimeImagesSparse, 640x480, 640, 480)->Arg(100)->Arg(2000)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_TimeImagesSparse, 1280x720, 1280, 720)->Arg(100)->Arg(2000)->Unit(benchmark::kMicrosecond);

// A dense window: `events` events on uniformly random pixels of the whole frame, alternating with
// another such window (forward flight at 1280x720 is about 105 k events a window, and touches
// most of the frame's blocks). "frame_bytes" is the bytes the two passes move per window by
// time_images.cpp's layout: 40 per visited pixel (pass 1 reads the 8-byte accumulator and writes
// it back as 0, writes I, Σt and T, 4 bytes each; pass 2 reads I and T and writes N); as a rate,
// it is the bandwidth the passes reach (docs/BENCHMARKS.md, "Bytes per window").
void BM_TimeImagesFrame(benchmark::State& state, int width, int height) {
  const auto events = static_cast<std::size_t>(state.range(0));
  std::vector<std::int32_t> px[2];
  std::vector<float> t[2];
  std::mt19937 rng(3);
  std::uniform_int_distribution<std::int32_t> pixel(0, width * height - 1);
  for (int k = 0; k < 2; ++k)
    for (std::size_t i = 0; i < events; ++i) {
      px[k].push_back(pixel(rng));
      t[k].push_back(static_cast<float>(to_seconds(kWindow)) * static_cast<float>(i) / static_cast<float>(events));
    }
  TimeImages ti;
  prepare_time_images(ti, width, height);
  std::size_t k = 0;
  double visited_pixels = 0;
  for (auto _ : state) {
    const CompensatedEventsView v{0, kWindow, width, height, px[k], t[k]};
    build_time_images(v, ti);
    benchmark::DoNotOptimize(ti.mean_normalized);
    visited_pixels += 16.0 * static_cast<double>(ti.blocks_visited);
    k ^= 1;
  }
  constexpr double kPassBytesPerPixel = 40;
  state.counters["frame_bytes"] = benchmark::Counter(kPassBytesPerPixel * visited_pixels, benchmark::Counter::kIsRate);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(events));
}
BENCHMARK_CAPTURE(BM_TimeImagesFrame, 640x480, 640, 480)->Arg(50'000)->Arg(125'000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_TimeImagesFrame, 1280x720, 1280, 720)->Arg(105'000)->Arg(300'000)->Unit(benchmark::kMillisecond);

// Per-window time is measured as the thread's CPU time: this machine is shared (other builds
// run at the same time), and wall time then mostly measures the scheduler.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

double wall_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// median / p99 / max of per-window times: `ms` is the calling thread's CPU time (robust on a
/// shared machine, but blind to helper threads), `wall` the steady clock (what a second thread
/// can improve).
void report_distribution(benchmark::State& state, std::vector<double>& ms, std::vector<double>& wall) {
  for (auto* v : {&ms, &wall}) std::sort(v->begin(), v->end());
  auto q = [](const std::vector<double>& v, double f) { return v[std::min(v.size() - 1, static_cast<std::size_t>(f * static_cast<double>(v.size())))]; };
  state.counters["median_ms"] = q(ms, 0.5);
  state.counters["p99_ms"] = q(ms, 0.99);
  state.counters["max_ms"] = ms.back();
  state.counters["wall_median_ms"] = q(wall, 0.5);
  state.counters["wall_p99_ms"] = q(wall, 0.99);
}

// Scenes at ≈ 5 M ev/s (125 k events per 25 ms window) with a moving blob:
//  textured: a static, exactly compensated background of 400 edge segments carries most events
//            (what a compensated real scene looks like), 1 ev/px/s background activity;
//  noisy:    the same blob over 4 M ev/s of uniform noise (a pessimistic case: a third of the
//            pixels fire at random times, so much more survives the threshold).
test::BlobScene bench_scene(bool noisy) {
  test::BlobScene s;
  if (noisy) {
    s.noise_rate_ev_s = 4.0e6;
    s.edge_segments = 150;
    s.events_per_edge_px = 6;
  } else {
    s.noise_rate_ev_s = 0.3e6;
    s.edge_segments = 400;
    s.events_per_edge_px = 6;
  }
  return s;
}

void BM_Detector(benchmark::State& state, bool noisy, int threads) {
  const CvThreads cv_threads(threads);
  const Calibration calib = bench_calibration();
  const test::BlobScene s = bench_scene(noisy);
  const std::vector<Event> ev = test::make_scene(calib.event_camera, s);
  CompensationOptions opt;
  opt.method = CompensationMethod::kNone;
  auto comp = make_compensator(calib, opt);
  const CompensatedWindow& cw = comp->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
  Detector detector(DetectorOptions{}, calib.event_camera);
  std::vector<double> ms, wall;
  bool found = true;
  DetectionTimings sum;
  double fit_ms = 0;  // the paper's source: Algorithm 1 and region retrieval
  CompensatedEventsView view = detector_input(cw);
  view.threads = threads;
  for (auto _ : state) {
    const double t0 = thread_cpu_ms(), w0 = wall_ms();
    const DetectionResult r = detector.detect(view);
    ms.push_back(thread_cpu_ms() - t0);
    wall.push_back(wall_ms() - w0);
    found = found && !r.detections.empty();
    sum.time_images_ms += r.timings.time_images_ms;
    sum.segmentation_ms += r.timings.segmentation_ms;
    sum.preprocess_ms += r.timings.preprocess_ms;
    fit_ms += r.timings.source_ms(GaussianFitSource::kName);
    sum.refine_ms += r.timings.refine_ms;
  }
  const double n = static_cast<double>(ms.size());
  state.counters["events"] = static_cast<double>(cw.size());
  state.counters["detected"] = found ? 1 : 0;
  state.counters["ti_ms"] = sum.time_images_ms / n;
  state.counters["pre_ms"] = sum.preprocess_ms / n;
  state.counters["fit_ms"] = fit_ms / n;
  state.counters["ref_ms"] = sum.refine_ms / n;
  report_distribution(state, ms, wall);
}
BENCHMARK_CAPTURE(BM_Detector, textured, false, 1)->Unit(benchmark::kMillisecond)->Iterations(300);
BENCHMARK_CAPTURE(BM_Detector, noisy, true, 1)->Unit(benchmark::kMillisecond)->Iterations(300);
BENCHMARK_CAPTURE(BM_Detector, textured/threads:2, false, 2)->Unit(benchmark::kMillisecond)->Iterations(300);

/// A detector's intermediate images on the textured scene (time images, S, P), for the stages.
struct StageInputs {
  TimeImages ti;
  double theta = 0;
  cv::Mat S, P;
  cv::Point arg_max;
};
const StageInputs& stage_inputs() {
  static const StageInputs in = [] {
    StageInputs r;
    const Calibration calib = bench_calibration();
    const test::BlobScene s = bench_scene(false);
    const std::vector<Event> ev = test::make_scene(calib.event_camera, s);
    CompensationOptions opt;
    opt.method = CompensationMethod::kNone;
    auto comp = make_compensator(calib, opt);
    build_time_images(detector_input(comp->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration})), r.ti);
    const DetectorOptions o;
    r.theta = adaptive_threshold(r.ti.mean_normalized, 0, 0, o);
    cv::Mat scratch;
    segment(r.ti, r.theta, o.min_pixel_events, r.S);
    preprocess(r.S, o, r.P, scratch);
    cv::minMaxLoc(r.P, nullptr, nullptr, nullptr, &r.arg_max);
    return r;
  }();
  return in;
}

// Segmentation (threshold θ on N) and pre-processing (mean filter, opening, square) of one window,
// as the detector runs them (Preprocessor's buffers reused, only inside S's bounds).
void BM_SegmentationPreprocess(benchmark::State& state) {
  const CvThreads cv_threads(1);
  const StageInputs& in = stage_inputs();
  const DetectorOptions o;
  cv::Mat S;
  Preprocessor pre(o);
  for (auto _ : state) {
    const SegmentResult seg = segment(in.ti, in.theta, o.min_pixel_events, S);
    benchmark::DoNotOptimize(pre.run(S, seg.bounds).data);
  }
}
BENCHMARK(BM_SegmentationPreprocess)->Unit(benchmark::kMillisecond);

// Algorithm 1 from the strongest pattern with the half-image ROI.
void BM_GaussianFit(benchmark::State& state) {
  const CvThreads cv_threads(1);
  const StageInputs& in = stage_inputs();
  const DetectorOptions o;
  GaussianFit fit;
  for (auto _ : state) {
    fit = iterative_gaussian_fit(in.P, Eigen::Vector2d(in.arg_max.x, in.arg_max.y), Eigen::Vector2d(320, 240), o);
    benchmark::DoNotOptimize(fit.center);
  }
  state.counters["iterations"] = fit.iterations;
}
BENCHMARK(BM_GaussianFit)->Unit(benchmark::kMicrosecond);

// Moving-region retrieval (connected components in the half-image search area).
void BM_RegionRetrieval(benchmark::State& state) {
  const CvThreads cv_threads(1);
  const StageInputs& in = stage_inputs();
  const DetectorOptions o;
  const Box2D initial{in.arg_max.x - 160.0, in.arg_max.y - 120.0, in.arg_max.x + 160.0, in.arg_max.y + 120.0};
  const cv::Rect search = box_pixels(initial, 640, 480);
  RegionScratch scratch;
  scratch.reserve(640, 480);
  for (auto _ : state) {
    const auto region = retrieve_region(in.P, initial, search, o, scratch);
    benchmark::DoNotOptimize(region);
  }
}
BENCHMARK(BM_RegionRetrieval)->Unit(benchmark::kMicrosecond);

// The event refinement of one detection (EventRefiner::refine) at 346x260: a ball of the given
// radius [px] whose rim makes events as it moves 10 px to the right over the 25 ms window (ten
// sweeps), on 1000 background events, time-sorted, and a box on a fragment of its leading edge at
// the window's middle, so that the square grows while it cuts the ball (up to the options' largest
// square). The grown cases' time is mostly the outline fit's SVD fallback, which real balls seldom
// reach; the pipeline's `refine` column (bench/run_timing_compare.py --stage refine) is the figure
// for recordings.
void BM_EventRefinement(benchmark::State& state) {
  constexpr int kWidth = 346, kHeight = 260;
  const double radius = static_cast<double>(state.range(0));
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<std::pair<float, std::int32_t>> events;  // (t [s], pixel)
  for (int i = 0; i < 1000; ++i)
    events.emplace_back(0.025f * unit(rng), static_cast<std::int32_t>(unit(rng) * (kWidth * kHeight - 1)));
  for (int step = 0; step < 10; ++step) {
    const float t = 0.025f * (static_cast<float>(step) + 0.5f) / 10;
    const double cx = 168 + 10.0 * t / 0.025, cy = 130;
    for (int y = static_cast<int>(cy - radius - 1); y <= static_cast<int>(cy + radius + 1); ++y)
      for (int x = static_cast<int>(cx - radius - 1); x <= static_cast<int>(cx + radius + 1); ++x)
        if (std::abs(std::hypot(x - cx, y - cy) - radius) < 0.7) events.emplace_back(t, y * kWidth + x);
  }
  std::sort(events.begin(), events.end());
  std::vector<std::int32_t> pixel;
  std::vector<float> t_s;
  for (const auto& [t, px] : events) t_s.push_back(t), pixel.push_back(px);
  CompensatedEventsView view{0, kWindow, kWidth, kHeight, pixel, t_s};
  view.time_sorted = true;
  const double lead = 173 + radius;  // the leading edge at the middle time
  const Box2D fragment{lead - 4, 126, lead + 2, 134};
  EventRefiner refiner{DetectorOptions{}};
  refiner.allocate(kWidth, kHeight);
  std::optional<RefinedCenter> r;
  for (auto _ : state) {
    r = refiner.refine(view, fragment, 0.0125);
    benchmark::DoNotOptimize(r);
  }
  if (!r) return state.SkipWithError("no refinement");
  state.counters["events"] = static_cast<double>(pixel.size());
  state.counters["extent_px"] = r->extent_px;
  state.counters["center_x"] = r->center.x();
}
BENCHMARK(BM_EventRefinement)->Arg(6)->Arg(20)->Arg(40)->Unit(benchmark::kMicrosecond);

// Whole front end per window: rotation_translation compensation + detection. The scene is seen
// from a vehicle at rest (IMU and odometry report zero motion) so that the events and the motion
// agree; the warp does the same per-event work as in flight.
void BM_FrontEnd(benchmark::State& state, bool noisy, int threads) {
  const CvThreads cv_threads(threads);
  const Calibration calib = bench_calibration();
  const test::BlobScene s = bench_scene(noisy);
  const std::vector<Event> ev = test::make_scene(calib.event_camera, s);
  const BenchWindow& w = bench_window();
  std::vector<ImuSample> imu = w.imu;
  for (auto& sample : imu) sample.gyro_rad_s.setZero();
  OdometrySample at_rest;
  CompensationOptions opt;
  opt.method = CompensationMethod::kRotationTranslation;
  opt.threads = threads;
  auto comp = make_compensator(calib, opt);
  Detector detector(DetectorOptions{}, calib.event_camera);
  const CompensationInput in{ev, s.t0, s.t0 + s.duration, imu, at_rest, &w.depth};
  if (comp->compensate(in).report.used != CompensationMethod::kRotationTranslation) state.SkipWithError("fell back");
  std::vector<double> ms, wall;
  for (auto _ : state) {
    const double t0 = thread_cpu_ms(), w0 = wall_ms();
    CompensatedEventsView view = detector_input(comp->compensate(in));
    view.threads = threads;
    const DetectionResult r = detector.detect(view);
    benchmark::DoNotOptimize(r.status);
    ms.push_back(thread_cpu_ms() - t0);
    wall.push_back(wall_ms() - w0);
  }
  state.counters["events"] = static_cast<double>(ev.size());
  report_distribution(state, ms, wall);
}
BENCHMARK_CAPTURE(BM_FrontEnd, textured, false, 1)->Unit(benchmark::kMillisecond)->Iterations(300);
BENCHMARK_CAPTURE(BM_FrontEnd, noisy, true, 1)->Unit(benchmark::kMillisecond)->Iterations(300);
BENCHMARK_CAPTURE(BM_FrontEnd, textured/threads:2, false, 2)->Unit(benchmark::kMillisecond)->Iterations(300);
BENCHMARK_CAPTURE(BM_FrontEnd, noisy/threads:2, true, 2)->Unit(benchmark::kMillisecond)->Iterations(300);

// The hot-pixel filter that Perception runs on each window's raw events before the front end
// (DetectorOptions::hot_pixels): its cost adds to BM_FrontEnd's. Eight windows of the scene with
// different seeds in turn, each a fresh copy (the copy is not timed), as a stream of windows.
void BM_HotPixelFilter(benchmark::State& state, bool noisy) {
  const Calibration calib = bench_calibration();
  std::vector<std::vector<Event>> windows;
  for (unsigned seed = 1; seed <= 8; ++seed) {
    test::BlobScene s = bench_scene(noisy);
    s.seed = seed;
    windows.push_back(test::make_scene(calib.event_camera, s));
  }
  HotPixelFilter filter(HotPixelOptions{}, calib.event_camera.width, calib.event_camera.height);
  std::vector<Event> buffer;
  buffer.reserve(2 * windows.front().size());
  std::vector<double> ms, wall;
  std::uint64_t k = 0;
  std::size_t dropped = 0;
  for (auto _ : state) {
    buffer.assign(windows[k % windows.size()].begin(), windows[k % windows.size()].end());
    const double t0 = thread_cpu_ms(), w0 = wall_ms();
    dropped += filter.filter(buffer, k++);
    ms.push_back(thread_cpu_ms() - t0);
    wall.push_back(wall_ms() - w0);
  }
  state.counters["events"] = static_cast<double>(windows.front().size());
  state.counters["dropped"] = static_cast<double>(dropped) / static_cast<double>(k);
  report_distribution(state, ms, wall);
}
BENCHMARK_CAPTURE(BM_HotPixelFilter, textured, false)->Unit(benchmark::kMillisecond)->Iterations(300);
BENCHMARK_CAPTURE(BM_HotPixelFilter, noisy, true)->Unit(benchmark::kMillisecond)->Iterations(300);

// Bad input through the whole Perception (BadInputWork.* in tests/pipeline/sensor_noise_test.cpp
// asserts the work bounds by count; this is their time per window): each iteration pushes one
// window of
//   overload     10x the benchmark window's events (1.25 M, uniformly random): the windower
//                decimates it to max_events_per_window (1 M) before any stage;
//   hot_pixels   only 2,000 isolated pixels firing at 1 kHz (50,000 events), learned in the 10
//                windows before the timing: the filter drops them all, no stage sees an event.
// A window is complete when the next one's first event arrives, so iteration k times window k-1.
void BM_BadInputWindow(benchmark::State& state, bool overload) {
  const Calibration calib = bench_calibration();
  std::vector<Event> window;
  std::mt19937 rng(9);
  if (overload) {
    for (int copy = 0; copy < 10; ++copy)
      for (const Event& e : bench_window().events) window.push_back({e.t, static_cast<std::uint16_t>(rng() % 640),
                                                                     static_cast<std::uint16_t>(rng() % 480), true});
  } else {
    for (int i = 0; i < 2000; ++i) {
      const auto x = static_cast<std::uint16_t>(4 + 8 * (i % 79)), y = static_cast<std::uint16_t>(4 + 8 * (i / 79));
      for (TimeNs t = static_cast<TimeNs>(rng() % kNsPerMs); t < kWindow; t += kNsPerMs) window.push_back({t, x, y, true});
    }
  }
  std::sort(window.begin(), window.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  PerceptionOptions o;
  o.compensation.method = CompensationMethod::kNone;
  o.detection.hot_pixels.enabled = !overload;
  o.estimate_trajectories = false;
  std::uint64_t processed = 0, windows = 0;
  PerceptionCallbacks cb;
  cb.on_window = [&](const WindowResult& w) {
    processed += w.compensation.events_in;
    ++windows;
  };
  Perception p(calib, o, cb);
  std::vector<Event> shifted(window.size());
  TimeNs offset = 0;
  const auto push_next = [&] {
    for (std::size_t i = 0; i < window.size(); ++i) shifted[i] = {window[i].t + offset, window[i].x, window[i].y, window[i].polarity};
    p.push_events(shifted);
    offset += kWindow;
  };
  for (int warm = 0; warm < 10; ++warm) push_next();
  processed = windows = 0;
  std::vector<double> ms, wall;
  for (auto _ : state) {
    const double t0 = thread_cpu_ms(), w0 = wall_ms();
    push_next();
    ms.push_back(thread_cpu_ms() - t0);
    wall.push_back(wall_ms() - w0);
  }
  state.counters["events_in"] = static_cast<double>(window.size());
  state.counters["events_processed"] = static_cast<double>(processed) / static_cast<double>(std::max<std::uint64_t>(windows, 1));
  report_distribution(state, ms, wall);
}
BENCHMARK_CAPTURE(BM_BadInputWindow, overload, true)->Unit(benchmark::kMillisecond)->Iterations(30);
BENCHMARK_CAPTURE(BM_BadInputWindow, hot_pixels, false)->Unit(benchmark::kMillisecond)->Iterations(300);

// This core's memory bandwidth: the bound of the front end's per-pixel passes (docs/BENCHMARKS.md,
// "Bytes per window"). Plain loops with ordinary stores, as the passes have (no streaming stores,
// no memcpy): read sums the buffer, write fills it, copy reads one and writes another (bytes count
// both). Buffers of range(0) MiB: 1 stays in the L2, 16 in the L3, 256 goes to DRAM.
enum class MemoryAccess { kRead, kWrite, kCopy };
void BM_MemoryBandwidth(benchmark::State& state, MemoryAccess access) {
  const std::size_t n = (static_cast<std::size_t>(state.range(0)) << 20) / sizeof(std::uint64_t);
  std::vector<std::uint64_t> from(n, 1), to(n, 0);
  std::uint64_t sweep = 0;
  for (auto _ : state) {
    ++sweep;
    if (access == MemoryAccess::kRead) {
      std::uint64_t sum = 0;
      for (std::uint64_t v : from) sum += v;
      benchmark::DoNotOptimize(sum);
    } else if (access == MemoryAccess::kWrite) {
      for (std::uint64_t& v : to) v = sweep;
    } else {
      for (std::size_t i = 0; i < n; ++i) to[i] = from[i] + sweep;
    }
    benchmark::ClobberMemory();
  }
  const std::size_t moved = (access == MemoryAccess::kCopy ? 2 : 1) * n * sizeof(std::uint64_t);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * moved));
}
BENCHMARK_CAPTURE(BM_MemoryBandwidth, read, MemoryAccess::kRead)->Arg(1)->Arg(16)->Arg(256)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MemoryBandwidth, write, MemoryAccess::kWrite)->Arg(1)->Arg(16)->Arg(256)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_MemoryBandwidth, copy, MemoryAccess::kCopy)->Arg(1)->Arg(16)->Arg(256)->Unit(benchmark::kMillisecond);

/// Console output as usual, and the CPU time of every run kept for the speed-up table.
class RecordingReporter : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> cpu_ms, wall_ms;  // per iteration (all paired runs are in ms)
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs)
      if (r.run_type == Run::RT_Iteration) {
        cpu_ms[r.benchmark_name()] = r.GetAdjustedCPUTime();
        wall_ms[r.benchmark_name()] = r.GetAdjustedRealTime();
      }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace
}  // namespace fdv

// Google Benchmark's main, plus the speed-up of each optimised stage over its plain reference,
// both measured in this run (CPU time per iteration).
int main(int argc, char** argv) {
  cv::setNumThreads(1);  // benchmarks that want two threads say so (CvThreads)
  // --benchmark_format=csv/json: Google Benchmark's own reporter, no table.
  bool console = true;
  for (int i = 1; i < argc; ++i)
    console = console && std::string(argv[i]).rfind("--benchmark_format=", 0) != 0;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  if (!console) {
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
  }
  fdv::RecordingReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  std::printf("\nspeed-up of the optimised code over the reference, same run (one thread: CPU time; two "
              "threads: wall time against the reference's wall time):\n");
  for (const auto& [name, ref_cpu] : reporter.cpu_ms) {
    const std::size_t at = name.find("/reference");
    if (at == std::string::npos) continue;
    for (const bool two : {false, true}) {
      std::string opt = name.rfind("BM_TimeImages", 0) == 0 ? "BM_TimeImages/optimised" : name.substr(0, at);
      if (two) opt += "/threads:2";
      const auto& table = two ? reporter.wall_ms : reporter.cpu_ms;
      const double ref = two ? reporter.wall_ms[name] : ref_cpu;
      if (const auto it = table.find(opt); it != table.end())
        std::printf("  %-58s %6.2fx  (%.3f ms vs %.3f ms)\n", opt.c_str(), ref / it->second, it->second, ref);
    }
  }
  benchmark::Shutdown();
  return 0;
}
