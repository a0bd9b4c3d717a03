#pragma once
/// Parameters of the detector (paper §IV-B). Defaults marked "provisional" are not from the
/// paper (it gives no values) and are to be tuned on simulated scenes (docs/DETECTION.md).
#include <string>

namespace fdv {

struct DetectorOptions {
  // Adaptive threshold θ(ω, v) = mean(N) + a‖ω‖ + b‖v‖ + c (§IV-B.1). b, c and the evidence
  // gates below were tuned on simulated seeds 1-4 (docs/DETECTION.md, "Tuning"); a was not varied.
  double threshold_a_s_per_rad = 0.01;  ///< a [1/(rad/s)]: more residual motion blur when rotating fast
  double threshold_b_s_per_m = 0.04;    ///< b [1/(m/s)]: the same for translation
  double threshold_c = 0.1;             ///< c [-]: keeps the upper part of the N distribution
  /// A pixel joins S only with at least this many compensated events (1 = the paper's S). The mean
  /// time of k events spread over the window (compensated background) exceeds θ by chance with
  /// probability ≈ 0.2 for k = 1 at θ = 0.8, ≈ 0.08 for k = 2 and ≈ 0.02 for k = 3, while a moving
  /// object's leading edge fires several events per pixel within a short time.
  int min_pixel_events = 2;
  // Pre-processing (§IV-B.2): mean filter, morphological opening, element-wise square.
  int mean_filter_px = 3;  ///< box filter size [px] (odd), provisional
  int opening_px = 3;      ///< square structuring element of the opening [px] (odd), provisional
  /// Evidence: the strongest pattern must reach this value in the filtered S (before squaring),
  /// i.e. P_max ≥ min_peak². Salt-and-pepper noise cannot (an isolated pixel gives ≤ 1/9 after the
  /// 3x3 mean filter); a moving object's recent sweep is a solid patch with high N (≈ 0.5-0.8).
  /// Provisional: separates noise clusters (≤ 0.21) from moving blobs (≥ 0.25) in tests/detection.
  double min_peak = 0.35;
  /// A candidate box must hold at least this many compensated events per pixel: a moving object
  /// fires events all over its image, sparse late pixels of background texture do not.
  double min_event_density = 1.5;
  /// Patterns tried per window: when the strongest one yields no plausible box or fails the
  /// evidence gates, it is blanked and the next strongest one is fitted.
  int max_candidates = 3;
  /// Track-aided detection (DetectionPrior): inside prior_gate_scale × a confirmed track's predicted
  /// box (half-sides at least prior_min_gate_px), a pattern needs only prior_min_peak. 1 disables it.
  double prior_min_peak = 0.25;
  double prior_gate_scale = 2.0;     ///< as the depth ROI (issue: the track's box × 2)
  double prior_min_gate_px = 10.0;   ///< [px]

  /// Dense-motion cue (not in the paper; docs/DETECTION.md, "Dense moving blob"): when no pattern
  /// of N passes, the densest patch of the count image I (box sums of motion_cue_density_px²) is
  /// tested for motion by a count-weighted plane fit T ≈ a + g·(x − x_c) of the mean-time image over
  /// the (2r+1)² square around it. A moving object fires late on its leading side and early on its
  /// trailing side, so T rises along its image velocity; compensated background has no such trend.
  /// It finds what N misses: a far, spinning, textured object whose events are spread over the
  /// whole window (its mean time is mid-window, below θ). Tuned on training seeds 1-4.
  bool motion_cue = true;
  int motion_cue_density_px = 5;     ///< side of the box whose event count is the density [px] (odd)
  int motion_cue_radius_px = 10;     ///< r: half-side of the square of the plane fit [px]
  /// Active pixels (I ≥ min_pixel_events: the density and the plane use only these) the square
  /// must hold: a plane through a few pixels (a hot pixel and its neighbours) explains anything.
  int motion_cue_min_pixels = 20;
  double motion_cue_min_r2 = 0.2;    ///< the plane must explain this fraction of T's variance
  /// The plane's rise across the square, |g|·(2r+1), as a fraction of the window: a static blob
  /// with a chance trend rises little.
  double motion_cue_min_span = 0.1;

  /// Count-contrast cue (not in the paper; docs/DETECTION.md, "Count-contrast cue"): when no
  /// candidate of N (nor of the track-aided look or the dense-motion cue) passes, the count image I
  /// is searched for a compact blob much denser than its surroundings. A slow object that fires
  /// evenly over the window (a far head-on ball) is not late in N when the background's events
  /// came late (a jerk of the hovering camera), but it is the densest compact blob of I.
  /// Centre: the count_cue_box_px² box (k); its contrast = its mean I / max(mean I of the surround,
  /// the image's mean I); the surround is the (count_cue_surround_scale·k)² box around it minus
  /// the centre box, and must lie in the image. Over the image the blob's mean event time must also
  /// stand out from all events' by θ's margin a‖ω‖ + b‖v‖ + c (in N's units), early or late: the
  /// background's events follow the camera's motion over the window, an independently moving
  /// object's do not. Thresholds measured on training seeds 1-4 (on: hover_headon 83 → 88 of 92
  /// eligible windows, false detections unchanged).
  bool count_cue = true;
  int count_cue_box_px = 9;               ///< k [px] (odd): about the smallest eligible ball (8 px across)
  double count_cue_surround_scale = 3.0;  ///< the surround box's side / k (> 1)
  double count_cue_min_contrast = 3.0;    ///< accepted at this contrast or more (ball 3.9-6.3 measured)
  /// Fraction of the centre box's pixels with I ≥ min_pixel_events: a filled, compact blob; a thin
  /// edge or a hot pixel cannot fill it (ball 0.80-0.96 measured; texture mostly 0.6-0.8).
  double count_cue_min_fill = 0.8;
  /// First inside confirmed tracks' gates (DetectionPrior, as the dense-motion cue), without the
  /// time test: there the track is the evidence that the blob moves.
  bool count_cue_in_gates = true;

  // Iterative Gaussian fitting (Algorithm 1).
  int fit_max_iterations = 30;        ///< K, provisional (a blob converges in ~10 from the half-image ROI)
  double fit_delta_center_px = 0.25; ///< δ_C: centre change below which the fit has converged [px]
  /// δ_L: change of each side below which it has converged [px]. L ← 4σ contracts by ≈ 0.7 per
  /// iteration near its fixed point, so the stopped L is within ≈ 2.5·δ_L of it.
  double fit_delta_size_px = 0.5;
  double fit_min_size_px = 3.0;      ///< sides are floored here so a tiny blob cannot collapse the ROI
  /// Smaller initial ROIs (docs/DETECTION.md): when the candidate from the half-image initial ROI
  /// fails the plausibility or evidence gates, Algorithm 1 runs again from the same seed with the
  /// initial ROI halved, while its shorter side is at least this [px]. 0 = off (the paper: one fit).
  /// Tuned on training seeds 1-4 (8 and 32 were worse).
  double refit_min_roi_px = 16.0;
  /// Such a smaller-ROI box must stand out locally: mean S over its segmented pixels ≥ mean N of
  /// the event pixels within this many × its longer side of its centre + (θ − mean(N)). 0 = no test.
  double refit_local_scale = 3.0;
  // Plausibility of the converged ROI (else moving-region retrieval, §IV-B.3).
  double roi_max_fraction = 0.35;  ///< a side longer than this fraction of the image side is implausible
  double roi_max_aspect = 4.0;     ///< long side / short side above this is implausible (a streak or two objects)
  int roi_min_events = 8;          ///< fewer compensated events inside is implausible (and no detection)
  // Moving-region retrieval.
  int region_min_area_px = 4;  ///< connected components smaller than this are ignored [px]
  /// Re-estimate the centre and time from the events themselves (docs/DETECTION.md, "centre and
  /// time"): events inside the box enlarged by this factor and within ±τ of the box's mean event
  /// time (τ as large as the window allows) give the centroid and mean time of a time-complete
  /// slice of the object, which removes the forward bias of the segmented region's centroid. 0 = off.
  double refine_box_scale = 2.0;
  /// Mean-shift passes of that region (re-centred on the events' centroid, same size) after the
  /// first, while the centroid moves by ≥ 0.25 px: residual background events in a region centred
  /// ahead of the object pull the centroid forwards; 0 = the region stays on the box.
  int refine_recentre_passes = 6;
  /// Report the box as a square of its longer side on the (refined) centre: the segmented sweep
  /// is often a thin crescent across the motion, whose longer side is the object's extent across
  /// the motion; a round object is as long along it (docs/DETECTION.md, "The box").
  bool square_box = true;
  // Whole-window guards.
  int min_window_events = 30;  ///< fewer compensated events: no detection ("too few events")
  /// More than this fraction of the image above θ means the compensation failed or a burst
  /// flooded the window: no detection ("segmentation flooded"), rather than a random one.
  double max_segmented_fraction = 0.25;

  std::string validate() const;
};

}  // namespace fdv
