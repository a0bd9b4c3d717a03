#pragma once
/// The paper's two tables reproduced on the simulator (`fdv table1`, `fdv table2`), with the
/// project's targets beside the figures, as Markdown for docs/RESULTS.md.
///
///   PaperTableOptions o;                        // seeds 101-105, cache out/cache
///   const Table1 t1 = compute_table1(o);        // simulates what the cache lacks, runs 80 times
///   std::cout << to_markdown(t1, {"fdv table1 ...", "2026-01-01", "abc1234"});
///
/// Table I (paper §V-B): per compensation method, the per-window compensation time and the
/// relative contrast η on scene1_no_object / scene2_ball, plus detection metrics on four scenes;
/// then detection by apparent size, for balls cut by the border and per ball, on more
/// scenes and cameras at the pipeline's compensation.
/// Table II (paper §V-C): APE of the final fusion and monocular estimates of the ball on
/// fast_forward / swing, and on hover_headon how soon the first fusion estimate came and how well
/// it predicted the closest approach. Every figure pools all seeds (see the notes in the Markdown).
/// Thread safety: no state between calls, but two calls sharing a cache_dir from two threads may
/// simulate the same dataset into it at once: one table at a time per cache folder.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fdv/eval/detection_metrics.h"
#include "fdv/eval/estimate_metrics.h"
#include "fdv/pipeline/perception.h"

namespace fdv {

struct PaperTableOptions {
  std::vector<std::uint64_t> seeds{101, 102, 103, 104,
                                   105};  ///< evaluation seeds (tuning uses others)
  std::string cache_dir =
      "out/cache";  ///< simulated datasets, reused between runs (ensure_simulated)
  /// Seeds of Table I's any-size detection table (its 1280x720 datasets are slow to
  /// simulate): unset = `seeds`, empty = no such table (the paper's rows only).
  std::optional<std::vector<std::uint64_t>> any_size_seeds;
  /// The event camera of close_pass's DAVIS346 row; relative to the working folder.
  std::string davis346_calibration = "../shared/data/real/davis346_00000133_calibration.xml";
  /// Base pipeline options; each row overrides compensation.method.
  PerceptionOptions perception;
  std::string validate() const;
};

/// Where the figures come from, for the document: the exact command, date and source revision.
struct Provenance {
  std::string command, date, commit;
};

/// One requirement checked against a figure.
struct TableTarget {
  std::string what, figure, goal;
  bool met = false;
};

/// One (scene, compensation method) pooled over the seeds.
struct CompensationRow {
  std::string scene, method;
  std::vector<double> compensation_ms, front_end_ms;  ///< every window of every seed
  std::vector<double> relative_contrast;              ///< every window where η is defined
  DetectionMetrics detection;
  std::vector<DetectionMetrics> per_seed;  ///< each seed's own, for the seed-to-seed spread
};

/// A simulated scene of Table I's any-size detection table: a preset at its own event
/// camera, at another resolution (same field of view, sim::set_event_resolution), or with the
/// event camera of a calibration file (`fdv simulate --camera`).
struct SceneVariant {
  std::string preset;
  int width = 0, height = 0;  ///< 0: the preset's own resolution
  std::string camera_file;    ///< non-empty: the event camera of this calibration file
  /// "640x480 (preset)", "346x260", "DAVIS346 calibration" ...: the table's camera column.
  std::string camera_label() const;
  /// The dataset's folder name in the cache: PRESET_seedSEED, with the camera as a suffix.
  std::string cache_name(std::uint64_t seed) const;
};

/// One scene variant's detection metrics at the pipeline's compensation (rotation_translation),
/// pooled over the seeds.
struct AnySizeRow {
  SceneVariant scene;
  int balls = 0;  ///< balls in the scene's truth
  DetectionMetrics detection;
  std::vector<DetectionMetrics> per_seed;  ///< each seed's own, for the seed-to-seed spread
};

/// How much a detection row's figures vary from seed to seed: the sample standard deviation of
/// each seed's own figure, over the seeds where it is defined (recall and centre error need an
/// eligible window); NaN with fewer than two such seeds. The yardstick of the any-size detection's
/// "no Table I row gets worse by more than its seed-to-seed spread".
struct SeedSpread {
  double recall = 0;                ///< Table I's recall (per window)
  double median_center_error_px = 0;
  double false_per_window = 0;
  double any_size_recall = 0;       ///< any size: every eligible (window, ball) pair
};
SeedSpread seed_spread(const std::vector<DetectionMetrics>& per_seed);

struct Table1 {
  std::vector<std::uint64_t> seeds;
  TimeNs step_ns = 0;                 ///< Δs, a window every Δs: the real-time bound
  int denoise_mean_filter_px = 0;     ///< η's shared denoising: the detector's mean filter side
  int denoise_opening_px = 0;         ///< and its opening's side
  std::vector<CompensationRow> rows;  ///< scenes × methods, in display order
  /// table1_any_size_scenes(), in that order (none without any-size seeds).
  std::vector<AnySizeRow> any_size_rows;
  std::vector<std::uint64_t> any_size_seeds;
  const CompensationRow* row(const std::string& scene, const std::string& method) const;
};

/// The scenes and methods of Table I.
const std::vector<std::string>& table1_compensation_scenes();  ///< scene1_no_object, scene2_ball
const std::vector<std::string>& table1_detection_scenes();     ///< + fast_forward, hover_headon
const std::vector<std::string>&
table1_methods();  ///< none, rotation, rotation_translation, contrast_max
/// The any-size detection table's scenes: the detection scenes at their own camera, at 346x260 and
/// at 1280x720; close_pass with the DAVIS346's calibration (options.davis346_calibration), at
/// 640x480 and at 1280x720; two_balls.
std::vector<SceneVariant> table1_any_size_scenes(const PaperTableOptions& options);

Table1 compute_table1(const PaperTableOptions& options);
std::vector<TableTarget> table1_targets(const Table1& table);
std::string to_markdown(const Table1& table, const Provenance& provenance);

/// One (scene, estimator) of Table II pooled over the seeds.
struct ApeRow {
  std::string scene;
  EstimatorMode mode = EstimatorMode::kFusion;
  std::vector<double> samples;                       ///< APE at every truth sample, all seeds
  std::vector<std::optional<double>> rmse_per_seed;  ///< nothing where that seed had no estimate
  int usable_final_seeds = 0;  ///< seeds whose scored (final converged) estimate was also usable
  int seeds_with_estimate() const;
};

struct HeadOnRun {
  std::uint64_t seed = 0;
  BallEstimateTiming timing;
};

struct Table2 {
  std::vector<std::uint64_t> seeds;
  std::vector<ApeRow> ape;         ///< fast_forward, swing × fusion, mono
  std::vector<HeadOnRun> head_on;  ///< hover_headon, one per seed
  const ApeRow* row(const std::string& scene, EstimatorMode mode) const;
};

/// Runs the full pipeline (options.perception, rotation_translation) on each scene and seed.
Table2 compute_table2(const PaperTableOptions& options);
std::vector<TableTarget> table2_targets(const Table2& table);
std::string to_markdown(const Table2& table, const Provenance& provenance);

/// "101-105" for consecutive seeds, else "1, 3, 7".
std::string seeds_text(const std::vector<std::uint64_t>& seeds);

}  // namespace fdv
