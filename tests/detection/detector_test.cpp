// The whole detector on synthetic windows: a moving blob over a static (hence exactly
// compensated) background with noise, seen through a distorted lens; and the bad-input cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "fdv/compensation/compensator.h"
#include "fdv/core/error.h"
#include "fdv/detection/detector.h"
#include "fdv/pipeline/detector_input.h"
#include "synthetic_scene.h"

namespace fdv {
namespace {

using test::lens;

class DetectorTest : public ::testing::Test {
 protected:
  DetectorTest() : detector_(DetectorOptions{}, lens()) {
    Calibration c;
    c.event_camera = lens();
    CompensationOptions o;
    o.method = CompensationMethod::kNone;
    o.max_events_per_window = 2'000'000;  // the uniform-density window's 1.2 M events, all kept
    compensator_ = make_compensator(c, o);
  }
  DetectionResult run(const std::vector<Event>& ev, TimeNs t0, TimeNs t1) {
    const CompensatedWindow& w = compensator_->compensate({.events = ev, .t_start = t0, .t_end = t1});
    return detector_.detect(detector_input(w));
  }
  std::unique_ptr<Compensator> compensator_;
  Detector detector_;
};

// The blob's true position at the detection's own time, on the undistorted grid and in raw pixels.
void expect_on_blob(const DetectionResult& r, const test::BlobScene& s, double tol_px) {
  ASSERT_TRUE(r.strongest()) << to_string(r.status) << ", fit rejected: " << test::fit_rejected(r);
  const Detection2D& d = *r.strongest();
  EXPECT_GT(d.t, s.t0);
  EXPECT_LT(d.t, s.t0 + s.duration);
  const Eigen::Vector2d truth = s.blob_at(d.t);
  EXPECT_LT((d.center_undistorted - truth).norm(), tol_px)
      << "detected " << d.center_undistorted.transpose() << " truth " << truth.transpose() << " at "
      << to_seconds(d.t - s.t0) * 1e3 << " ms, source " << to_string(d.source);
  const PinholeCamera cam = lens();
  const Eigen::Vector2d truth_raw =
      cam.normalized_to_pixel({(truth.x() - cam.cx) / cam.fx, (truth.y() - cam.cy) / cam.fy});
  EXPECT_LT((d.center_raw - truth_raw).norm(), tol_px);
  EXPECT_NEAR(d.center_normalized.x(), (truth.x() - cam.cx) / cam.fx, tol_px / cam.fx);
  // The box contains the centre in both coordinate systems and has the blob's scale.
  EXPECT_TRUE(d.box_undistorted.x0 < d.center_undistorted.x() && d.center_undistorted.x() < d.box_undistorted.x1);
  EXPECT_TRUE(d.box_raw.x0 < d.center_raw.x() && d.center_raw.x() < d.box_raw.x1);
  EXPECT_TRUE(d.box_raw.y0 < d.center_raw.y() && d.center_raw.y() < d.box_raw.y1);
  EXPECT_LT(d.box_undistorted.width(), 8 * s.radius_px);
  EXPECT_GT(d.events, 20);
  EXPECT_GE(d.score, DetectorOptions{}.gaussian_fit.min_peak);
  EXPECT_LE(d.score, 1.0);
}

// The time images are made at construction, so that the first window does not pay for them; it
// then writes into those same buffers.
TEST_F(DetectorTest, TimeImagesAreMadeAtConstructionAndKeptByTheFirstWindow) {
  Detector fresh(DetectorOptions{}, lens());
  ASSERT_EQ(fresh.time_images().count.size(), cv::Size(lens().width, lens().height));
  const void* count_data = fresh.time_images().count.data;
  test::BlobScene s;
  const auto ev = test::make_scene(lens(), s);
  Calibration c;
  c.event_camera = lens();
  CompensationOptions none;
  none.method = CompensationMethod::kNone;
  const auto comp = make_compensator(c, none);
  (void)fresh.detect(detector_input(comp->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration})));
  EXPECT_EQ(fresh.time_images().count.data, count_data);
  EXPECT_GT(fresh.time_images().events, 0);
}

// Windows with too few events leave no segmentation behind, also when several follow each other
// (the first blanks S, the next ones find it blank) and when a segmented window comes between.
TEST_F(DetectorTest, WindowsWithTooFewEventsLeaveSBlank) {
  test::BlobScene s;
  const auto blob = test::make_scene(lens(), s);
  const std::vector<Event> few{{s.t0 + 1000, 10, 10, true}, {s.t0 + 2000, 20, 20, false}};
  for (int round = 0; round < 2; ++round) {
    EXPECT_EQ(run(blob, s.t0, s.t0 + s.duration).status, DetectionStatus::kDetected);
    EXPECT_GT(cv::countNonZero(detector_.segmentation()), 0);
    for (int i = 0; i < 2; ++i) {
      EXPECT_EQ(run(few, s.t0, s.t0 + s.duration).status, DetectionStatus::kTooFewEvents);
      EXPECT_EQ(cv::countNonZero(detector_.segmentation()), 0) << "round " << round << ", window " << i;
    }
  }
}

TEST_F(DetectorTest, FindsAMovingBlobWithinTwoPixels) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    test::BlobScene s;
    s.seed = seed;
    s.t0 = 3 * kNsPerS + seed * 25 * kNsPerMs;
    s.start_uv = {120.0 + 90 * seed, 100.0 + 60 * seed};
    s.velocity_px_s = {seed % 2 ? 300.0 : -250.0, seed % 3 ? 160.0 : -200.0};
    const auto ev = test::make_scene(lens(), s);
    const DetectionResult r = run(ev, s.t0, s.t0 + s.duration);
    SCOPED_TRACE("seed " + std::to_string(seed));
    expect_on_blob(r, s, 2.0);
    EXPECT_GT(r.timings.total_ms, 0);
  }
}

// A ball crossing the image fast: the segmented pattern is its latest sweep, a crescent across the
// motion (thin along it). With square_box the reported box is the square of its longer side on the
// refined centre, which holds the whole disc at the detection's time; without it, the crescent.
TEST(DetectorBox, SquareBoxHoldsTheWholeFastBallNotJustItsLatestSweep) {
  Calibration c;
  c.event_camera = lens();
  CompensationOptions co;
  co.method = CompensationMethod::kNone;
  const auto compensator = make_compensator(c, co);
  for (const bool square : {true, false}) {
    DetectorOptions o;
    o.square_box = square;
    Detector detector(o, lens());
    int holds_the_disc = 0;
    for (unsigned seed = 1; seed <= 4; ++seed) {
      test::BlobScene s;
      s.seed = seed;
      s.radius_px = 14;
      s.blob_rate_ev_s = 1'200'000;
      s.start_uv = {200.0 + 30 * seed, 150.0 + 20 * seed};
      s.velocity_px_s = {seed % 2 ? 1200.0 : 0.0, seed % 2 ? 0.0 : 1200.0};  // 30 px per window
      const auto ev = test::make_scene(lens(), s);
      const CompensatedWindow& w =
          compensator->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
      const DetectionResult r = detector.detect(detector_input(w));
      ASSERT_TRUE(r.strongest()) << to_string(r.status);
      const Box2D& b = r.strongest()->box_undistorted;
      const Eigen::Vector2d at = s.blob_at(r.strongest()->t);
      const double margin = 2.0;  // px: the disc's edge pixels are sparse
      holds_the_disc += b.x0 <= at.x() - s.radius_px + margin && b.x1 >= at.x() + s.radius_px - margin &&
                        b.y0 <= at.y() - s.radius_px + margin && b.y1 >= at.y() + s.radius_px - margin;
      if (square) {
        EXPECT_NEAR(b.width(), b.height(), 1e-9);
        EXPECT_LT(b.width(), 3 * 2 * s.radius_px) << "seed " << seed;  // the ball's scale, not the sweep's
      }
    }
    if (square)
      EXPECT_EQ(holds_the_disc, 4);
    else
      EXPECT_LT(holds_the_disc, 4) << "the crescent box was expected to cut the disc";
  }
}

// The box and centre on the compensated grid stay where the events are; the camera-at-t fields
// (center_raw, center_normalized, box_raw) go through the view's observed_at at the detection's
// time: here a made-up ego-motion that moves the image by (800, −500) px/s.
TEST_F(DetectorTest, CenterForTheCameraAtTheDetectionTimeGoesThroughObservedAt) {
  test::BlobScene s;
  s.t0 = 5 * kNsPerS;
  s.start_uv = {250.0, 200.0};
  s.velocity_px_s = {300.0, 160.0};
  const auto ev = test::make_scene(lens(), s);
  const CompensatedWindow& w = compensator_->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
  const DetectionResult plain = detector_.detect(detector_input(w));
  CompensatedEventsView view = detector_input(w);
  const Eigen::Vector2d flow(800.0, -500.0);
  view.observed_at = [&](const Eigen::Vector2d& px, double t_s) -> Eigen::Vector2d { return px + flow * t_s; };
  const DetectionResult moved = detector_.detect(view);
  ASSERT_TRUE(plain.strongest() && moved.strongest());
  const Detection2D &a = *plain.strongest(), &b = *moved.strongest();
  EXPECT_EQ(a.t, b.t);
  EXPECT_EQ(a.center_undistorted, b.center_undistorted);
  EXPECT_EQ(a.box_undistorted.x0, b.box_undistorted.x0);
  const Eigen::Vector2d seen = a.center_undistorted + flow * to_seconds(a.t - s.t0);
  EXPECT_GT((seen - a.center_undistorted).norm(), 5.0);
  const PinholeCamera cam = lens();
  const Eigen::Vector2d xn((seen.x() - cam.cx) / cam.fx, (seen.y() - cam.cy) / cam.fy);
  // t_ns is the detection's mean time rounded to a nanosecond: ≤ 1e-6 px here.
  EXPECT_NEAR((b.center_normalized - xn).norm(), 0, 1e-8);
  EXPECT_NEAR((b.center_raw - cam.normalized_to_pixel(xn)).norm(), 0, 1e-6);
  EXPECT_TRUE(b.box_raw.x0 < b.center_raw.x() && b.center_raw.x() < b.box_raw.x1);
  EXPECT_TRUE(b.box_raw.y0 < b.center_raw.y() && b.center_raw.y() < b.box_raw.y1);
  EXPECT_NEAR(b.box_raw.width(), a.box_raw.width(), 0.05 * a.box_raw.width());
}

// Residual background around a fast object's path (imperfect compensation leaves texture events
// there) pulls a centroid taken over a region centred on the box - which sits on the object's
// latest sweep, ahead of it - forwards along the motion; the re-centred region
// (refine_recenter_passes) settles on the object's own events.
TEST(DetectorRefine, RecenterdRegionRemovesTheClutterPullAlongTheMotion) {
  test::BlobScene s;
  s.t0 = 2 * kNsPerS;
  s.start_uv = {180, 240};
  s.velocity_px_s = {2400, 0};  // 60 px per window, like a ball thrown across at 3 m
  s.radius_px = 12;
  s.blob_rate_ev_s = 2'000'000;
  s.edge_segments = 0;
  s.noise_rate_ev_s = 100'000;
  std::vector<Event> ev = test::make_scene(lens(), s);
  std::mt19937 rng(3);
  std::uniform_int_distribution<TimeNs> when(s.t0, s.t0 + s.duration - 1);
  std::uniform_real_distribution<double> ux(130, 330), uy(180, 300);
  for (int i = 0; i < 150'000; ++i) {
    Event e;
    e.t = when(rng);
    e.polarity = true;
    if (test::to_raw(lens(), {ux(rng), uy(rng)}, e)) ev.push_back(e);
  }
  std::sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  Calibration c;
  c.event_camera = lens();
  CompensationOptions none;
  none.method = CompensationMethod::kNone;
  auto comp = make_compensator(c, none);
  const CompensatedWindow& w = comp->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
  auto along_error = [&](int passes) {
    DetectorOptions o;
    o.refine_recenter_passes = passes;
    Detector d(o, lens());
    const DetectionResult r = d.detect(detector_input(w));
    EXPECT_TRUE(r.strongest()) << to_string(r.status);
    return r.strongest() ? r.strongest()->center_undistorted.x() - s.blob_at(r.strongest()->t).x() : 1e9;
  };
  const double single = along_error(0), recenterd = along_error(DetectorOptions{}.refine_recenter_passes);
  EXPECT_GT(single, 2.0) << "the set-up must show the pull";
  EXPECT_LT(std::abs(recenterd), 1.0);

  // The refinement's time slice found by binary search (time-sorted window) and by testing every
  // event's time (a window not known to be sorted) bins the same events: the same detection.
  Detector sorted(DetectorOptions{}, lens()), unsorted(DetectorOptions{}, lens());
  CompensatedEventsView v = detector_input(w);
  ASSERT_TRUE(v.time_sorted);
  const DetectionResult a = sorted.detect(v);
  v.time_sorted = false;
  const DetectionResult b = unsorted.detect(v);
  ASSERT_TRUE(a.strongest() && b.strongest());
  EXPECT_EQ(a.strongest()->center_undistorted, b.strongest()->center_undistorted);
  EXPECT_EQ(a.strongest()->t, b.strongest()->t);
}

TEST_F(DetectorTest, StaticBackgroundAndNoiseAloneGiveNoDetection) {
  test::BlobScene s;
  s.blob_rate_ev_s = 0;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    s.seed = seed;
    const DetectionResult r = run(test::make_scene(lens(), s), s.t0, s.t0 + s.duration);
    EXPECT_FALSE(r.strongest()) << "seed " << seed << " at " << r.strongest()->center_undistorted.transpose();
  }
}

TEST_F(DetectorTest, EmptyAndNearlyEmptyWindows) {
  DetectionResult r = run({}, 0, 25 * kNsPerMs);
  EXPECT_FALSE(r.strongest());
  EXPECT_EQ(r.status, DetectionStatus::kTooFewEvents);
  std::vector<Event> few;
  for (int i = 0; i < 10; ++i) few.push_back({i * kNsPerMs, static_cast<std::uint16_t>(300 + i), 200, true});
  r = run(few, 0, 25 * kNsPerMs);
  EXPECT_FALSE(r.strongest());
  EXPECT_EQ(r.status, DetectionStatus::kTooFewEvents);
  EXPECT_EQ(cv::countNonZero(detector_.preprocessed()), 0);
  // Many events, all at one instant: no temporal contrast.
  std::vector<Event> same_time;
  for (int i = 0; i < 500; ++i) same_time.push_back({kNsPerMs, static_cast<std::uint16_t>(100 + i % 50), static_cast<std::uint16_t>(100 + i / 50), true});
  r = run(same_time, 0, 25 * kNsPerMs);
  EXPECT_FALSE(r.strongest());
  EXPECT_EQ(r.status, DetectionStatus::kNoTemporalContrast);
}

std::vector<Event> with_burst(std::vector<Event> ev, TimeNs from, TimeNs to, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<TimeNs> when(from, to - 1);
  std::uniform_int_distribution<int> ux(0, 639), uy(0, 479);
  for (int i = 0; i < n; ++i)
    ev.push_back({when(rng), static_cast<std::uint16_t>(ux(rng)), static_cast<std::uint16_t>(uy(rng)), true});
  std::sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  return ev;
}

TEST_F(DetectorTest, BurstFarAboveTheNormalRate) {
  test::BlobScene s;
  const auto ev = test::make_scene(lens(), s);
  // 200 k events within 1 ms (200 M ev/s, 10x the whole window's normal count) in mid-window:
  // the burst pixels' mean time sits mid-window, below θ, and the blob is still found.
  const DetectionResult mid = run(with_burst(ev, 12 * kNsPerMs, 13 * kNsPerMs, 200'000, 5), s.t0, s.t0 + s.duration);
  expect_on_blob(mid, s, 2.0);
  // The same burst in the window's last millisecond makes a third of the image "newest". Half of
  // the pixels with events are then burst pixels at N ≈ 1, so mean(N) ≈ 0.7 and θ = mean(N) + c
  // reaches 1: nothing is segmented, and the paper's detector reports nothing rather than a
  // random one.
  const auto late_burst = with_burst(ev, 24 * kNsPerMs, 25 * kNsPerMs, 200'000, 6);
  DetectorOptions paper_options;
  paper_options.count_contrast.enabled = false;
  Detector paper(paper_options, lens());
  const DetectionResult late_paper =
      paper.detect(detector_input(compensator_->compensate({.events = late_burst, .t_start = s.t0, .t_end = s.t0 + s.duration})));
  EXPECT_FALSE(late_paper.strongest());
  EXPECT_GT(late_paper.mean_normalized, 0.65);
  EXPECT_EQ(late_paper.status, DetectionStatus::kNothingSegmented);
  // A late burst of background events is what the count-contrast source is for: the blob fires
  // evenly over the window, so it is dense in I and early against all events.
  const DetectionResult late = run(late_burst, s.t0, s.t0 + s.duration);
  expect_on_blob(late, s, 2.0);
  EXPECT_EQ(late.strongest()->source, DetectionSource::kCountContrast);
  EXPECT_LT(test::count_contrast_of(late).time_offset, -late.theta + late.mean_normalized);
  // With c = 0 the burst passes θ and floods the segmentation: reported as such.
  DetectorOptions o;
  o.threshold_c = 0;
  o.min_pixel_events = 1;  // the paper's S: single-event burst pixels count
  Detector permissive(o, lens());
  const CompensatedWindow& w = compensator_->compensate(
      {.events = with_burst(ev, 24 * kNsPerMs, 25 * kNsPerMs, 200'000, 6), .t_start = s.t0, .t_end = s.t0 + s.duration});
  const DetectionResult flooded = permissive.detect(detector_input(w));
  EXPECT_FALSE(flooded.strongest());
  EXPECT_EQ(flooded.status, DetectionStatus::kFlooded);
}

// A decoy stronger than the blob in P but with one event per pixel: a solid 24x24 patch all fired in
// the window's last millisecond (N ≈ 1 everywhere on it). The density gate rejects it; with a
// second candidate allowed, the blob is found; with one, the window has no detection.
TEST_F(DetectorTest, NextCandidateIsTriedWhenTheStrongestPatternFailsTheEvidenceGates) {
  test::BlobScene s;
  std::vector<Event> ev = test::make_scene(lens(), s);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      Event e{s.t0 + 24 * kNsPerMs + (x + 24 * y) * 1000, 0, 0, true};
      if (test::to_raw(lens(), {450.0 + x, 300.0 + y}, e)) ev.push_back(e);
    }
  std::sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  DetectorOptions o;
  o.min_pixel_events = 1;     // the decoy's single-event pixels enter S (the paper's S)
  o.min_event_density = 2.0;  // the blob holds tens of events per pixel
  o.gaussian_fit.max_candidates = 1;
  o.count_contrast.still_motion = 0;  // the camera is still: the count cue would find the blob
  const CompensatedWindow& w = compensator_->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
  const DetectionResult one = Detector(o, lens()).detect(detector_input(w));
  EXPECT_FALSE(one.strongest());
  EXPECT_EQ(one.status, DetectionStatus::kWeakEvidence);
  EXPECT_EQ(one.candidates, 1);
  o.gaussian_fit.max_candidates = 3;
  const DetectionResult more = Detector(o, lens()).detect(detector_input(w));
  EXPECT_EQ(more.candidates, 3);  // the decoy, the blob, and the decoy again in the search for a second object
  expect_on_blob(more, s, 2.0);
  EXPECT_GE(more.strongest()->event_density, 2.0);
  // Without the density gate the decoy wins: it is the strongest pattern.
  o.min_event_density = 0;
  const DetectionResult ungated = Detector(o, lens()).detect(detector_input(w));
  ASSERT_TRUE(ungated.strongest());
  EXPECT_NEAR(ungated.strongest()->center_undistorted.x(), 461.5, 3.0);
}

// A small dense blob with sparse late clutter 50-70 px around it (posters on a wall): from the
// half-image initial ROI Algorithm 1 spreads over blob and clutter, and the box fails the density
// gate; from a smaller initial ROI (refit_min_roi_px) it converges on the blob.
TEST_F(DetectorTest, SmallerInitialRoiFindsASmallBlobInSparseClutter) {
  test::BlobScene s;
  s.start_uv = {300, 240};
  std::vector<Event> ev = test::make_scene(lens(), s);
  const Eigen::Vector2d mid = s.blob_at(s.t0 + s.duration / 2);
  // Sparse clutter: 10x10 squares, one event per pixel, later than most of the background but not the latest (N ≈ 0.7).
  const Eigen::Vector2d offsets[] = {{-70, 0}, {70, 0}, {0, -50}, {0, 50}, {-60, -45}, {60, 45}};
  for (const Eigen::Vector2d& off : offsets)
    for (int y = 0; y < 10; ++y)
      for (int x = 0; x < 10; ++x) {
        Event e{s.t0 + 17 * kNsPerMs + (x + 10 * y) * 10'000, 0, 0, true};
        if (test::to_raw(lens(), mid + off + Eigen::Vector2d(x - 5, y - 5), e)) ev.push_back(e);
      }
  std::sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  const CompensatedWindow& w = compensator_->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
  DetectorOptions o;
  o.min_pixel_events = 1;  // the clutter's single-event pixels enter S
  o.gaussian_fit.max_candidates = 1;
  o.gaussian_fit.refit_min_roi_px = 0;  // the paper: one fit from half the image
  const DetectionResult paper = Detector(o, lens()).detect(detector_input(w));
  EXPECT_FALSE(paper.strongest()) << "the half-image fit should spread over the clutter";
  o.gaussian_fit.refit_min_roi_px = 16;
  const DetectionResult refit = Detector(o, lens()).detect(detector_input(w));
  expect_on_blob(refit, s, 2.5);
  EXPECT_LT(refit.strongest()->box_undistorted.width(), 40);
}

// A pattern under min_peak is taken only inside a confirmed track's gate, at prior_min_peak.
TEST_F(DetectorTest, TrackPriorAdmitsAWeakerPatternOnlyInsideItsGate) {
  test::BlobScene s;
  const auto ev = test::make_scene(lens(), s);
  const CompensatedWindow& w = compensator_->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
  DetectorOptions o;
  o.gaussian_fit.min_peak = 0.99;  // nothing passes the normal gate
  o.track_aided.min_peak = 0.3;
  o.count_contrast.still_motion = 0;  // the camera is still: the count cue would find the blob
  Detector detector(o, lens());
  EXPECT_FALSE(detector.detect(detector_input(w)).strongest());
  const PinholeCamera cam = lens();
  auto raw_of = [&](const Eigen::Vector2d& uv) {
    return cam.normalized_to_pixel({(uv.x() - cam.cx) / cam.fx, (uv.y() - cam.cy) / cam.fy});
  };
  // The prior where the blob is at mid-window (as a Kalman prediction would put it).
  const DetectionPrior on_blob{raw_of(s.blob_at(s.t0 + s.duration / 2)), {14, 14}};
  const DetectionResult aided = detector.detect(detector_input(w), std::span(&on_blob, 1));
  expect_on_blob(aided, s, 2.0);
  EXPECT_TRUE(aided.strongest()->track_aided);
  // A prior 100 px away opens a gate with only background in it.
  const DetectionPrior elsewhere{raw_of(s.blob_at(s.t0) + Eigen::Vector2d(100, 100)), {14, 14}};
  EXPECT_FALSE(detector.detect(detector_input(w), std::span(&elsewhere, 1)).strongest());
  // A gate 14 px ahead of the blob holds only its leading edge: the pattern is seeded there, but
  // the box the fit finds is centred outside the gate, so it is not taken.
  const DetectionPrior at_edge{raw_of(s.blob_at(s.t0 + s.duration) + Eigen::Vector2d(14, 0)), {2, 2}};
  EXPECT_FALSE(detector.detect(detector_input(w), std::span(&at_edge, 1)).strongest());
}

// A far, spinning, textured ball: events all over its disk throughout the window (the scene's
// blob), moving slowly (8 px per window). With N's cue switched off (min_peak = prior_min_peak = 1),
// only the dense-motion source can find it, and only inside a track's gate.
TEST_F(DetectorTest, DenseMotionCueFindsASlowDenseBlobInsideATrackGateOnly) {
  test::BlobScene s;
  s.radius_px = 9;
  s.velocity_px_s = {0, -320};
  s.blob_rate_ev_s = 2'000'000;
  DetectorOptions o;
  o.gaussian_fit.min_peak = 1.0;
  o.track_aided.min_peak = 1.0;
  // The count-contrast source would find this dense blob too (inside a gate it asks no motion): this
  // test is about the dense-motion source alone.
  o.count_contrast.enabled = false;
  const PinholeCamera cam = lens();
  auto raw_of = [&](const Eigen::Vector2d& uv) {
    return cam.normalized_to_pixel({(uv.x() - cam.cx) / cam.fx, (uv.y() - cam.cy) / cam.fy});
  };
  const DetectionPrior on_blob{raw_of(s.blob_at(s.t0 + s.duration / 2)), {18, 18}};
  auto detect = [&](const test::BlobScene& scene, const DetectorOptions& options,
                    std::span<const DetectionPrior> priors) {
    const auto ev = test::make_scene(cam, scene);
    const CompensatedWindow& w =
        compensator_->compensate({.events = ev, .t_start = scene.t0, .t_end = scene.t0 + scene.duration});
    Detector detector(options, cam);
    return detector.detect(detector_input(w), priors);
  };

  const DetectionResult found = detect(s, o, std::span(&on_blob, 1));
  ASSERT_TRUE(found.strongest()) << to_string(found.status);
  const Detection2D& d = *found.strongest();
  EXPECT_EQ(d.source, DetectionSource::kDenseMotion);
  EXPECT_TRUE(d.track_aided);
  EXPECT_GE(test::dense_motion_of(found).r2, o.dense_motion.min_r2);
  EXPECT_DOUBLE_EQ(d.score, test::dense_motion_of(found).r2);
  // T rises by 8 px per window along −y: across the 21 px square that is ≈ 2.6 windows on an
  // infinite edge; the finite disk gives less, but well above the gate.
  EXPECT_GT(test::dense_motion_of(found).span, 0.3);
  EXPECT_LT((d.center_undistorted - s.blob_at(d.t)).norm(), 2.0)
      << d.center_undistorted.transpose() << " vs " << s.blob_at(d.t).transpose();
  EXPECT_LT(d.box_undistorted.width(), 4 * s.radius_px);

  // Without a gate the cue does not run (it would report any dense moving thing, e.g. a person).
  const DetectionResult no_prior = detect(s, o, {});
  EXPECT_FALSE(no_prior.strongest());
  EXPECT_FALSE(test::ran(no_prior, DenseMotionSource::kName));
  // Switched off.
  DetectorOptions off = o;
  off.dense_motion.enabled = false;
  EXPECT_FALSE(detect(s, off, std::span(&on_blob, 1)).strongest());
  // The same dense blob standing still: no trend of T across it.
  test::BlobScene still = s;
  still.velocity_px_s = {0, 0};
  const DetectionResult static_blob = detect(still, o, std::span(&on_blob, 1));
  EXPECT_FALSE(static_blob.strongest());
  EXPECT_TRUE(test::ran(static_blob, DenseMotionSource::kName));
  EXPECT_LT(test::dense_motion_of(static_blob).r2, o.dense_motion.min_r2);
}

// The hovering camera's jerk (docs/DETECTION.md, "Count-contrast source"): the textured background
// fires only in the window's last 40 %, so it is late in N; a slow ball fires evenly over the
// window. Static camera, so `none` is the exact compensation. `spot` adds a static, dense,
// compact spot of texture (radius 5 px, 4 events per pixel) that fires with the background.
std::vector<Event> late_background_scene(const PinholeCamera& cam, const test::BlobScene& s, bool spot) {
  test::BlobScene ball_only = s;
  ball_only.edge_segments = 0;
  ball_only.noise_rate_ev_s = 0;
  std::vector<Event> ev = test::make_scene(cam, ball_only);
  std::mt19937 rng(s.seed + 7);
  std::uniform_int_distribution<TimeNs> late(s.t0 + s.duration * 6 / 10, s.t0 + s.duration - 1);
  std::uniform_real_distribution<double> ux(0, cam.width - 1), uy(0, cam.height - 1), unit(0, 1);
  const Eigen::Vector2d ball = s.blob_at(s.t0 + s.duration / 2), spot_at(450, 320);
  auto add = [&](const Eigen::Vector2d& uv, int count) {
    Event e;
    if (!test::to_raw(cam, uv, e)) return;
    for (int k = 0; k < count; ++k) {
      e.t = late(rng);
      e.polarity = k % 2 == 0;
      ev.push_back(e);
    }
  };
  for (int i = 0; i < s.edge_segments; ++i) {  // texture edges, 3 events per pixel
    const Eigen::Vector2d a(ux(rng), uy(rng));
    const double ang = unit(rng) * M_PI, len = 20 + 60 * unit(rng);
    for (double l = 0; l < len; l += 1.0) {
      const Eigen::Vector2d p = a + l * Eigen::Vector2d(std::cos(ang), std::sin(ang));
      if ((p - ball).norm() > 40 && (p - spot_at).norm() > 40) add(p, 3);
    }
  }
  const int n_noise = static_cast<int>(s.noise_rate_ev_s * to_seconds(s.duration));
  for (int i = 0; i < n_noise; ++i) add({ux(rng), uy(rng)}, 1);
  if (spot)
    for (int dy = -5; dy <= 5; ++dy)
      for (int dx = -5; dx <= 5; ++dx)
        if (dx * dx + dy * dy <= 25) add(spot_at + Eigen::Vector2d(dx, dy), 4);
  std::sort(ev.begin(), ev.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  return ev;
}

/// The count-contrast source's search done the obvious way, for comparison with the detector's pruned
/// one: every centre whose surround lies in the image, raster order, box sums from a prefix-sum
/// table in int64 of I saturated at 255 and of its active pixels.
struct CountContrastSearch {
  double best_contrast = 0, best_fill = 0;
  int filled_centers = 0;
};
CountContrastSearch count_contrast_by_brute_force(const CompensatedEventsView& view, const DetectorOptions& o) {
  TimeImages ti;
  build_time_images(view, ti);
  const int w = ti.count.cols, h = ti.count.rows, k = o.count_contrast.box_px, hk = k / 2;
  const int hs = static_cast<int>(std::lround(0.5 * o.count_contrast.surround_scale * k));
  std::vector<std::int64_t> count((w + 1) * (h + 1), 0), active((w + 1) * (h + 1), 0);
  auto at = [w](std::vector<std::int64_t>& t, int x, int y) -> std::int64_t& { return t[y * (w + 1) + x]; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int c = ti.count.at<std::int32_t>(y, x);
      at(count, x + 1, y + 1) = std::min(c, 255) + at(count, x, y + 1) + at(count, x + 1, y) - at(count, x, y);
      at(active, x + 1, y + 1) =
          (c >= o.min_pixel_events) + at(active, x, y + 1) + at(active, x + 1, y) - at(active, x, y);
    }
  auto sum = [&](std::vector<std::int64_t>& t, int x0, int y0, int side) {
    return static_cast<double>(at(t, x0 + side, y0 + side) - at(t, x0, y0 + side) - at(t, x0 + side, y0) + at(t, x0, y0));
  };
  const double center_area = static_cast<double>(k) * k;
  const double ring_area = static_cast<double>(2 * hs + 1) * (2 * hs + 1) - center_area;
  const double image_density = static_cast<double>(ti.events) / (static_cast<double>(w) * h);
  CountContrastSearch r;
  for (int y = hs; y < h - hs; ++y)
    for (int x = hs; x < w - hs; ++x) {
      const double fill = sum(active, x - hk, y - hk, k) / center_area;
      if (fill < o.count_contrast.min_fill) continue;
      ++r.filled_centers;
      const double in = sum(count, x - hk, y - hk, k);
      const double surround = (sum(count, x - hs, y - hs, 2 * hs + 1) - in) / ring_area;
      const double contrast = in / center_area / std::max(surround, image_density);
      if (contrast > r.best_contrast) r.best_contrast = contrast, r.best_fill = fill;
    }
  return r;
}

void expect_count_contrast_search_as_brute_force(const DetectionResult& r, const CompensatedEventsView& view,
                                            const DetectorOptions& o) {
  const CountContrastSearch expected = count_contrast_by_brute_force(view, o);
  EXPECT_EQ(test::count_contrast_of(r).filled_centers, expected.filled_centers);
  EXPECT_DOUBLE_EQ(test::count_contrast_of(r).contrast, expected.best_contrast);
  EXPECT_DOUBLE_EQ(test::count_contrast_of(r).fill, expected.best_fill);
}

TEST_F(DetectorTest, CountContrastCueFindsAnEvenlyFiringBlobOnALateBackground) {
  test::BlobScene s;
  s.radius_px = 8;
  s.velocity_px_s = {60, 40};  // ≈ 1.8 px per window: a far head-on ball
  s.blob_rate_ev_s = 40'000;   // ≈ 1000 events, ≈ 4 per pixel of its sweep
  s.edge_segments = 120;
  s.noise_rate_ev_s = 1'000'000;
  const PinholeCamera cam = lens();
  auto detect = [&](const std::vector<Event>& ev, const DetectorOptions& options) {
    const CompensatedWindow& w =
        compensator_->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
    Detector detector(options, cam);
    return detector.detect(detector_input(w));
  };
  DetectorOptions off, on;
  off.count_contrast.enabled = false;
  on.count_contrast.enabled = true;
  off.gate_focal_px = on.gate_focal_px = 0;  // the reference scan below uses box_px as given
  const auto scene = late_background_scene(cam, s, false);
  // The premise: the time-based detector does not find the ball.
  const DetectionResult paper = detect(scene, off);
  EXPECT_TRUE(!paper.strongest() || (paper.strongest()->center_undistorted - s.blob_at(paper.strongest()->t)).norm() > 10)
      << paper.strongest()->center_undistorted.transpose();
  EXPECT_FALSE(test::ran(paper, CountContrastSource::kName));

  const DetectionResult found = detect(scene, on);
  {
    SCOPED_TRACE("few filled centres: their box sums taken directly");
    const CompensatedWindow& w =
        compensator_->compensate({.events = scene, .t_start = s.t0, .t_end = s.t0 + s.duration});
    expect_count_contrast_search_as_brute_force(found, detector_input(w), on);
    EXPECT_GT(test::count_contrast_of(found).filled_centers, 0);
    EXPECT_LT(test::count_contrast_of(found).filled_centers, 1000);
  }
  const CountContrastDiagnostics cc = test::count_contrast_of(found);
  ASSERT_TRUE(found.strongest()) << to_string(found.status) << ", contrast " << cc.contrast << ", fill " << cc.fill
                                 << ", time offset " << cc.time_offset;
  const Detection2D& d = *found.strongest();
  EXPECT_EQ(d.source, DetectionSource::kCountContrast);
  EXPECT_FALSE(d.track_aided);
  EXPECT_GE(test::count_contrast_of(found).contrast, on.count_contrast.min_contrast);
  EXPECT_GE(test::count_contrast_of(found).fill, on.count_contrast.min_fill);
  EXPECT_NEAR(d.score, 1.0 - 1.0 / test::count_contrast_of(found).contrast, 1e-12);
  // Early against the late background: the ball's mean time is mid-window (0.5), the background's
  // ≈ 0.8 of it; by more than θ's margin c = 0.1 (static camera: ω = v = 0).
  EXPECT_LT(test::count_contrast_of(found).time_offset, -0.2);
  // At the ball's true centre at the detection's time, with the ball's size.
  EXPECT_LT((d.center_undistorted - s.blob_at(d.t)).norm(), 2.0)
      << d.center_undistorted.transpose() << " vs " << s.blob_at(d.t).transpose();
  EXPECT_GT(d.box_undistorted.width(), s.radius_px);
  EXPECT_LT(d.box_undistorted.width(), 4 * s.radius_px);

  // The same late background without the ball: no compact blob (edges are thin, the activity is
  // sparse: no centre box is filled).
  test::BlobScene no_ball = s;
  no_ball.blob_rate_ev_s = 0;
  const DetectionResult background = detect(late_background_scene(cam, no_ball, false), on);
  EXPECT_FALSE(background.strongest()) << background.strongest()->center_undistorted.transpose();
  EXPECT_TRUE(test::ran(background, CountContrastSource::kName));
  EXPECT_LT(test::count_contrast_of(background).contrast, on.count_contrast.min_contrast);

  // A dense, compact static spot that fires with the background: dense enough in I, but its
  // events follow the background's time profile, so the time test rejects it.
  const DetectionResult spot = detect(late_background_scene(cam, no_ball, true), on);
  EXPECT_FALSE(spot.strongest()) << spot.strongest()->center_undistorted.transpose();
  EXPECT_GE(test::count_contrast_of(spot).contrast, on.count_contrast.min_contrast);
  EXPECT_LT(std::abs(test::count_contrast_of(spot).time_offset), 0.1);

  // Uniform density: every pixel fires evenly, ≈ 4 events each (a large, evenly textured
  // surface): the centre boxes are filled (P(I ≥ 2) ≈ 0.91), but none is denser than its
  // surroundings.
  test::BlobScene uniform;
  uniform.blob_rate_ev_s = 0;
  uniform.edge_segments = 0;
  uniform.noise_rate_ev_s = 4.0 * 640 * 480 / to_seconds(uniform.duration);
  const auto ev = test::make_scene(cam, uniform);
  const CompensatedWindow& w =
      compensator_->compensate({.events = ev, .t_start = uniform.t0, .t_end = uniform.t0 + uniform.duration});
  Detector detector(on, cam);
  const DetectionResult flat = detector.detect(detector_input(w));
  EXPECT_FALSE(flat.strongest()) << to_string(flat.status);
  EXPECT_TRUE(test::ran(flat, CountContrastSource::kName));
  EXPECT_GE(test::count_contrast_of(flat).fill, on.count_contrast.min_fill);
  // The best of ≈ 300 k centres: a 9x9 box's mean count fluctuates by ≈ 0.22 around 4.
  EXPECT_LT(test::count_contrast_of(flat).contrast, 2.0);
  SCOPED_TRACE("most centres filled: box sums from the whole image's table");
  expect_count_contrast_search_as_brute_force(flat, detector_input(w), on);
  EXPECT_GT(test::count_contrast_of(flat).filled_centers, 100'000);
}

TEST_F(DetectorTest, CountContrastCueSkipsNoFilledCenterAtTheEdgesOfItsBlocks) {
  // The search skips blocks of 8x8 centres whose boxes together hold too few active pixels. Two
  // 9x9 boxes filled exactly at the threshold (65 of 81 active: a 4x4 hole in the middle, so that
  // no shifted box is filled), centred on the first and on the last centre of a block: a union
  // one pixel too small on either side would skip them.
  DetectorOptions o;
  o.gaussian_fit.min_peak = 1.0;  // the time-based detection is kept out of the way
  o.gate_focal_px = 0;            // box_px as given
  ASSERT_EQ(o.count_contrast.box_px, 9);
  ASSERT_DOUBLE_EQ(o.count_contrast.surround_scale, 3.0);  // centres from x, y = 14, in blocks of 8
  ASSERT_DOUBLE_EQ(o.count_contrast.min_fill, 0.8);
  const int w = 640, h = 480;
  std::vector<std::int32_t> pixel;
  std::vector<float> t_s;
  auto fire = [&](int x, int y, int n) {
    for (int i = 0; i < n; ++i) {
      pixel.push_back(y * w + x);
      t_s.push_back(0.001f * static_cast<float>(1 + (x + 3 * y + 7 * i) % 23));
    }
  };
  for (const cv::Point c : {cv::Point(14 + 8 * 10, 14 + 8 * 10), cv::Point(14 + 8 * 30 + 7, 14 + 8 * 20 + 7)})
    for (int dy = -4; dy <= 4; ++dy)
      for (int dx = -4; dx <= 4; ++dx)
        if (!(dx >= -2 && dx <= 1 && dy >= -2 && dy <= 1)) fire(c.x + dx, c.y + dy, 3);
  for (int i = 0; i < 2000; ++i) fire((37 * i) % w, (53 * i) % h, 1);  // sparse single events
  const CompensatedEventsView view{.t_start = 0, .t_end = 25 * kNsPerMs, .width = w, .height = h,
                                   .pixel = pixel, .t_s = t_s};
  Detector detector(o, lens());
  const DetectionResult r = detector.detect(view);
  ASSERT_TRUE(test::ran(r, CountContrastSource::kName)) << to_string(r.status);
  EXPECT_EQ(test::count_contrast_of(r).filled_centers, 2);
  EXPECT_DOUBLE_EQ(test::count_contrast_of(r).fill, 65.0 / 81.0);
  expect_count_contrast_search_as_brute_force(r, view, o);
}

TEST_F(DetectorTest, CountContrastCueWaivesTheTimeTestOnlyInsideATrackGate) {
  // An evenly firing ball on an evenly firing background: its mean time is the image's, so over
  // the image the time test rejects it; inside a confirmed track's gate (count_contrast_in_gates) the
  // track is the evidence that it moves. The camera is still, so the still-camera test, off until
  // the end, finds it over the image too.
  test::BlobScene s;
  s.radius_px = 8;
  s.velocity_px_s = {60, 40};
  s.blob_rate_ev_s = 40'000;
  s.edge_segments = 120;
  s.noise_rate_ev_s = 1'000'000;
  const PinholeCamera cam = lens();
  const auto ev = test::make_scene(cam, s);
  const CompensatedWindow& w =
      compensator_->compensate({.events = ev, .t_start = s.t0, .t_end = s.t0 + s.duration});
  const Eigen::Vector2d mid = s.blob_at(s.t0 + s.duration / 2);
  const DetectionPrior on_ball{cam.normalized_to_pixel({(mid.x() - cam.cx) / cam.fx, (mid.y() - cam.cy) / cam.fy}),
                               {16, 16}};
  DetectorOptions o;
  o.gaussian_fit.min_peak = 1.0;  // the time-based detection is kept out of the way
  o.track_aided.min_peak = 1.0;
  o.dense_motion.enabled = false;
  o.count_contrast.enabled = true;
  o.count_contrast.in_gates = false;
  o.count_contrast.still_motion = 0;
  const DetectionResult image_only = Detector(o, cam).detect(detector_input(w), std::span(&on_ball, 1));
  EXPECT_FALSE(image_only.strongest()) << to_string(image_only.strongest()->source);
  EXPECT_GE(test::count_contrast_of(image_only).contrast, o.count_contrast.min_contrast);
  EXPECT_LT(std::abs(test::count_contrast_of(image_only).time_offset), 0.1);
  o.count_contrast.in_gates = true;
  const DetectionResult gated = Detector(o, cam).detect(detector_input(w), std::span(&on_ball, 1));
  ASSERT_TRUE(gated.strongest()) << to_string(gated.status);
  EXPECT_EQ(gated.strongest()->source, DetectionSource::kCountContrast);
  EXPECT_TRUE(gated.strongest()->track_aided);
  EXPECT_LT((gated.strongest()->center_undistorted - s.blob_at(gated.strongest()->t)).norm(), 2.0);
  // Without a gate: nothing.
  EXPECT_FALSE(Detector(o, cam).detect(detector_input(w)).strongest());
  // With the still-camera test: the ball stands out from its surround and moves 1.8 px.
  o.count_contrast.still_motion = DetectorOptions{}.count_contrast.still_motion;
  const DetectionResult still = Detector(o, cam).detect(detector_input(w));
  ASSERT_TRUE(still.strongest()) << "isolation " << test::count_contrast_of(still).isolation << ", z "
                                 << test::count_contrast_of(still).motion_z;
  EXPECT_EQ(still.strongest()->source, DetectionSource::kCountContrast);
  EXPECT_FALSE(still.strongest()->track_aided);
  EXPECT_LT((still.strongest()->center_undistorted - s.blob_at(still.strongest()->t)).norm(), 2.0);
}

TEST(DetectorGates, EventCountGatesShrinkWithAShorterFocalLengthOnly) {
  DetectorOptions o;
  o.min_event_density = 1.5;
  o.count_contrast.box_px = 9;
  o.gate_focal_px = 500;
  PinholeCamera cam = lens();
  // Half the focal length: half the density; the 4.5 px box rounds to 5 (odd).
  cam.fx = 250;
  DetectorOptions scaled = scaled_to_camera(o, cam);
  EXPECT_DOUBLE_EQ(scaled.min_event_density, 0.75);
  EXPECT_EQ(scaled.count_contrast.box_px, 5);
  // 2/9 of it: the 2 px box would be even; the next odd size is 3, also the smallest allowed.
  cam.fx = 500.0 * 2 / 9;
  scaled = scaled_to_camera(o, cam);
  EXPECT_NEAR(scaled.min_event_density, 1.5 * 2 / 9, 1e-12);
  EXPECT_EQ(scaled.count_contrast.box_px, 3);
  cam.fx = 50;
  EXPECT_EQ(scaled_to_camera(o, cam).count_contrast.box_px, 3);
  // The reference focal length and longer ones keep the values as given, and so does 0 (off).
  for (const double fx : {500.0, 1000.0}) {
    cam.fx = fx;
    scaled = scaled_to_camera(o, cam);
    EXPECT_EQ(scaled.min_event_density, 1.5) << fx;
    EXPECT_EQ(scaled.count_contrast.box_px, 9) << fx;
  }
  o.gate_focal_px = 0;
  cam.fx = 250;
  EXPECT_EQ(scaled_to_camera(o, cam).min_event_density, 1.5);
  // The detector uses the scaled values.
  o.gate_focal_px = 500;
  EXPECT_DOUBLE_EQ(Detector(o, cam).options().min_event_density, 0.75);
}

TEST_F(DetectorTest, InvalidOptionsAreRejected) {
  DetectorOptions o;
  o.mean_filter_px = 4;
  EXPECT_NE(o.validate().find("mean_filter_px"), std::string::npos);
  EXPECT_THROW(Detector(o, lens()), ConfigError);
  // Each bad value alone, and the words the message must name.
  const std::vector<std::pair<const char*, std::function<void(DetectorOptions&)>>> cases = {
      {"δ_C", [](DetectorOptions& x) { x.fit_delta_center_px = 0; }},
      {"threshold_a_s_per_rad (a)", [](DetectorOptions& x) { x.threshold_a_s_per_rad = -0.01; }},
      {"threshold_b_s_per_m (b)", [](DetectorOptions& x) { x.threshold_b_s_per_m = -1; }},
      {"threshold_c (c) must be in [-1, 1], got -5", [](DetectorOptions& x) { x.threshold_c = -5; }},
      {"max_candidates", [](DetectorOptions& x) { x.gaussian_fit.max_candidates = 0; }},
      {"min_pixel_events", [](DetectorOptions& x) { x.min_pixel_events = 0; }},
      {"min_event_density", [](DetectorOptions& x) { x.min_event_density = -1; }},
      {"gate_focal_px must be 0 (off) or in [10, 1e5], got 5", [](DetectorOptions& x) { x.gate_focal_px = 5; }},
      {"dense_motion_density_px", [](DetectorOptions& x) { x.dense_motion.density_px = 4; }},
      {"dense_motion_min_r2", [](DetectorOptions& x) { x.dense_motion.min_r2 = 1.5; }},
      {"refine_recenter_passes", [](DetectorOptions& x) { x.refine_recenter_passes = -1; }},
      {"refine_grow_density must be in [0, 1], got 2", [](DetectorOptions& x) { x.refine_grow_density = 2; }},
      {"refine_grow_contrast", [](DetectorOptions& x) { x.refine_grow_contrast = -1; }},
      {"dense_motion_min_pixels", [](DetectorOptions& x) { x.dense_motion.min_pixels = 2; }},
      {"refit_min_roi_px", [](DetectorOptions& x) { x.gaussian_fit.refit_min_roi_px = 0.5; }},
      {"refit_local_scale", [](DetectorOptions& x) { x.gaussian_fit.refit_local_scale = -1; }},
      {"count_contrast_box_px", [](DetectorOptions& x) { x.count_contrast.box_px = 8; }},
      {"count_contrast_surround_scale", [](DetectorOptions& x) { x.count_contrast.surround_scale = 1; }},
      {"count_contrast_min_contrast", [](DetectorOptions& x) { x.count_contrast.min_contrast = 0.5; }},
      {"count_contrast_min_fill", [](DetectorOptions& x) { x.count_contrast.min_fill = 1.2; }},
      {"count_contrast_still_motion", [](DetectorOptions& x) { x.count_contrast.still_motion = -0.1; }},
      {"count_contrast_still_isolation", [](DetectorOptions& x) { x.count_contrast.still_min_isolation = 0.5; }},
      {"count_contrast_still_motion_z", [](DetectorOptions& x) { x.count_contrast.still_min_motion_z = NAN; }},
      {"count_contrast_sparse_chance", [](DetectorOptions& x) { x.count_contrast.sparse_chance = 1; }},
      {"count_contrast_sparse_chance", [](DetectorOptions& x) { x.count_contrast.sparse_chance = NAN; }},
      {"evidence_cell_px", [](DetectorOptions& x) { x.evidence.cell_px = 1; }},
      {"evidence_signal_sigma", [](DetectorOptions& x) { x.evidence.signal_sigma = 0; }},
      {"evidence_threshold", [](DetectorOptions& x) { x.evidence.threshold = NAN; }},
      {"evidence_max_window_llr", [](DetectorOptions& x) { x.evidence.max_window_llr = -1; }},
      {"evidence_background_weight", [](DetectorOptions& x) { x.evidence.background_weight = 0; }},
      {"evidence_min_background", [](DetectorOptions& x) { x.evidence.min_background = -1; }},
      {"evidence_min_travel_cells", [](DetectorOptions& x) { x.evidence.min_travel_cells = 6; }},
      {"evidence_warmup_windows", [](DetectorOptions& x) { x.evidence.warmup_windows = -1; }},
      {"evidence_max_surround_ratio", [](DetectorOptions& x) { x.evidence.max_surround_ratio = -0.1; }},
      {"evidence_min_isolation", [](DetectorOptions& x) { x.evidence.min_isolation = NAN; }},
  };
  for (const auto& [name, make_bad] : cases) {
    DetectorOptions bad;
    make_bad(bad);
    EXPECT_NE(bad.validate().find(name), std::string::npos) << name;
  }
  EXPECT_TRUE(DetectorOptions{}.validate().empty());
}

}  // namespace
}  // namespace fdv
