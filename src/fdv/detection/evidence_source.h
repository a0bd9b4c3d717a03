#pragma once
/// Candidate source 5 (not in the paper; docs/DETECTION.md, "Evidence source"): track-before-detect
/// for a far, small object that no single window shows convincingly. Every window, each C × C cell
/// of the compensated count image gives a log-likelihood ratio of "background and an object"
/// against "background alone" from its fired pixels and their own history; a dynamic programme
/// over windows adds it along the paths an object can take (a cell a window from where its recent
/// motion over the scene predicts it, after the ego-motion between windows), and the best cell
/// whose path's sum reaches the threshold h, that has travelled over the scene and that stands
/// alone (little excess in the ring of cells around it) is a candidate.
/// Incremental: one update a window, no history.
///
///   EvidenceSource source(options);   // once; allocate(width, height) before the first window
///   source.begin_window(in);          // every window that reaches the sources, before find()
///   std::optional<Candidate> c = source.find(in, res);
///   res.diagnostics<EvidenceDiagnostics>(EvidenceSource::kName)   // the best path's sum
/// Thread safety: not thread-safe (evidence across windows); owned by one Detector, used by one thread.
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "fdv/detection/candidate_source.h"
#include "fdv/detection/detector_options.h"

namespace fdv {

/// The evidence model of the source, on a grid of cells (EvidenceSourceOptions states the symbols).
/// Each cell c has a running mean m_c and variance v_c of its fired pixels per window; in a window
/// with n_c fired pixels:
///   μ_c = g·m_c, σ_c² = max(g²·v_c, μ_c) + b_min, with g = max(1, (Σ n + N·b_min) / (Σ m + N·b_min))
///         the window's activity over the expected, N cells (the camera speeding up raises every
///         cell alike: no object; b_min keeps a small object in an empty scene from setting g; a
///         quietening scene does not make the cells still firing look raised);
///   z_c = (n_c − μ_c) / σ_c, and ℓ_c = min(δ·z_c − δ²/2, ℓ_max): the log-likelihood ratio of a
///         mean shifted by δσ against none, for a Gaussian z (a cell that fires in bursts has a
///         large v and needs a large excess; a single window adds at most ℓ_max);
///   L_c = min(max(0, ℓ_c + L_p), 2h), where p is the best path a window ago (moved by the
///         ego-motion) among those whose cell moved by their recent step (1 − 0.8)·T_p lands within
///         a cell of c: the best path's sum, reset at 0 (Page's CUSUM along paths, a dynamic
///         programme), held below 2h so that an object that left fades within a few windows;
///   T_c = 0.8·T_p + (c − p): the path's recent travel over the scene [cells];
///   e_c = max(0, n_c − μ_c − σ_c): the cell's excess beyond its usual variation, for the
///         candidate's surround test (EvidenceSourceOptions::max_surround_ratio);
///   m_c, v_c ← exponential averages of weight max(α, 1/k) in the k-th window.
/// No evidence (ℓ = 0) in the first `warmup_windows` windows, while m and v are learned.
class EvidenceGrid {
 public:
  explicit EvidenceGrid(const EvidenceSourceOptions& options) : options_(options) {}
  /// Starts afresh on a cols × rows grid: no evidence, nothing learned.
  void reset(int cols, int rows);
  /// Ends every path (a window was missed), keeping m and v.
  void break_paths();
  /// One window: `fired` holds each cell's fired pixels (CV_32F, rows × cols). `previous` maps each
  /// cell to where its scene point was on the last window's grid, in cells (CV_32FC2: x, y); empty
  /// when the camera did not move. Does not allocate after the first call.
  void update(const cv::Mat& fired, const cv::Mat& previous = {});
  const cv::Mat& evidence() const { return evidence_; }  ///< L, CV_32F
  const cv::Mat& llr() const { return llr_; }            ///< ℓ of the last window, CV_32F
  /// The excess e_c = max(0, n_c − μ_c − σ_c) of the last window [fired pixels], CV_32F: what a
  /// cell fired beyond its usual variation (the surround test's measure).
  const cv::Mat& excess() const { return excess_; }
  const cv::Mat& mean() const { return mean_; }          ///< m, CV_32F
  const cv::Mat& variance() const { return variance_; }  ///< v, CV_32F
  int windows() const { return windows_; }
  /// Each path's recent travel over the scene [cells] (CV_32FC2): T ← 0.8·T(predecessor) + the
  /// step from it; a consistently moving object's grows to 5 cells at a cell a window.
  const cv::Mat& travel() const { return travel_; }
  static constexpr double kTravelMemory = 0.8;

 private:
  EvidenceSourceOptions options_;
  cv::Mat mean_, variance_, evidence_, llr_, excess_, predicted_evidence_, predicted_mean_, predicted_variance_;
  cv::Mat travel_, predicted_travel_;  ///< CV_32FC2
  cv::Mat best_offer_, offer_from_;    ///< the best predecessor's L (CV_32F) and cell (CV_32SC2)
  int windows_ = 0;
};

/// The best path's sum and cell in the last window, once the source updated.
struct EvidenceDiagnostics {
  double evidence = 0;  ///< the candidate's L, else the largest L below h of a path that passed the grid's tests
  int cell_x = -1, cell_y = -1;
  double isolation = 0;  ///< the candidate's (EvidenceSourceOptions::min_isolation); 0 without one
};

class EvidenceSource final : public CandidateSource {
 public:
  static constexpr std::string_view kName = "evidence";
  /// `options` must be valid (DetectorOptions::validate).
  explicit EvidenceSource(const DetectorOptions& options);
  void allocate(int width, int height) override;
  bool begin_window(const SourceWindow& in) override;
  std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) override;
  /// The grid after the last window that reached the sources, one value per cell: `fired` (n),
  /// `llr` (ℓ), `evidence` (L), `excess` (e), `mean` and `variance` (m and v once this window is
  /// learned; ℓ used them as they were before), all CV_32F, and `travel` (T [cells], CV_32FC2).
  /// Row y, column x is the cell of pixels [xC, (x+1)C) × [yC, (y+1)C).
  void state_images(std::vector<SourceStateImage>& out) const override;

 private:
  /// Each cell's fired pixels: the pixels of its count image with an event.
  void count_fired(const SourceWindow& in);
  /// Where each cell's centre goes by the next window's start (the window's observed_at after its
  /// length), into previous_ for the next update; moved_ false without ego-motion.
  void predict_motion(const SourceWindow& in);
  /// The surround test of EvidenceSourceOptions::max_surround_ratio at cell (x, y).
  bool isolated(int x, int y) const;
  /// The candidate of a path at `cell` with sum `evidence`: a C-sided box around the events'
  /// centroid over the cell and half a cell around it; nothing with too few events.
  std::optional<Candidate> candidate_at(const SourceWindow& in, cv::Point cell, double evidence) const;
  /// `found`'s isolation in the window's count image (EvidenceSourceOptions::min_isolation).
  double isolation_of(const SourceWindow& in, const Candidate& found) const;

  static constexpr int kCoarseStep = 4;   ///< the ego-motion is evaluated every this many cells
  static constexpr int kBorderCells = 2;  ///< rings of cells at the border that make no candidate

  DetectorOptions options_;
  EvidenceGrid grid_;
  int width_ = 0, height_ = 0, cols_ = 0, rows_ = 0;
  cv::Mat fired_, coarse_;
  std::vector<std::uint16_t> column_fired_;  ///< count_fired's per-column sums over one row of cells
  /// Where each cell's scene point was in the last window (EvidenceGrid::update's `previous`),
  /// written after each update for the next; valid when `moved_` (the window had ego-motion).
  cv::Mat previous_;
  bool moved_ = false;
  TimeNs last_start_ = 0, last_end_ = 0;
  bool updated_ = false;  ///< this window's update ran (find() of a later pass reuses it)
};

}  // namespace fdv
