// No heap allocation per window in the event path once warmed up: windower -> compensation (all
// three IMU / odometry driven methods, new depth frames included) -> time images -> detector. A
// counting global operator new / delete replaces the library's in this test binary only (its own
// executable: the replacement is process-wide), and counts while a window is being processed.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "detection/synthetic_scene.h"
#include "fdv/compensation/compensator.h"
#include "fdv/detection/detector.h"
#include "fdv/detection/time_images.h"
#include "fdv/detection/track_aided_source.h"
#include "fdv/pipeline/event_windower.h"

namespace {

std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};

void* counted_alloc(std::size_t n, std::size_t align = 0) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (n == 0) n = 1;
  void* p = align > alignof(std::max_align_t) ? std::aligned_alloc(align, (n + align - 1) / align * align) : std::malloc(n);
  if (!p) throw std::bad_alloc();
  return p;
}

}  // namespace

void* operator new(std::size_t n) { return counted_alloc(n); }
void* operator new[](std::size_t n) { return counted_alloc(n); }
void* operator new(std::size_t n, std::align_val_t a) { return counted_alloc(n, static_cast<std::size_t>(a)); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_alloc(n, static_cast<std::size_t>(a)); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted_alloc(n);
  } catch (...) {
    return nullptr;
  }
}
// counted_alloc() takes its memory from malloc, so free() is the matching release; GCC at -O1
// (the sanitizer build) inlines these into gtest's `new TestClass` and takes the pair for a
// mismatch.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace fdv {
namespace {

constexpr TimeNs kWindow = 25 * kNsPerMs;
constexpr int kWindows = 16, kWarmUp = 4;

PinholeCamera camera() { return {640, 480, 400.0, 401.0, 318.0, 243.0, {-0.1, 0.01, 0.0005, -0.0003, 0.0}}; }

/// kWindows windows of a moving blob over a textured background (~5 M ev/s), IMU, odometry, and
/// one registered depth frame per window (with holes), like a flight.
struct Stream {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  OdometrySample odometry;
  std::vector<RegisteredDepth> depth;
};

Stream make_stream() {
  Stream s;
  for (int k = 0; k < kWindows; ++k) {
    test::BlobScene scene;
    scene.t0 = k * kWindow;
    scene.seed = static_cast<unsigned>(k + 1);
    scene.edge_segments = 300;
    scene.events_per_edge_px = 6;
    scene.start_uv = {150.0 + 10 * k, 150.0};
    const std::vector<Event> ev = test::make_scene(camera(), scene);
    s.events.insert(s.events.end(), ev.begin(), ev.end());
    RegisteredDepth d;
    d.t = scene.t0 + kWindow / 2;
    d.width = 640;
    d.height = 480;
    d.depth_m.assign(640 * 480, 3.0f + 0.1f * static_cast<float>(k));
    for (std::size_t i = 0; i < d.depth_m.size(); i += 7) d.depth_m[i] = 0;  // holes
    s.depth.push_back(std::move(d));
  }
  for (TimeNs t = -10 * kNsPerMs; t <= (kWindows + 1) * kWindow; t += kNsPerMs)
    s.imu.push_back({t, {0.3, -0.5, 1.0}, {0, 0, 9.81}});
  s.odometry.v_W = {2.0, 0.3, 0.1};
  return s;
}

/// Streams through the windower in 1 ms runs; returns allocations per processed window (after
/// the warm-up) for the windower + compensation + time images part, and for the detector.
struct Counts {
  long path = 0, detector = 0;
  int windows = 0;
  int candidates = 0, retrievals = 0, motion_cues = 0, count_cues = 0;  ///< detector paths taken (DetectionResult)
  int detected = 0;  ///< windows with at least one detection
};

Counts run(const char* method, std::size_t max_events_per_window, const DetectorOptions& detector_options = {},
           std::span<const DetectionPrior> priors = {}) {
  static const Stream s = make_stream();
  Calibration calib;
  calib.event_camera = camera();
  CompensationOptions copt;
  copt.method = *parse_compensation_method(method);
  auto comp = make_compensator(calib, copt);
  Detector detector(detector_options, calib.event_camera);
  EventWindower windower({.window_ns = kWindow, .max_events_per_window = max_events_per_window});
  TimeImages ti;
  Counts c;
  int index = 0;
  // Built once, outside the loop: a std::function made from a capturing lambda at each call would
  // itself allocate (that would be the caller's allocation, not the path's).
  const EventWindower::Callback on_window = [&](const EventWindow& w) {
    ++index;
    const RegisteredDepth& depth = s.depth[static_cast<std::size_t>(w.index) % s.depth.size()];
    const CompensationInput in{w.events, w.t_start, w.t_end, s.imu, s.odometry, &depth};
    const CompensatedWindow& cw = comp->compensate(in);
    CompensatedEventsView v{cw.t_start, cw.t_end, cw.width, cw.height, cw.pixel(), cw.t_s()};
    build_time_images(v, ti);
    const long before_detector = g_allocations.load();
    const DetectionResult r = detector.detect(v, priors);
    const long in_detector = g_allocations.load() - before_detector;
    g_allocations -= in_detector;  // what is left is the path's
    if (g_counting) {
      c.detector += in_detector;
      ++c.windows;
      c.candidates += r.candidates;
      c.detected += !r.detections.empty();
      // Retrieval runs when a pattern's fit is rejected.
      for (const std::string_view pattern_source : {GaussianFitSource::kName, TrackAidedSource::kName})
        if (const auto* fit = r.diagnostics<PatternFitDiagnostics>(pattern_source))
          c.retrievals += !fit->fit_rejected.empty();
      c.motion_cues += test::ran(r, DenseMotionSource::kName);
      c.count_cues += test::ran(r, CountContrastSource::kName);
    }
  };
  const std::span<const Event> all(s.events);
  std::size_t i = 0;
  for (TimeNs t = kNsPerMs; i < all.size(); t += kNsPerMs) {
    const std::size_t j = static_cast<std::size_t>(
        std::lower_bound(all.begin() + static_cast<std::ptrdiff_t>(i), all.end(), t,
                         [](const Event& e, TimeNs x) { return e.t < x; }) - all.begin());
    g_allocations = 0;
    g_counting = index >= kWarmUp;  // every window completed by this run is measured
    windower.push(all.subspan(i, j - i), on_window);
    if (g_counting) c.path += g_allocations.load();
    g_counting = false;
    i = j;
  }
  g_counting = false;
  return c;
}

TEST(NoAllocation, WindowerCompensationAndTimeImagesAfterWarmUp) {
  for (const char* method : {"none", "rotation", "rotation_translation"}) {
    SCOPED_TRACE(method);
    const Counts c = run(method, 1'000'000);
    ASSERT_EQ(c.windows, kWindows - kWarmUp - 1);  // the last window is never completed
    EXPECT_EQ(c.path, 0) << "allocations in " << c.windows << " windows";
  }
}

TEST(NoAllocation, DecimatedWindowsToo) {
  // The overload policy's decimation (every k-th event into a reused buffer) must not allocate.
  const Counts c = run("rotation", 50'000);
  EXPECT_EQ(c.path, 0);
}

TEST(NoAllocation, CountingAllocatorSeesAllocations) {
  // The counter itself works (else the tests above could not fail).
  g_allocations = 0;
  g_counting = true;
  auto* v = new std::vector<int>(100);
  g_counting = false;
  delete v;
  EXPECT_GE(g_allocations.exchange(0), 2);
}

TEST(NoAllocation, DetectorAfterWarmUp) {
  // Time images, segmentation, pre-processing, the candidates' Gaussian fits, region retrieval
  // and refinement, and the search for a further object, all work in the Detector's buffers (sized
  // in its constructor). The one allocation of a window with a detection is the result's list.
  const Counts c = run("rotation_translation", 1'000'000);
  ASSERT_EQ(c.windows, kWindows - kWarmUp - 1);
  EXPECT_GT(c.detected, 0);
  EXPECT_EQ(c.detector, c.detected) << "allocations in " << c.windows << " windows";
}

TEST(NoAllocation, EvidenceSourceToo) {
  // The evidence source (off by default) updates its grids every window: its cell counts, the
  // ego-motion map and the paths work in buffers sized once.
  DetectorOptions o;
  o.evidence.enabled = true;
  o.evidence.warmup_windows = 0;  // its evidence pass too, not only the learning
  const Counts c = run("rotation_translation", 1'000'000, o);
  ASSERT_EQ(c.windows, kWindows - kWarmUp - 1);
  EXPECT_EQ(c.detector, c.detected) << "allocations in " << c.windows << " windows";
}

TEST(NoAllocation, DetectorRetrievalBlankingAndPriorsToo) {
  // The paths a clean blob does not take: a fit that never converges (one iteration) sends every
  // candidate to region retrieval, an unreachable event density fails them all (blanking and the
  // next candidates), and a track's prior adds the track-aided look and the dense-motion source; the
  // count-contrast source runs when all of them fail.
  DetectorOptions o;
  o.fit_max_iterations = 1;
  o.min_event_density = 1e3;
  const DetectionPrior prior{{200.0, 150.0}, {30.0, 30.0}};
  const Counts c = run("rotation_translation", 1'000'000, o, std::span<const DetectionPrior>(&prior, 1));
  ASSERT_EQ(c.windows, kWindows - kWarmUp - 1);
  EXPECT_GT(c.candidates, c.windows);  // several candidates per window, and retrieval, were run
  EXPECT_GT(c.retrievals, 0);
  EXPECT_GT(c.motion_cues, 0);
  EXPECT_GT(c.count_cues, 0);
  EXPECT_EQ(c.detector, c.detected) << "allocations in " << c.windows << " windows";
}

}  // namespace
}  // namespace fdv
