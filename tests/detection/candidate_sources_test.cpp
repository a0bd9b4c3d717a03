// Each candidate source alone, on hand-made event windows whose answer is known in closed form: a
// symmetric blob's candidate is centred on it, a time plane's fit explains all of T's variance.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "fdv/detection/count_contrast_source.h"
#include "fdv/detection/dense_motion_source.h"
#include "fdv/detection/event_refinement.h"
#include "fdv/detection/gaussian_fit_source.h"
#include "fdv/detection/track_aided_source.h"
#include "synthetic_scene.h"

namespace fdv {
namespace {

constexpr int kWidth = 160, kHeight = 120;
constexpr double kWindowS = 0.025;

/// Events on a kWidth × kHeight grid, and everything a SourceWindow borrows, built from them as
/// Detector::detect builds it (θ = mean(N) + c: a static camera).
struct HandMadeWindow {
  std::vector<std::int32_t> pixel;
  std::vector<float> t_s;
  TimeImages ti;
  cv::Mat S;
  std::optional<Preprocessor> pre;
  RegionScratch scratch;
  std::vector<Box2D> gates;
  std::vector<Box2D> tentative_gates;
  CompensatedEventsView view;
  double theta = 0;
  double speed_m_s = 0;  ///< the camera's ‖v‖ (θ's b‖v‖ term); 0: a still camera

  void add(int x, int y, int events, double t) {
    for (int k = 0; k < events; ++k) {
      pixel.push_back(y * kWidth + x);
      t_s.push_back(static_cast<float>(t));
    }
  }
  /// A side × side square of pixels centred on (cx, cy), `events` each at time t(x, y).
  template <typename TimeOf>
  void add_square(int cx, int cy, int side, int events, TimeOf t) {
    for (int y = cy - side / 2; y <= cy + side / 2; ++y)
      for (int x = cx - side / 2; x <= cx + side / 2; ++x) add(x, y, events, t(x, y));
  }
  SourceWindow build(const DetectorOptions& o) {
    view = {0, from_seconds(kWindowS), kWidth, kHeight, pixel, t_s};
    view.speed_m_s = speed_m_s;
    build_time_images(view, ti);
    theta = adaptive_threshold(ti.mean_normalized, 0, speed_m_s, o);
    const SegmentResult seg = segment(ti, theta, o.min_pixel_events, S);
    pre.emplace(o);
    const cv::Mat& P = pre->run(S, seg.bounds);
    scratch.reserve(kWidth, kHeight);
    return {.events = view,
            .ti = ti,
            .S = S,
            .P = P,
            .P_support = pre->nonzero_bounds(),
            .P_max = pre->first_max(),
            .theta = theta,
            .window_s = kWindowS,
            .gates = gates,
            .tentative_gates = tentative_gates,
            .region_scratch = scratch};
  }
};

/// Sparse early background in the top rows (one event per pixel, below min_pixel_events) and a late
/// 9x9 blob below them: N = 1 on the blob, 0 elsewhere.
HandMadeWindow late_blob(int cx, int cy) {
  HandMadeWindow w;
  for (int y = 2; y < 40; y += 6)
    for (int x = 2; x < kWidth; x += 6) w.add(x, y, 1, 0.001);
  w.add_square(cx, cy, 9, 3, [](int, int) { return 0.024; });
  return w;
}

// The blob is symmetric about its centre, and so are S, P and Algorithm 1's weights: the fit's
// centre is the blob's.
TEST(GaussianFitSource, ALateSymmetricBlobIsFoundAtItsCenter) {
  const DetectorOptions o;
  HandMadeWindow w = late_blob(100, 70);
  SourceWindow in = w.build(o);
  GaussianFitSource source(o);
  source.allocate(kWidth, kHeight);
  DetectionResult res;
  const std::optional<Candidate> c = source.find(in, res);
  ASSERT_TRUE(c) << to_string(in.why_not);
  EXPECT_EQ(c->source, DetectionSource::kGaussianFit);
  EXPECT_NEAR(c->center.x(), 100.0, 1e-3);
  EXPECT_NEAR(c->center.y(), 70.0, 1e-3);
  EXPECT_NEAR(c->score, 1.0, 1e-6);        // a solid patch at N = 1
  EXPECT_NEAR(c->t_mean_s, 0.024, 1e-6);   // the blob's own events only
  EXPECT_EQ(c->events % 3, 0);             // whole blob pixels, 3 events each
  EXPECT_EQ(res.candidates, 1);
}

TEST(GaussianFitSource, NothingAboveThresholdMeansNoCandidate) {
  const DetectorOptions o;
  HandMadeWindow w = late_blob(100, 70);
  w.pixel.resize(w.pixel.size() - 81 * 3);  // the blob's events were added last
  w.t_s.resize(w.pixel.size());
  w.add(50, 50, 2, 0.024);                  // one late pixel: too small a pattern for min_peak
  SourceWindow in = w.build(o);
  GaussianFitSource source(o);
  source.allocate(kWidth, kHeight);
  DetectionResult res;
  EXPECT_FALSE(source.find(in, res));
  EXPECT_EQ(res.candidates, 0);
}

// Inside a gate the pattern is evaluated as by source 1, at the lower threshold; a gate elsewhere
// finds nothing, and no gate means the source does not run.
TEST(TrackAidedSource, FindsTheBlobOnlyInsideAGateThatHoldsIt) {
  DetectorOptions o;
  o.track_aided.min_peak = 0.3;
  HandMadeWindow w = late_blob(60, 50);
  TrackAidedSource source(o);
  {
    SourceWindow in = w.build(o);
    DetectionResult res;
    EXPECT_FALSE(source.find(in, res));
    EXPECT_EQ(res.candidates, 0);
  }
  w.gates = {Box2D{120, 80, 150, 110}};
  {
    SourceWindow in = w.build(o);
    DetectionResult res;
    EXPECT_FALSE(source.find(in, res));
    EXPECT_FALSE(res.track_aided);
  }
  w.gates.push_back(Box2D{45, 35, 75, 65});
  SourceWindow in = w.build(o);
  DetectionResult res;
  const std::optional<Candidate> c = source.find(in, res);
  ASSERT_TRUE(c);
  EXPECT_TRUE(res.track_aided);
  EXPECT_NEAR(c->center.x(), 60.0, 1e-3);
  EXPECT_NEAR(c->center.y(), 50.0, 1e-3);

  // A tentative track's gate is left to the dense-motion source.
  w.tentative_gates = {w.gates.back()};
  w.gates.pop_back();
  SourceWindow tentative_in = w.build(o);
  DetectionResult tentative_res;
  EXPECT_FALSE(source.find(tentative_in, tentative_res));
  EXPECT_EQ(tentative_res.candidates, 0);
}

// An 11x11 blob whose mean time rises along x by g per pixel: T is exactly a plane, so its R² is 1
// and its rise across the (2r+1)-wide square is g·(2r+1)/Δt of the window; equal counts make the
// centroid of I the blob's centre, and the box is centred there.
TEST(DenseMotionSource, ATimePlaneBlobIsFoundAtItsCentroid) {
  const DetectorOptions o;
  constexpr double kSlopeS = 0.0005;  // [s/px]
  auto rising_blob = [&] {
    HandMadeWindow b;
    b.add_square(80, 60, 11, 3, [&](int x, int) { return 0.0125 + kSlopeS * (x - 80); });
    return b;
  };
  HandMadeWindow w = rising_blob();
  w.gates = {Box2D{60, 40, 100, 80}};
  SourceWindow in = w.build(o);
  DenseMotionSource source(o);
  source.allocate(kWidth, kHeight);
  DetectionResult res;
  const std::optional<Candidate> c = source.find(in, res);
  ASSERT_TRUE(c) << "R² " << test::dense_motion_of(res).r2 << ", span " << test::dense_motion_of(res).span;
  EXPECT_TRUE(test::ran(res, DenseMotionSource::kName));
  EXPECT_TRUE(res.track_aided);
  EXPECT_EQ(c->source, DetectionSource::kDenseMotion);
  EXPECT_NEAR(test::dense_motion_of(res).r2, 1.0, 1e-6);
  EXPECT_NEAR(test::dense_motion_of(res).span, kSlopeS * (2 * o.dense_motion.radius_px + 1) / kWindowS, 1e-5);
  EXPECT_NEAR(c->center.x(), 80.0, 1e-9);
  EXPECT_NEAR(c->center.y(), 60.0, 1e-9);
  EXPECT_NEAR(c->t_mean_s, 0.0125, 1e-6);
  // In a tentative track's gate too.
  HandMadeWindow tentative = rising_blob();
  tentative.tentative_gates = w.gates;
  SourceWindow tentative_in = tentative.build(o);
  DetectionResult tentative_res;
  const std::optional<Candidate> t = source.find(tentative_in, tentative_res);
  ASSERT_TRUE(t);
  EXPECT_EQ(t->center, c->center);

  // The same blob with times alternating as a checkerboard has no linear trend (Σ x·(−1)^x = 0 over
  // a symmetric row): R² ≈ 0, as a static blob's.
  HandMadeWindow flat;
  flat.add_square(80, 60, 11, 3, [](int x, int y) { return (x + y) % 2 ? 0.0075 : 0.0175; });
  flat.gates = w.gates;
  SourceWindow flat_in = flat.build(o);
  DetectionResult flat_res;
  EXPECT_FALSE(source.find(flat_in, flat_res));
  EXPECT_TRUE(test::ran(flat_res, DenseMotionSource::kName));
  EXPECT_LT(test::dense_motion_of(flat_res).r2, 0.01);
}

// A 9x9 blob of 10 events per pixel with an empty surround: its contrast is its density over the
// image's mean, its fill 1, and Algorithm 1 on the uniform excess is centred on it. The blob fires
// evenly (mean time mid-window) while the background fires late, so it passes the time test.
TEST(CountContrastSource, ADenseBlobOnAnEmptySurroundIsFoundAtItsCenter) {
  const DetectorOptions o;
  HandMadeWindow w;
  for (int x = 0; x < kWidth; x += 2) {  // 160 single late events, far from the blob
    w.add(x, 5, 1, 0.024);
    w.add(x, 110, 1, 0.024);
  }
  for (int y = 66; y <= 74; ++y)
    for (int x = 96; x <= 104; ++x)
      for (int k = 0; k < 10; ++k) w.add(x, y, 1, (k + 0.5) * 0.0025);
  SourceWindow in = w.build(o);
  CountContrastSource source(o);
  source.allocate(kWidth, kHeight);
  DetectionResult res;
  const std::optional<Candidate> c = source.find(in, res);
  ASSERT_TRUE(c) << "contrast " << test::count_contrast_of(res).contrast << ", time offset "
                 << test::count_contrast_of(res).time_offset;
  EXPECT_EQ(c->source, DetectionSource::kCountContrast);
  const double image_density = static_cast<double>(w.pixel.size()) / (kWidth * kHeight);
  EXPECT_DOUBLE_EQ(test::count_contrast_of(res).contrast, 10.0 / image_density);
  EXPECT_DOUBLE_EQ(test::count_contrast_of(res).fill, 1.0);
  EXPECT_NEAR(c->center.x(), 100.0, 1e-4);
  EXPECT_NEAR(c->center.y(), 70.0, 1e-4);
  EXPECT_DOUBLE_EQ(c->score, 1.0 - 1.0 / test::count_contrast_of(res).contrast);
  EXPECT_LT(test::count_contrast_of(res).time_offset, -(in.theta - w.ti.mean_normalized));

  // Disabled: the registry makes no such source.
  DetectorOptions off;
  off.count_contrast.enabled = false;
  for (const RegisteredSource& registered : registered_sources())
    if (registered.name == CountContrastSource::kName) {
      EXPECT_EQ(registered.make(off), nullptr);
    }
}

/// A 9x9 square centred on (100, 70) at the window's middle, moving at `speed_px_s` along x, whose
/// pixels fire 10 events each, evenly over the window (a spinning ball: its mean time is the
/// window's middle), on sparse background whose mean time is the middle too (one event every 4 px,
/// at a quarter or three quarters of the window in turn): no time test can see it. Optionally on a
/// static 45x45 body of `body_events` events per pixel.
HandMadeWindow evenly_firing_square(double speed_px_s, int body_events = 0) {
  HandMadeWindow w;
  for (int y = 0; y < kHeight; y += 4)
    for (int x = 0; x < kWidth; x += 4) w.add(x, y, 1, ((x + y) / 4 % 2 == 0 ? 0.25 : 0.75) * kWindowS);
  if (body_events > 0) w.add_square(100, 70, 45, body_events, [](int, int) { return 0.5 * kWindowS; });
  for (int k = 0; k < 10; ++k) {
    const double t = (k + 0.5) * kWindowS / 10;
    const int cx = static_cast<int>(std::lround(100 + speed_px_s * (t - 0.5 * kWindowS)));
    w.add_square(cx, 70, 9, 1, [t](int, int) { return t; });
  }
  return w;
}

std::optional<Candidate> count_contrast(const DetectorOptions& o, HandMadeWindow& w, DetectionResult& res) {
  SourceWindow in = w.build(o);
  CountContrastSource source(o);
  source.allocate(kWidth, kHeight);
  return source.find(in, res);
}

// A still camera's compensated background is sparse. The square moving 4 px in the window stands
// out from its own-scale surround and moves, so it is found, although its mean time is the
// image's. The same square standing still (a flickering light), on a moving camera (where the
// time test must decide), or on a body as dense as a fifth of it (a person's part) is not.
TEST(CountContrastSource, AnEvenlyFiringMovingBlobIsFoundOnlyWithTheCameraStill) {
  const DetectorOptions o;
  constexpr double kSpeed = 4 / kWindowS;  // 4 px in the window
  {
    HandMadeWindow w = evenly_firing_square(kSpeed);
    DetectionResult res;
    const std::optional<Candidate> c = count_contrast(o, w, res);
    ASSERT_TRUE(c) << "isolation " << test::count_contrast_of(res).isolation << ", z "
                   << test::count_contrast_of(res).motion_z;
    EXPECT_LT(std::abs(test::count_contrast_of(res).time_offset), o.threshold_c);  // the time test alone fails
    EXPECT_GE(test::count_contrast_of(res).isolation, o.count_contrast.still_min_isolation);
    EXPECT_GE(test::count_contrast_of(res).motion_z, o.count_contrast.still_min_motion_z);
    EXPECT_NEAR(c->center.x(), 100.0, 0.5);
    EXPECT_NEAR(c->center.y(), 70.0, 0.5);
    DetectorOptions off = o;
    off.count_contrast.still_motion = 0;
    DetectionResult off_res;
    EXPECT_FALSE(count_contrast(off, w, off_res));
  }
  {
    HandMadeWindow w = evenly_firing_square(0);
    DetectionResult res;
    EXPECT_FALSE(count_contrast(o, w, res));
    EXPECT_GE(test::count_contrast_of(res).isolation, o.count_contrast.still_min_isolation);
    EXPECT_LT(test::count_contrast_of(res).motion_z, 0.5);
  }
  {
    HandMadeWindow w = evenly_firing_square(kSpeed);
    w.speed_m_s = 6;  // b‖v‖ = 0.24 > still_motion
    DetectionResult res;
    EXPECT_FALSE(count_contrast(o, w, res));
    EXPECT_EQ(test::count_contrast_of(res).isolation, 0.0);  // the still-camera test did not run
    // Inside a confirmed track's gate there is no time test; a tentative track's gate is not searched.
    const Box2D gate{85, 55, 115, 85};
    w.tentative_gates = {gate};
    DetectionResult tentative_res;
    EXPECT_FALSE(count_contrast(o, w, tentative_res));
    w.tentative_gates.clear();
    w.gates = {gate};
    DetectionResult gated_res;
    const std::optional<Candidate> c = count_contrast(o, w, gated_res);
    ASSERT_TRUE(c);
    EXPECT_TRUE(gated_res.track_aided);
    EXPECT_NEAR(c->center.x(), 100.0, 0.5);
  }
  {
    HandMadeWindow w = evenly_firing_square(kSpeed, 2);
    DetectionResult res;
    EXPECT_FALSE(count_contrast(o, w, res));
    EXPECT_GT(test::count_contrast_of(res).contrast, o.count_contrast.min_contrast);  // dense enough for the cue
    EXPECT_GT(test::count_contrast_of(res).isolation, 1.0);
    EXPECT_LT(test::count_contrast_of(res).isolation, o.count_contrast.still_min_isolation);
  }
}

// A part of the window (the events within 20 px of the blob) handed over with every event time of
// the whole window (window_t_s), whose background fires early: the blob's time offset against the
// image's mean time is the whole window's. Without the times the kept events, mostly the blob's,
// would set the mean, and the offset would shrink.
TEST(CountContrastSource, APartOfTheWindowIsMeasuredAgainstTheWholeWindow) {
  const DetectorOptions o;
  HandMadeWindow whole = evenly_firing_square(4 / kWindowS);
  for (int y = 2; y < kHeight; y += 4)
    for (int x = 2; x < kWidth; x += 4) whole.add(x, y, 1, 0.1 * kWindowS);
  DetectionResult whole_res;
  ASSERT_TRUE(count_contrast(o, whole, whole_res));
  HandMadeWindow part;
  for (std::size_t i = 0; i < whole.pixel.size(); ++i)
    if (std::abs(whole.pixel[i] % kWidth - 100) <= 20 && std::abs(whole.pixel[i] / kWidth - 70) <= 20) {
      part.pixel.push_back(whole.pixel[i]);
      part.t_s.push_back(whole.t_s[i]);
    }
  auto offset_of_part = [&](std::span<const float> window_t_s) {
    SourceWindow in = part.build(o);
    part.view.window_t_s = window_t_s;
    CountContrastSource source(o);
    source.allocate(kWidth, kHeight);
    DetectionResult res;
    EXPECT_TRUE(source.find(in, res));
    return test::count_contrast_of(res).time_offset;
  };
  const double whole_offset = test::count_contrast_of(whole_res).time_offset;
  EXPECT_NEAR(offset_of_part(whole.t_s), whole_offset, 1e-6);
  EXPECT_LT(offset_of_part({}), whole_offset - 0.05);
}

// The least m with centres · P(Binomial(n, p) ≥ m) ≤ chance, checked against scipy.stats.binom.sf:
// 25 pixels at p = 0.013 over a DAVIS346 frame need 8 (7 give 2.7e-3 expected boxes); at p = 0.04, 11.
TEST(CountContrastSource, TheSparseFillIsTheFewestActivePixelsScatteredEventsSeldomReach) {
  EXPECT_EQ(fewest_unlikely_active(25, 0.013, 346 * 260, 1e-3), 8);
  EXPECT_EQ(fewest_unlikely_active(25, 0.04, 346 * 260, 1e-3), 11);
  EXPECT_EQ(fewest_unlikely_active(81, 0.015, kWidth * kHeight, 1e-3), 11);
  EXPECT_EQ(fewest_unlikely_active(9, 0.5, 1000, 1e-3), 10);  // no count is unlikely enough
  EXPECT_EQ(fewest_unlikely_active(25, 0.0, 100, 1e-3), 1);
}

/// A still camera's quiet window: single events on 1 pixel in 64 (a sensor's noise), and an 11x11
/// square at (cx, 70) at the window's middle, moving `speed_px_s` along x, of which a tenth of the
/// pixels fire in each tenth of the window (a far spinning ball: at most a few events per pixel, so
/// no centre box fills at min_pixel_events).
void add_sparse_square(HandMadeWindow& w, int cx, double speed_px_s) {
  for (int k = 0; k < 10; ++k) {
    const double t = (k + 0.5) * kWindowS / 10;
    const int x0 = static_cast<int>(std::lround(cx + speed_px_s * (t - 0.5 * kWindowS)));
    for (int y = 65; y <= 75; ++y)
      for (int x = x0 - 5; x <= x0 + 5; ++x)
        if ((x + 3 * y + 7 * k) % 10 == 0) w.add(x, y, 1, t);
  }
}
HandMadeWindow quiet_window() {
  HandMadeWindow w;
  for (int i = 0; i < kWidth * kHeight / 64; ++i)
    w.add((i * 37) % kWidth, (i * 61 / 7) % kHeight, 1, (i % 10 + 0.5) * kWindowS / 10);
  return w;
}

/// The count cue with `gate` as a tentative track's only gate; what it finds there is track-aided.
std::optional<Candidate> count_contrast_in_tentative_gate(const DetectorOptions& o, HandMadeWindow& w,
                                                          const Box2D& gate) {
  w.tentative_gates = {gate};
  DetectionResult res;
  std::optional<Candidate> c = count_contrast(o, w, res);
  EXPECT_EQ(res.track_aided, c.has_value());
  return c;
}

// The sparse search: with the camera still and nothing dense, a lone blob whose boxes hold more fired
// pixels than scattered noise would reach is found; not when the search is off, when a second such
// blob makes the background more than noise, when the camera moves, or when it does not move
// within the window (a flickering light) over the image. In a tentative track's gate neither the
// second blob nor the motion is asked about.
TEST(CountContrastSource, ALoneSparseMovingBlobIsFoundWithTheCameraStill) {
  const DetectorOptions o;
  constexpr double kSpeed = 4 / kWindowS;
  {
    HandMadeWindow w = quiet_window();
    add_sparse_square(w, 100, kSpeed);
    DetectionResult res;
    const std::optional<Candidate> c = count_contrast(o, w, res);
    const CountContrastDiagnostics cc = test::count_contrast_of(res);
    ASSERT_TRUE(c) << "contrast " << cc.contrast << ", fill " << cc.fill << ", isolation " << cc.isolation << ", z "
                   << cc.motion_z;
    EXPECT_GT(cc.sparse_min_active, 0);                 // the sparse search found it
    EXPECT_LT(c->event_density, o.min_event_density);  // below the dense gate
    EXPECT_GE(cc.motion_z, o.count_contrast.still_min_motion_z);
    EXPECT_NEAR(c->center.x(), 100.0, 1.0);
    EXPECT_NEAR(c->center.y(), 70.0, 1.0);
    EXPECT_FALSE(res.track_aided);
    DetectorOptions off = o;
    off.count_contrast.sparse_chance = 0;
    DetectionResult off_res;
    EXPECT_FALSE(count_contrast(off, w, off_res));
    EXPECT_EQ(test::count_contrast_of(off_res).sparse_min_active, 0);

    w.speed_m_s = 6;  // b‖v‖ = 0.24 > still_motion
    DetectionResult moving_res;
    EXPECT_FALSE(count_contrast(o, w, moving_res));
    EXPECT_EQ(test::count_contrast_of(moving_res).sparse_min_active, 0);
  }
  {
    HandMadeWindow w = quiet_window();
    add_sparse_square(w, 100, kSpeed);
    add_sparse_square(w, 60, kSpeed);
    DetectionResult res;
    EXPECT_FALSE(count_contrast(o, w, res));
    EXPECT_GT(test::count_contrast_of(res).sparse_min_active, 0);
    // A track's gate holding both is searched for its best blob all the same.
    const std::optional<Candidate> c = count_contrast_in_tentative_gate(o, w, Box2D{45, 55, 115, 85});
    ASSERT_TRUE(c);
    EXPECT_NEAR(c->center.y(), 70.0, 1.0);
    EXPECT_LT(std::min(std::abs(c->center.x() - 100.0), std::abs(c->center.x() - 60.0)), 1.0) << c->center.x();
  }
  {
    HandMadeWindow w = quiet_window();
    add_sparse_square(w, 100, 0);
    DetectionResult res;
    EXPECT_FALSE(count_contrast(o, w, res));
    EXPECT_GE(test::count_contrast_of(res).isolation, o.count_contrast.still_min_isolation);
    EXPECT_LT(test::count_contrast_of(res).motion_z, o.count_contrast.still_min_motion_z);
    const std::optional<Candidate> c = count_contrast_in_tentative_gate(o, w, Box2D{85, 55, 115, 85});
    ASSERT_TRUE(c);
    EXPECT_NEAR(c->center.x(), 100.0, 1.0);
  }
}

/// One refinement with these options, from a fresh refiner.
std::optional<RefinedCenter> refine_once(const DetectorOptions& o, const CompensatedEventsView& view, const Box2D& box,
                                         double t_box_s) {
  EventRefiner refiner(o);
  refiner.allocate(kWidth, kHeight);
  return refiner.refine(view, box, t_box_s);
}

/// A ring of events 13-15 px from (80, 60), at three times across the window, `right` events per
/// pixel on its right half (x > 80) and `left` on its left, on background of one event every 8 px.
void add_ring_on_sparse_background(HandMadeWindow& w, int right, int left) {
  for (int y = 0; y < kHeight; y += 8)
    for (int x = 0; x < kWidth; x += 8) w.add(x, y, 1, 0.0125);
  for (int y = 30; y <= 90; ++y)
    for (int x = 50; x <= 110; ++x) {
      const double r = std::hypot(x - 80, y - 60);
      if (r >= 13 && r <= 15)
        for (const double t : {0.005, 0.0125, 0.020}) w.add(x, y, x > 80 ? right : left, t);
    }
  w.view = {0, from_seconds(kWindowS), kWidth, kHeight, w.pixel, w.t_s};
}

// Events of a square object symmetric about its centre and about the window's middle time: the
// refined centre and time are that centre and time, from a box centred off it.
TEST(EventRefiner, SymmetricEventsGiveTheirCentroidAndMeanTime) {
  HandMadeWindow w;
  for (int y = 47; y <= 53; ++y)
    for (int x = 37; x <= 43; ++x)
      for (const double t : {0.005, 0.0125, 0.020}) w.add(x, y, 1, t);
  w.view = {0, from_seconds(kWindowS), kWidth, kHeight, w.pixel, w.t_s};  // not time-sorted
  const std::optional<RefinedCenter> r = refine_once(DetectorOptions{}, w.view, Box2D{38, 46, 46, 54}, 0.0125);
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->center.x(), 40.0, 1e-9);
  EXPECT_NEAR(r->center.y(), 50.0, 1e-9);
  EXPECT_NEAR(r->t_mean_s, 0.0125, 1e-7);
}

// Squares of events against the image's left and right edges, symmetric about their middle row and
// time: the square the refinement bins is cut by the edge, its first or last column is the image's,
// and the centroid is the mean of the object's columns (0..6: 3; 153..159: 156), events in time
// order or not.
TEST(EventRefiner, AnObjectAtTheImagesEdgeKeepsItsEdgeColumns) {
  for (const auto& [x0, expected_x] : {std::pair{0, 3.0}, std::pair{kWidth - 7, kWidth - 4.0}}) {
    for (const bool sorted : {false, true}) {
      SCOPED_TRACE(testing::Message() << "x0 " << x0 << (sorted ? ", time-sorted" : ""));
      HandMadeWindow w;
      for (const double t : {0.005, 0.0125, 0.020})
        for (int y = 47; y <= 53; ++y)
          for (int x = x0; x <= x0 + 6; ++x) w.add(x, y, 1, t);
      w.view = {0, from_seconds(kWindowS), kWidth, kHeight, w.pixel, w.t_s};
      w.view.time_sorted = sorted;
      const std::optional<RefinedCenter> r =
          refine_once(DetectorOptions{}, w.view, Box2D{x0 - 1.0, 46, x0 + 8.0, 54}, 0.0125);
      ASSERT_TRUE(r);
      EXPECT_DOUBLE_EQ(r->center.x(), expected_x);
      EXPECT_DOUBLE_EQ(r->center.y(), 50.0);
      EXPECT_NEAR(r->t_mean_s, 0.0125, 1e-7);
    }
  }
}

// A ring of events (a uniform ball's rim, 30 px across) on sparse background, and a box on a 6 px
// fragment of its right arc: the square grows until it holds the whole ring, and the centre is the
// ring's. Without growth the centre stays on the arc.
TEST(EventRefiner, ABoxOnAFragmentGrowsToHoldTheWholeObject) {
  HandMadeWindow w;
  add_ring_on_sparse_background(w, 1, 1);
  const Box2D fragment{91, 57, 97, 63};

  const std::optional<RefinedCenter> r = refine_once(DetectorOptions{}, w.view, fragment, 0.0125);
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->center.x(), 80.0, 1.5);
  EXPECT_NEAR(r->center.y(), 60.0, 1.5);
  // The square grows 12 → 18 → 27 → 40.5 px and holds the ring: 40.5 / sqrt(1.5) = 33 px.
  EXPECT_NEAR(r->extent_px, 30.0, 30.0 * (std::sqrt(1.5) - 1));

  DetectorOptions fixed;
  fixed.refine_grow_density = 0;
  const std::optional<RefinedCenter> f = refine_once(fixed, w.view, fragment, 0.0125);
  ASSERT_TRUE(f);
  EXPECT_GT(f->center.x(), 90.0);
  EXPECT_DOUBLE_EQ(f->extent_px, 6.0);
}

// The same ring whose right half makes 3 events per pixel and its left half 2, as a ball that comes
// closer while it moves right sweeps more pixels with its leading edge: the events' centroid lies
// (3 - 2) / 5 · 2r/π ≈ 1.8 px right of the centre (2r/π = 8.9 px, a half ring's mean offset at
// r = 14), the fitted outline's centre on it. (At 2:1 the square stops growing before it holds the
// left half: the band's density test compares it with the denser right half.)
TEST(EventRefiner, AGrownSquaresCenterIsItsOutlinesNotItsEventsCentroid) {
  HandMadeWindow w;
  add_ring_on_sparse_background(w, 3, 2);
  const Box2D fragment{91, 57, 97, 63};

  const std::optional<RefinedCenter> outline = refine_once(DetectorOptions{}, w.view, fragment, 0.0125);
  ASSERT_TRUE(outline);
  EXPECT_NEAR(outline->center.x(), 80.0, 0.3);
  EXPECT_NEAR(outline->center.y(), 60.0, 0.3);

  DetectorOptions centroid;
  centroid.refine_fit_outline = false;
  const std::optional<RefinedCenter> c = refine_once(centroid, w.view, fragment, 0.0125);
  ASSERT_TRUE(c);
  EXPECT_NEAR(c->center.x(), 81.8, 0.3);
  EXPECT_NEAR(c->center.y(), 60.0, 0.3);
  EXPECT_DOUBLE_EQ(c->extent_px, outline->extent_px);  // the fit moves the centre only
}

// A 9x9 object at 4 events per pixel on background of 1 event per pixel everywhere: the band around
// the square is as dense as the whole image, so the square keeps its size. Without the contrast test
// it grows over the background.
TEST(EventRefiner, ABoxOnTexturedBackgroundKeepsItsSize) {
  HandMadeWindow w;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) w.add(x, y, 1, (x + y) % 2 == 0 ? 0.005 : 0.020);
  w.add_square(80, 60, 9, 3, [](int, int) { return 0.0125; });
  w.view = {0, from_seconds(kWindowS), kWidth, kHeight, w.pixel, w.t_s};
  const Box2D box{75.5, 55.5, 84.5, 64.5};

  const std::optional<RefinedCenter> r = refine_once(DetectorOptions{}, w.view, box, 0.0125);
  ASSERT_TRUE(r);
  EXPECT_DOUBLE_EQ(r->extent_px, 9.0);
  EXPECT_NEAR(r->center.x(), 80.0, 0.5);

  DetectorOptions no_contrast;
  no_contrast.refine_grow_contrast = 0;
  const std::optional<RefinedCenter> g = refine_once(no_contrast, w.view, box, 0.0125);
  ASSERT_TRUE(g);
  EXPECT_GT(g->extent_px, 9.0);
}

// The same window handed over only near the object (PerceptionOptions::gates_only_between_anchors),
// with every event's time of the window (window_t_s): the band is compared with the whole window's
// density, and the square keeps its size. Without them the image outside the kept part looks empty
// and the square grows over the background.
TEST(EventRefiner, APartOfTheWindowIsMeasuredAgainstTheWholeWindow) {
  HandMadeWindow w;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) w.add(x, y, 1, (x + y) % 2 == 0 ? 0.005 : 0.020);
  w.add_square(80, 60, 9, 3, [](int, int) { return 0.0125; });
  std::vector<std::int32_t> pixel;
  std::vector<float> t_s;
  for (std::size_t i = 0; i < w.pixel.size(); ++i)
    if (std::abs(w.pixel[i] % kWidth - 80) <= 15 && std::abs(w.pixel[i] / kWidth - 60) <= 15)
      pixel.push_back(w.pixel[i]), t_s.push_back(w.t_s[i]);
  ASSERT_LT(pixel.size(), w.pixel.size() / 10);
  CompensatedEventsView part{0, from_seconds(kWindowS), kWidth, kHeight, pixel, t_s};
  part.window_t_s = w.t_s;
  const Box2D box{75.5, 55.5, 84.5, 64.5};
  const std::optional<RefinedCenter> r = refine_once(DetectorOptions{}, part, box, 0.0125);
  ASSERT_TRUE(r);
  EXPECT_DOUBLE_EQ(r->extent_px, 9.0);
  part.window_t_s = {};
  const std::optional<RefinedCenter> g = refine_once(DetectorOptions{}, part, box, 0.0125);
  ASSERT_TRUE(g);
  EXPECT_GT(g->extent_px, 9.0);
}

}  // namespace
}  // namespace fdv
