// The evidence source (track-before-detect, evidence_source.h): its grid against the model's own
// analytic values on hand-made cell counts, then the source in a Detector on synthetic windows.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "fdv/detection/detector.h"
#include "fdv/detection/evidence_source.h"

namespace fdv {
namespace {

constexpr int kCols = 10, kRows = 8;

EvidenceSourceOptions grid_options() {
  EvidenceSourceOptions o;
  o.signal_sigma = 2;
  o.max_window_llr = 100;  // no cap unless a test sets one
  o.threshold = 12;
  o.warmup_windows = 8;
  o.min_background = 1;
  return o;
}

cv::Mat uniform_counts(float n) { return cv::Mat(kRows, kCols, CV_32F, cv::Scalar(n)); }

/// Feeds `windows` windows of n fired pixels in every cell.
void learn(EvidenceGrid& grid, float n, int windows) {
  for (int k = 0; k < windows; ++k) grid.update(uniform_counts(n));
}

TEST(EvidenceGrid, AConstantExcessAlongAPathConfirmsWhenTheModelSays) {
  const EvidenceSourceOptions o = grid_options();
  EvidenceGrid grid(o);
  grid.reset(kCols, kRows);
  learn(grid, 4, o.warmup_windows);
  // A target adding 6 fired pixels, one cell to the right each window, on cells that fired 4 in
  // every window (v = 0): μ = 4g with g = (326 + 80)/(320 + 80) (m is still 4 everywhere ahead of
  // the target; 80 cells of b_min = 1), σ² = μ + b_min, z = (10 − μ)/σ, and ℓ = δz − δ²/2 = 3.28 a
  // window: L passes h = 12 in the 4th.
  const double g = 406.0 / 400.0, mu = 4 * g, z = (10 - mu) / std::sqrt(mu + 1), l = 2 * z - 2;
  ASSERT_NEAR(l, 3.28, 0.01);
  int confirmed_in = 0;
  for (int k = 1; k <= 5; ++k) {
    cv::Mat n = uniform_counts(4);
    n.at<float>(4, k) = 10;
    grid.update(n);
    const double L = grid.evidence().at<float>(4, k);
    // Each earlier target cell's mean rose, so g is a little lower than above after the first:
    // within 2 % of k·ℓ.
    EXPECT_NEAR(L, k * l, 0.02 * k * l) << "window " << k;
    if (confirmed_in == 0 && L >= o.threshold) confirmed_in = k;
    // The target's cell holds the most; cells no path of it reaches have none (a path steps a
    // cell a window, and loses about δ²/2 a window away from the target).
    cv::Point best;
    cv::minMaxLoc(grid.evidence(), nullptr, nullptr, nullptr, &best);
    EXPECT_EQ(best, cv::Point(k, 4));
    EXPECT_EQ(grid.evidence().at<float>(0, 9), 0.f);
  }
  EXPECT_EQ(confirmed_in, 4);
}

TEST(EvidenceGrid, NoSingleWindowConfirmsHoweverStrongAndEvidenceFades) {
  EvidenceSourceOptions o = grid_options();
  o.max_window_llr = 4;  // h / ℓ_max = 3 windows at least
  EvidenceGrid grid(o);
  grid.reset(kCols, kRows);
  learn(grid, 4, o.warmup_windows);
  cv::Mat burst = uniform_counts(4);
  burst.at<float>(3, 3) = 1000;
  grid.update(burst);
  EXPECT_FLOAT_EQ(grid.evidence().at<float>(3, 3), 4.f);
  double peak = 0;
  cv::minMaxLoc(grid.evidence(), nullptr, &peak);
  EXPECT_LT(peak, o.threshold);
  // Back to the background: the burst's own cell now expects 115 (m ← m + (1000 − 4)/9), so
  // g ≈ (320 + 80)/(316 + 115 + 80) = 0.78, z ≈ (4 − 3.1)/2 and ℓ ≈ −1.1 a window: the 4 (which
  // the neighbours inherit through the 3 × 3 max) is gone within 4 windows.
  int windows = 0;
  for (; peak > 0 && windows < 10; ++windows) {
    learn(grid, 4, 1);
    cv::minMaxLoc(grid.evidence(), nullptr, &peak);
  }
  EXPECT_LE(windows, 4);
}

TEST(EvidenceGrid, ACellThatFiresInBurstsNeedsAnExcessOfItsOwnVariation) {
  EvidenceSourceOptions o = grid_options();
  o.signal_sigma = 6;
  o.max_window_llr = 4;
  EvidenceGrid grid(o);
  grid.reset(kCols, kRows);
  // Cell (2, 2) alternates 0 and 20 fired pixels (texture swept by a hovering camera): m ≈ 10,
  // v ≈ 100. Cell (6, 5) fires 1 (a quiet wall).
  auto window = [](int k, float bursty_extra, float quiet_extra) {
    cv::Mat n = uniform_counts(1);
    n.at<float>(2, 2) = (k % 2 ? 20.f : 0.f) + bursty_extra;
    n.at<float>(5, 6) = 1 + quiet_extra;
    return n;
  };
  int k = 0;
  for (; k < 60; ++k) grid.update(window(k, 0, 0));
  EXPECT_NEAR(grid.mean().at<float>(2, 2), 10, 1.5);
  EXPECT_NEAR(grid.variance().at<float>(2, 2), 100, 15);
  // The same 20 fired pixels more in both: z ≈ 20/10 = 2 in the bursty cell gives ℓ = 6·2 − 18 < 0,
  // z ≈ 20/1.4 in the quiet one ℓ_max.
  grid.update(window(k, 20, 20));
  EXPECT_LT(grid.llr().at<float>(2, 2), 0.f);
  EXPECT_FLOAT_EQ(grid.llr().at<float>(5, 6), 4.f);
  EXPECT_FLOAT_EQ(grid.evidence().at<float>(5, 6), 4.f);
}

TEST(EvidenceGrid, APathFollowsTheSceneThroughTheEgoMotionMap) {
  EvidenceSourceOptions o = grid_options();
  o.max_window_llr = 4;
  // The camera pans: the scene moves 2 cells right a window, so cell (x, y) was at (x − 2, y). A
  // target moving 1 cell a window over the scene moves 3 in the image: beyond the 3 × 3 step of a
  // path without the map, one cell from its scene point's previous cell with it.
  cv::Mat previous(kRows, kCols, CV_32FC2);
  for (int y = 0; y < kRows; ++y)
    for (int x = 0; x < kCols; ++x) previous.at<cv::Vec2f>(y, x) = cv::Vec2f(static_cast<float>(x - 2), static_cast<float>(y));
  for (const bool with_map : {true, false}) {
    EvidenceGrid grid(o);
    grid.reset(kCols, kRows);
    learn(grid, 0, o.warmup_windows);
    float at_target = 0;
    for (int k = 0; k < 4; ++k) {
      cv::Mat n = uniform_counts(0);
      n.at<float>(3, 3 * k) = 12;
      grid.update(n, with_map ? previous : cv::Mat());
      at_target = grid.evidence().at<float>(3, 3 * k);
    }
    if (with_map) EXPECT_FLOAT_EQ(at_target, 16.f);  // 4 windows of ℓ_max
    else EXPECT_FLOAT_EQ(at_target, 4.f);            // every window starts a new path
  }
}

// The source in a Detector: windows of uniform noise, with or without a small dim blob drifting
// (5, 3) px a window, seen by a still camera ("none" is the exact compensation).
constexpr int kNoisyWidth = 320, kNoisyHeight = 240;
constexpr double kNoisyWindowS = 0.025;

struct NoisyWindows {
  std::vector<std::int32_t> pixel;
  std::vector<float> t_s;
  std::mt19937 rng{7};

  /// An edge: a 48 px bar across the motion, 2 px wide, as the moving contour of a large object.
  /// A patch: a 20 px square firing on about half its pixels, as a spot of texture that the
  /// compensation leaves: its excess lies in the candidate's 3 × 3 cells, and in the window's image
  /// it runs on into the candidate box's surround.
  enum class Object { kNone, kBlob, kEdge, kPatch };
  CompensatedEventsView make(int k, bool blob, Eigen::Vector2d& blob_at) {
    return make(k, blob ? Object::kBlob : Object::kNone, blob_at);
  }
  CompensatedEventsView make(int k, Object object, Eigen::Vector2d& blob_at) {
    const bool blob = object == Object::kBlob;
    pixel.clear();
    t_s.clear();
    std::uniform_int_distribution<int> x(0, kNoisyWidth - 1), y(0, kNoisyHeight - 1);
    std::uniform_real_distribution<double> t(0, kNoisyWindowS), unit(0, 1);
    std::vector<std::pair<float, std::int32_t>> ev;
    for (int i = 0; i < 2000; ++i) ev.push_back({static_cast<float>(t(rng)), y(rng) * kNoisyWidth + x(rng)});
    blob_at = {20.0 + 5 * k, 40.0 + 3 * k};
    if (blob)
      for (int i = 0; i < 45; ++i) {  // radius 3: about 28 px, most of which fire
        const double r = 3 * std::sqrt(unit(rng)), a = 2 * M_PI * unit(rng);
        const int u = static_cast<int>(std::lround(blob_at.x() + r * std::cos(a)));
        const int v = static_cast<int>(std::lround(blob_at.y() + r * std::sin(a)));
        ev.push_back({static_cast<float>(t(rng)), v * kNoisyWidth + u});
      }
    if (object == Object::kPatch)
      for (int v = -10; v < 10; ++v)
        for (int u = -10; u < 10; ++u)
          if (unit(rng) < 0.5)
            ev.push_back({static_cast<float>(t(rng)), (static_cast<int>(std::lround(blob_at.y())) + v) * kNoisyWidth +
                                                          static_cast<int>(std::lround(blob_at.x())) + u});
    if (object == Object::kEdge)
      for (int i = -24; i < 24; ++i)  // along (−3, 5), perpendicular to the motion (5, 3)
        for (int w = 0; w < 2; ++w) {
          const double along = i / std::sqrt(34.0);
          const int u = static_cast<int>(std::lround(blob_at.x() - 3 * along + w));
          const int v = static_cast<int>(std::lround(blob_at.y() + 5 * along));
          if (u >= 0 && v >= 0 && u < kNoisyWidth && v < kNoisyHeight) ev.push_back({static_cast<float>(t(rng)), v * kNoisyWidth + u});
        }
    std::sort(ev.begin(), ev.end());
    for (const auto& [when, p] : ev) {
      t_s.push_back(when);
      pixel.push_back(p);
    }
    const TimeNs start = from_seconds(k * kNoisyWindowS);
    return {start, start + from_seconds(kNoisyWindowS), kNoisyWidth, kNoisyHeight, pixel, t_s};
  }
};

PinholeCamera small_camera() { return {.width = kNoisyWidth, .height = kNoisyHeight, .fx = 300, .fy = 300, .cx = 160, .cy = 120, .distortion = {}}; }

struct BlobRun {
  int found = 0;  ///< windows after the evidence could exist (warm-up + 3) with the blob found, of 26
  int evidence_hits = 0, evidence_misplaced = 0;
  double worst_px = 0;  ///< the evidence detections' largest distance from the blob's centre
  double least_isolation = 1e9;  ///< the smallest isolation the source reported with a detection
};

BlobRun run_blob(bool evidence, NoisyWindows::Object object = NoisyWindows::Object::kBlob,
               double max_surround_ratio = EvidenceSourceOptions{}.max_surround_ratio,
               double min_isolation = EvidenceSourceOptions{}.min_isolation) {
  DetectorOptions o;
  o.evidence.enabled = evidence;
  o.evidence.max_surround_ratio = max_surround_ratio;
  o.evidence.min_isolation = min_isolation;
  Detector detector(o, small_camera());
  NoisyWindows windows;
  BlobRun out;
  for (int k = 0; k < 50; ++k) {
    Eigen::Vector2d blob_at;
    const DetectionResult r = detector.detect(windows.make(k, object, blob_at));
    bool found = false;
    for (const Detection2D& d : r.detections) {
      const bool on_blob = (d.center_undistorted - blob_at).norm() < 3.0;
      found = found || on_blob;
      if (d.source == DetectionSource::kEvidence) {
        out.least_isolation = std::min(out.least_isolation, r.diagnostics<EvidenceDiagnostics>(EvidenceSource::kName)->isolation);
        ++(on_blob ? out.evidence_hits : out.evidence_misplaced);
        out.worst_px = std::max(out.worst_px, (d.center_undistorted - blob_at).norm());
      }
    }
    if (k >= o.evidence.warmup_windows + 4 && found) ++out.found;
  }
  return out;
}

TEST(EvidenceSource, ADimDriftingBlobIsFoundInMoreWindowsAndNoiseIsNot) {
  const BlobRun with = run_blob(true), without = run_blob(false);
  EXPECT_GT(with.evidence_hits, 0);
  // A path's predicted cell can take a noise cell's chance excess ahead of the blob: at most one
  // in ten (1 of 16 here, 16.9 px ahead).
  EXPECT_LE(10 * with.evidence_misplaced, with.evidence_hits) << "worst " << with.worst_px << " px";
  EXPECT_GT(with.found, without.found) << "of 26 windows";
  EXPECT_EQ(without.evidence_hits, 0);
  DetectorOptions o;
  o.evidence.enabled = true;
  Detector detector(o, small_camera());
  NoisyWindows windows;
  int noise_detections = 0;
  for (int k = 0; k < 60; ++k) {
    Eigen::Vector2d unused;
    noise_detections += static_cast<int>(detector.detect(windows.make(k, false, unused)).detections.size());
  }
  EXPECT_EQ(noise_detections, 0);
}

TEST(EvidenceSource, AWindowWithoutNewEvidenceIsSkipped) {
  // Overlapping windows: between each two windows, one whose events were counted already
  // (new_evidence false). The evidence source finds nothing in those, and in the others exactly
  // what it finds without them.
  DetectorOptions o;
  o.evidence.enabled = true;
  const auto evidence_centres = [](const DetectionResult& r) {
    std::vector<Eigen::Vector2d> c;
    for (const Detection2D& d : r.detections)
      if (d.source == DetectionSource::kEvidence) c.push_back(d.center_undistorted);
    return c;
  };
  Detector alone(o, small_camera()), interleaved(o, small_camera());
  NoisyWindows windows, same_windows, between;
  int found = 0;
  for (int k = 0; k < 50; ++k) {
    Eigen::Vector2d blob_at;
    const auto expected = evidence_centres(alone.detect(windows.make(k, true, blob_at)));
    const auto seen = evidence_centres(interleaved.detect(same_windows.make(k, true, blob_at)));
    ASSERT_EQ(seen.size(), expected.size()) << "window " << k;
    for (std::size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], expected[i]);
    found += static_cast<int>(seen.size());
    CompensatedEventsView repeat = between.make(k, true, blob_at);
    repeat.new_evidence = false;
    EXPECT_TRUE(evidence_centres(interleaved.detect(repeat)).empty()) << "window " << k;
  }
  EXPECT_GT(found, 0);
}

TEST(EvidenceSource, AMovingEdgeRunsThroughTheSurroundAndIsNoCandidate) {
  // The same motion as the blob's: without the surround test the edge's path gathers evidence
  // like the blob's; with κ = 0.5 (the edge puts about as many pixels in the ring 2-3 cells away
  // as in its own 3 × 3 cells) it makes none, and the blob still does.
  const BlobRun edge_unchecked = run_blob(true, NoisyWindows::Object::kEdge, 1e9);
  const BlobRun edge = run_blob(true, NoisyWindows::Object::kEdge, 0.5);
  const BlobRun blob = run_blob(true, NoisyWindows::Object::kBlob, 0.5);
  EXPECT_GT(edge_unchecked.evidence_hits + edge_unchecked.evidence_misplaced, 0);
  EXPECT_EQ(edge.evidence_hits + edge.evidence_misplaced, 0);
  EXPECT_GT(blob.evidence_hits, 0);
}

TEST(EvidenceSource, ATextureSpotRunsOnIntoItsImageSurroundAndIsNoCandidate) {
  // The patch's events lie in its 3 × 3 cells, so the grid's surround test passes it; in the
  // window's image the 8 px candidate box holds about 0.5 events per pixel and its surround (the
  // box grown by 8 px) about 0.33 of the patch's, an isolation near 1.5, against the blob's
  // 45 events on 28 px in noise of 0.026 per pixel.
  const BlobRun patch_unchecked = run_blob(true, NoisyWindows::Object::kPatch, EvidenceSourceOptions{}.max_surround_ratio, 0);
  const BlobRun patch = run_blob(true, NoisyWindows::Object::kPatch);
  const BlobRun blob = run_blob(true, NoisyWindows::Object::kBlob);
  EXPECT_GT(patch_unchecked.evidence_hits, 0);
  EXPECT_EQ(patch.evidence_hits + patch.evidence_misplaced, 0);
  EXPECT_GT(blob.evidence_hits, 0);
  // The diagnostics report the candidate's isolation: the gate's, and the patch's under it.
  EXPECT_GE(blob.least_isolation, EvidenceSourceOptions{}.min_isolation);
  EXPECT_LT(patch_unchecked.least_isolation, EvidenceSourceOptions{}.min_isolation);
}

TEST(EvidenceSource, ItsStateImagesAreTheGridOfTheLastWindow) {
  DetectorOptions o;
  o.evidence.enabled = true;
  Detector detector(o, small_camera());
  const int c = detector.options().evidence.cell_px, cols = (kNoisyWidth + c - 1) / c, rows = (kNoisyHeight + c - 1) / c;
  int calls = 0;
  detector.for_each_source_state([&](std::string_view, const std::vector<SourceStateImage>&) { ++calls; });
  EXPECT_EQ(calls, 0);  // nothing learned before the first window
  NoisyWindows windows;
  for (int k = 0; k < 12; ++k) {
    Eigen::Vector2d blob_at;
    detector.detect(windows.make(k, true, blob_at));
    // Each cell's fired pixels, counted here from the window's count image.
    cv::Mat fired(rows, cols, CV_32F, cv::Scalar(0));
    const cv::Mat& I = detector.time_images().count;
    for (int y = 0; y < kNoisyHeight; ++y)
      for (int x = 0; x < kNoisyWidth; ++x) fired.at<float>(y / c, x / c) += I.at<std::int32_t>(y, x) > 0 ? 1.f : 0.f;
    std::vector<std::string> names;
    detector.for_each_source_state([&](std::string_view source, const std::vector<SourceStateImage>& images) {
      ASSERT_EQ(source, EvidenceSource::kName);
      for (const SourceStateImage& im : images) {
        names.emplace_back(im.name);
        ASSERT_EQ(im.image->size(), cv::Size(cols, rows)) << im.name;
        EXPECT_EQ(im.image->type(), im.name == "travel" ? CV_32FC2 : CV_32F) << im.name;
        if (im.name == "fired") {
          EXPECT_EQ(cv::norm(*im.image, fired, cv::NORM_INF), 0) << "window " << k;
        }
        if (im.name == "evidence") {  // L in [0, 2h]
          double lo, hi;
          cv::minMaxLoc(*im.image, &lo, &hi);
          EXPECT_GE(lo, 0);
          EXPECT_LE(hi, 2 * o.evidence.threshold);
        }
      }
    });
    EXPECT_EQ(names, (std::vector<std::string>{"fired", "mean", "variance", "llr", "evidence", "excess", "travel"}));
  }
}

}  // namespace
}  // namespace fdv
