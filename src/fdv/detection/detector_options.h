#pragma once
/// Parameters of the detector (paper §IV-B): the fields every candidate source shares, then one
/// sub-struct per source (detector.h lists the sources and their order). Defaults marked
/// "provisional" are not from the paper (it gives no values); the others were tuned on training
/// seeds 1-4 (docs/DETECTION.md, "Tuning").
///
///   DetectorOptions o;
///   o.dense_motion.enabled = false;   // YAML: detector.dense_motion
///   if (const std::string why = o.validate(); !why.empty()) fail(why);
///
/// The `detector:` YAML keys are flat: each source's field list (describe() below) gives its
/// fields their YAML names (e.g. `dense_motion_radius_px` fills dense_motion.radius_px), and
/// describe(v, DetectorOptions&) lists the sources' keys beside the shared ones, so files written
/// before the split still load. validate()'s messages name those keys.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <string>

#include "fdv/detection/hot_pixels.h"

namespace fdv {

/// Source 1: Algorithm 1 from the strongest patterns of P, with moving-region retrieval when a fit
/// fails (§IV-B.2-3). Its plausibility and refit options also apply to the track-aided source,
/// which evaluates patterns the same way (gaussian_fit_source.h, PatternFit).
struct GaussianFitSourceOptions {
  /// Evidence [-]: the strongest pattern must reach this in the filtered S (before squaring), i.e.
  /// P_max ≥ min_peak²: an isolated noise pixel gives ≤ 1/9 after the 3x3 mean filter, a moving
  /// object's recent sweep a solid patch of N ≈ 0.5-0.8. YAML `min_peak`; tuned.
  double min_peak = 0.35;
  /// The same for the window's further objects, once one is found [-]: the texture patterns the
  /// first object outshone would otherwise come through (docs/DETECTION.md, "Several objects").
  /// YAML `further_min_peak`; tuned.
  double further_min_peak = 0.6;
  /// Patterns tried per window: a pattern with no plausible box, or failing the evidence gates, is
  /// blanked and the next strongest one is fitted. YAML `max_candidates`; provisional.
  int max_candidates = 3;
  /// A fitted side longer than this fraction of the image side is implausible [-] (then retrieval,
  /// whose connected regions may be larger, up to DetectorOptions::fills_view_fraction): Algorithm
  /// 1 from the half-image ROI spreads over texture as readily as over a large object.
  /// YAML `roi_max_fraction`; provisional.
  double roi_max_fraction = 0.35;
  /// A retrieved region beyond that size is an object only when it is this many times denser in
  /// events than the rest of the image [-]: a large region of evenly active texture is connected
  /// too, but no denser than its surroundings. YAML `large_region_min_contrast`; provisional.
  double large_region_min_contrast = 2.0;
  /// Smaller initial ROIs [px]: when the half-image fit's box fails the gates, Algorithm 1 reruns
  /// from the same seed with L⁰ halved while its shorter side is ≥ this; 0 = off (the paper: one
  /// fit). A small object merged with clutter converges alone from a smaller window
  /// (docs/DETECTION.md, "Smaller initial ROIs"). YAML `refit_min_roi_px`; tuned.
  double refit_min_roi_px = 16.0;
  /// Such a smaller-ROI box must stand out locally [-]: mean S over its segmented pixels ≥ mean N
  /// of the event pixels within this many × its longer side of its centre + (θ − mean(N)), which
  /// rejects texture of a region the compensation left late as a whole. 0 = no test.
  /// YAML `refit_local_scale`; tuned.
  double refit_local_scale = 3.0;
  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): flat keys of the `detector` section.
template <class V>
void describe(V& v, GaussianFitSourceOptions& o) {
  v("min_peak", o.min_peak, "-", "source 1: evidence, the strongest pattern's value in the filtered S; tuned");
  v("further_min_peak", o.further_min_peak, "-", "source 1: the same for a window's further objects; tuned");
  v("max_candidates", o.max_candidates, "-", "source 1: patterns tried per window; provisional");
  v("roi_max_fraction", o.roi_max_fraction, "-", "a fitted side longer than this fraction of the image side is implausible (then retrieval)");
  v("large_region_min_contrast", o.large_region_min_contrast, "-", "a region beyond that size must be this many times denser in events than the rest");
  v("refit_min_roi_px", o.refit_min_roi_px, "px", "smaller initial ROIs: halve L⁰ while its shorter side ≥ this (0 = off, the paper); tuned");
  v("refit_local_scale", o.refit_local_scale, "-", "a smaller-ROI box must stand out within this × its side (0 = no test); tuned");
}

/// Source 2: inside each confirmed track's gate (DetectionPrior), the strongest pattern of P,
/// evaluated as source 1's but at a lower evidence threshold; its box must stay centred in the gate.
struct TrackAidedSourceOptions {
  /// The evidence threshold inside a gate [-], on the same scale as GaussianFitSourceOptions::min_peak:
  /// the track is evidence of its own. 1 = off. YAML `prior_min_peak`; tuned.
  double min_peak = 0.25;
  std::string validate() const;
};

template <class V>
void describe(V& v, TrackAidedSourceOptions& o) {
  v("prior_min_peak", o.min_peak, "-", "source 2: evidence threshold inside a confirmed track's gate (1 = off); tuned");
}

/// Source 3, not in the paper (docs/DETECTION.md, "Dense-motion source"): inside the tracks' gates,
/// the densest patch of active pixels of I, accepted when its mean-time image T rises across it as
/// a plane T ≈ a + g·(x − x_c) (count-weighted least squares over the (2r+1)² square around it). A
/// moving object fires late on its leading side, so T rises along its image velocity; compensated
/// background has no such trend. It finds what N misses: a far, spinning, textured object whose
/// events spread over the whole window (mean time mid-window, below θ).
struct DenseMotionSourceOptions {
  bool enabled = true;  ///< false = the paper. YAML `dense_motion`
  /// Side of the box whose active-pixel count is the density [px] (odd). YAML `dense_motion_density_px`
  int density_px = 5;
  int radius_px = 10;  ///< r: half-side of the plane fit's square [px]. YAML `dense_motion_radius_px`
  /// Active pixels (I ≥ min_pixel_events) the square must hold [px]: a plane through a few pixels
  /// (a hot pixel and its neighbours) explains anything. YAML `dense_motion_min_pixels`
  int min_pixels = 20;
  /// Fraction of T's variance the plane must explain [-]; from the training seeds' measurement
  /// (docs/DETECTION.md). YAML `dense_motion_min_r2`
  double min_r2 = 0.2;
  /// The plane's rise across the square, |g|·(2r+1), as a fraction of the window [-]: a static blob
  /// with a chance trend rises little. YAML `dense_motion_min_span`
  double min_span = 0.1;
  std::string validate() const;
};

template <class V>
void describe(V& v, DenseMotionSourceOptions& o) {
  v("dense_motion", o.enabled, "-", "source 3, dense moving blob inside track gates (false = the paper)");
  v("dense_motion_density_px", o.density_px, "px", "side of the box whose active pixels are the density (odd)");
  v("dense_motion_radius_px", o.radius_px, "px", "r: half-side of the plane fit's square");
  v("dense_motion_min_pixels", o.min_pixels, "px", "active pixels the square must hold");
  v("dense_motion_min_r2", o.min_r2, "-", "fraction of T's variance the plane must explain");
  v("dense_motion_min_span", o.min_span, "-", "the plane's rise across the square / Δt");
  // The keys' names before they took the source's name.
  v.removed("motion_cue", "renamed dense_motion");
  v.removed("motion_cue_density_px", "renamed dense_motion_density_px");
  v.removed("motion_cue_radius_px", "renamed dense_motion_radius_px");
  v.removed("motion_cue_min_pixels", "renamed dense_motion_min_pixels");
  v.removed("motion_cue_min_r2", "renamed dense_motion_min_r2");
  v.removed("motion_cue_min_span", "renamed dense_motion_min_span");
}

/// Source 4, not in the paper (docs/DETECTION.md, "Count-contrast source"): a compact blob of the count
/// image I much denser than its surroundings. A slow object that fires evenly over the window (a
/// far head-on ball) is not late in N when the background's events came late (a jerk of the
/// hovering camera), but it is the densest compact blob of I. Centre: the box_px² box (k); contrast
/// = its mean I / max(mean I of the surround, the image's mean I); the surround is the
/// (surround_scale·k)² box minus the centre box and must lie in the image. Over the whole image the
/// blob's mean event time must also stand out from all events' by θ's margin a‖ω‖ + b‖v‖ + c (in
/// N's units), early or late: the background's events follow the camera's motion over the window,
/// an independently moving object's do not.
struct CountContrastSourceOptions {
  bool enabled = true;  ///< false = the paper. YAML `count_contrast`
  /// k [px] (odd): about the smallest eligible ball (8 px across), at DetectorOptions::gate_focal_px.
  /// YAML `count_contrast_box_px`
  int box_px = 9;
  double surround_scale = 3.0;  ///< the surround box's side / k [-] (> 1). YAML `count_contrast_surround_scale`
  /// Accepted at this contrast or more [-] (the ball measured 3.9-6.3). YAML `count_contrast_min_contrast`
  double min_contrast = 3.0;
  /// Fraction of the centre box's pixels with I ≥ min_pixel_events [-]: a filled, compact blob; a
  /// thin edge or a hot pixel cannot fill it (ball 0.80-0.96, texture mostly 0.6-0.8 measured).
  /// YAML `count_contrast_min_fill`
  double min_fill = 0.8;
  /// Search confirmed tracks' gates first, without the time test: there the track is the evidence
  /// that the blob moves. YAML `count_contrast_in_gates`
  bool in_gates = true;
  /// The still-camera test, which a blob may pass instead of the time test (docs/DETECTION.md,
  /// "Count-contrast source"): it applies while θ's motion term a‖ω‖ + b‖v‖ is at most this [-]
  /// (hovering ≈ 0.002-0.02, fast flight ≈ 0.2-0.3); 0 = off. YAML `count_contrast_still_motion`
  double still_motion = 0.05;
  /// ... the blob's events per pixel over those of its own-scale surround (its box grown by its own
  /// sides on every side), or the image's mean if larger, at least this [-]: a part of a larger
  /// moving body (a person) does not stand out from the rest of it. YAML `count_contrast_still_isolation`
  double still_min_isolation = 8.0;
  /// ... and its events' pixel must move with their time: the Wald statistic of the two slopes
  /// (x and y regressed on t) at least this [-]; a flickering light does not move.
  /// YAML `count_contrast_still_motion_z`
  double still_min_motion_z = 2.0;
  /// The sparse search (docs/DETECTION.md, "Count-contrast source"): with the camera nearly still and
  /// nothing found, a centre box is filled when so many of its pixels fired at all that, were the
  /// image's fired pixels scattered at random, this many boxes of the image would be expected to
  /// reach it per window [-]; 0 = off. YAML `count_contrast_sparse_chance`
  double sparse_chance = 1e-3;
  std::string validate() const;
};

template <class V>
void describe(V& v, CountContrastSourceOptions& o) {
  v("count_contrast", o.enabled, "-", "source 4, count-contrast blob (false = the paper)");
  v("count_contrast_box_px", o.box_px, "px", "k: side of the centre box (odd), at gate_focal_px; about the smallest eligible ball");
  v("count_contrast_surround_scale", o.surround_scale, "-", "the surround box's side / k (> 1)");
  v("count_contrast_min_contrast", o.min_contrast, "-", "centre density / max(surround density, image mean)");
  v("count_contrast_min_fill", o.min_fill, "-", "fraction of the centre box's pixels with I ≥ min_pixel_events");
  v("count_contrast_in_gates", o.in_gates, "-", "search confirmed tracks' gates first, without the time test");
  v("count_contrast_still_motion", o.still_motion, "-", "the still-camera test replaces the time test while a‖ω‖ + b‖v‖ ≤ this (0 = off); tuned");
  v("count_contrast_still_isolation", o.still_min_isolation, "-", "... the blob's density / its own-scale surround's (or the image mean's) ≥ this; tuned");
  v("count_contrast_still_motion_z", o.still_min_motion_z, "-", "... and the Wald z of its events' position-on-time slopes ≥ this; tuned");
  v("count_contrast_sparse_chance", o.sparse_chance, "-", "still camera, nothing found: boxes of scattered events expected per window to fill a sparse centre box (0 = off); tuned");
  // The keys' names before they took the source's name.
  v.removed("count_cue", "renamed count_contrast");
  v.removed("count_cue_box_px", "renamed count_contrast_box_px");
  v.removed("count_cue_surround_scale", "renamed count_contrast_surround_scale");
  v.removed("count_cue_min_contrast", "renamed count_contrast_min_contrast");
  v.removed("count_cue_min_fill", "renamed count_contrast_min_fill");
  v.removed("count_cue_in_gates", "renamed count_contrast_in_gates");
  v.removed("count_cue_still_motion", "renamed count_contrast_still_motion");
  v.removed("count_cue_still_isolation", "renamed count_contrast_still_isolation");
  v.removed("count_cue_still_motion_z", "renamed count_contrast_still_motion_z");
  v.removed("count_cue_sparse_chance", "renamed count_contrast_sparse_chance");
}

/// Candidate source 5, evidence over windows (evidence_source.h; docs/DETECTION.md, "Evidence
/// source"): per C × C cell, the log-likelihood ratio ℓ = δz − δ²/2 of its fired pixels' z against
/// the cell's own history, summed along paths over windows (L = max(0, ℓ + the best neighbour's L
/// a window ago)); a cell at L ≥ h is a candidate (evidence_source.h states the model).
struct EvidenceSourceOptions {
  /// On by default since its image isolation test (min_isolation) keeps the texture of a moving
  /// background out (docs/DETECTION.md, "Evidence source"). YAML `evidence`
  bool enabled = true;
  /// C [px] at DetectorOptions::gate_focal_px (a longer focal length scales it up): a far ball
  /// (4-10 px) lies in one or two cells and moves about a cell a window. YAML `evidence_cell_px`
  int cell_px = 8;
  /// δ: the object's excess of fired pixels in σ of the cell's own variation [-]. The best of 9
  /// predecessors lifts a path by about σ_ℓ·√(2 ln 9) = 2.1δ a window, so δ²/2 must exceed it:
  /// δ > 4.2 (δ = 2-5 left paths through texture growing on training seeds 10, 11, 16).
  /// YAML `evidence_signal_sigma`
  double signal_sigma = 6.0;
  /// h: the path's sum of ℓ at which a cell is a candidate [-]. YAML `evidence_threshold`
  double threshold = 12.0;
  /// ℓ_max: the most one window adds [-]; h / ℓ_max windows at least make a candidate, so a single
  /// window's clump (texture, vibration, a burst) never does. YAML `evidence_max_window_llr`
  double max_window_llr = 4.0;
  /// α: the weight of a window in each cell's running mean and variance [-]. YAML `evidence_background_weight`
  double background_weight = 0.05;
  /// b_min: added to every cell's variance [fired pixels² per window]: in an empty cell one event
  /// must not be evidence. YAML `evidence_min_background`
  double min_background = 1.0;
  /// The least travel over the scene of a path that makes a candidate [cells]: T ← 0.8·T + the
  /// path's step over the scene each window (after the ego-motion), so two steps of a cell make
  /// 1.8; a head-on ball hardly moves on the image, and the static scene's paths, which hop about
  /// their place, are kept out by the surround and isolation tests (docs/DETECTION.md, "Evidence
  /// source"). YAML `evidence_min_travel_cells`
  double min_travel_cells = 1.0;
  /// Windows in which each cell's mean and variance are learned before any evidence counts (0.2 s
  /// at 25 ms; the surround test keeps the real recordings' people out with 8). YAML
  /// `evidence_warmup_windows`
  int warmup_windows = 8;
  /// κ: a candidate's surround (the ring of cells 2-3 away) may hold at most κ times the excess
  /// of its own 3 × 3 cells [-], the excess being the fired pixels beyond μ + σ. A far ball is a
  /// blob on its own; the moving edge of a person or of a swinging object runs on through the
  /// ring (a line through 7 × 7 cells puts 4/3 of its centre's pixels there). 0.3 kept both real
  /// recordings with a moving person clean with 8 warm-up windows (docs/DETECTION.md).
  /// YAML `evidence_max_surround_ratio`
  double max_surround_ratio = 0.3;
  /// A candidate's events per pixel over its surround's in this window's count image (`isolation`
  /// in candidate_source.h: the C-sided box around the events' centroid against the box grown by
  /// its own sides, floored at the image's mean) at least this [-]; 0 = off. A far ball stands
  /// out of its surround; the texture that forward flight's parallax or a swinging camera leaves
  /// uncompensated runs on into it (docs/DETECTION.md, "Evidence source"). YAML
  /// `evidence_min_isolation`; tuned.
  double min_isolation = 3.0;
  std::string validate() const;
};

template <class V>
void describe(V& v, EvidenceSourceOptions& o) {
  v("evidence", o.enabled, "-", "source 5, evidence over windows along paths: track-before-detect (false = the paper)");
  v("evidence_cell_px", o.cell_px, "px", "C: side of a cell of the evidence grid, at gate_focal_px (a longer fx scales it up)");
  v("evidence_signal_sigma", o.signal_sigma, "-", "δ: an object's excess of fired pixels, in σ of the cell's own variation");
  v("evidence_threshold", o.threshold, "-", "h: a path's sum of log-likelihood ratios that makes a candidate; tuned");
  v("evidence_max_window_llr", o.max_window_llr, "-", "ℓ_max: the most one window adds (h / ℓ_max windows at least)");
  v("evidence_background_weight", o.background_weight, "-", "α: a window's weight in each cell's running mean and variance");
  v("evidence_min_background", o.min_background, "px²", "b_min: added to every cell's variance of fired pixels per window");
  v("evidence_min_travel_cells", o.min_travel_cells, "cells", "a candidate path's recent travel over the scene at least (T ← 0.8 T + step)");
  v("evidence_warmup_windows", o.warmup_windows, "-", "windows that learn the background before evidence counts");
  v("evidence_max_surround_ratio", o.max_surround_ratio, "-", "κ: a candidate's excess (beyond μ + σ) in the ring 2-3 cells away, at most this times its 3x3 cells'");
  v("evidence_min_isolation", o.min_isolation, "-", "a candidate's events per pixel over its surround's (the box grown by its sides) in the window's count image, at least this (0 = off); tuned");
}

struct DetectorOptions {
  // Adaptive threshold θ(ω, v) = mean(N) + a‖ω‖ + b‖v‖ + c (§IV-B.1).
  double threshold_a_s_per_rad = 0.01;  ///< a [1/(rad/s)]: more residual motion blur when rotating fast
  double threshold_b_s_per_m = 0.04;    ///< b [1/(m/s)]: the same for translation
  double threshold_c = 0.1;             ///< c [-]: keeps the upper part of the N distribution
  /// A pixel joins S only with at least this many compensated events (1 = the paper's S). The mean
  /// time of k events spread over the window (compensated background) exceeds θ by chance with
  /// probability ≈ 0.2 for k = 1 at θ = 0.8, ≈ 0.08 for k = 2 and ≈ 0.02 for k = 3, while a moving
  /// object's leading edge fires several events per pixel within a short time. Also the "active
  /// pixel" level of the dense-motion and count-contrast sources.
  int min_pixel_events = 2;
  // Pre-processing (§IV-B.2): mean filter, morphological opening, element-wise square.
  int mean_filter_px = 3;  ///< box filter size [px] (odd), provisional
  int opening_px = 3;      ///< square structuring element of the opening [px] (odd), provisional

  // Iterative Gaussian fitting (Algorithm 1): source 1's fit and source 4's box.
  int fit_max_iterations = 30;        ///< K, provisional (a blob converges in ~10 from the half-image ROI)
  double fit_delta_center_px = 0.25; ///< δ_C: centre change below which the fit has converged [px]
  /// δ_L: change of each side below which it has converged [px]. L ← 4σ contracts by ≈ 0.7 per
  /// iteration near its fixed point, so the stopped L is within ≈ 2.5·δ_L of it.
  double fit_delta_size_px = 0.5;
  /// Both δ grow with the pattern: at least this fraction of the current side L [-], so that a
  /// large pattern converges in as many iterations as a small one (0 = the fixed δ only).
  double fit_delta_fraction = 0.01;
  /// Sides are floored here so a tiny blob cannot collapse the ROI [px] (also source 3's box).
  double fit_min_size_px = 3.0;
  int region_min_area_px = 4;  ///< moving-region retrieval ignores smaller components [px]

  // Gates of every source's box.
  double roi_max_aspect = 4.0;  ///< long side / short side above this is implausible (a streak or two objects)
  int roi_min_events = 8;       ///< fewer compensated events inside is implausible (and no detection)
  /// A candidate box must hold at least this many compensated events per pixel: a moving object
  /// fires events all over its image, sparse late pixels of background texture do not.
  double min_event_density = 1.5;
  /// The focal length [px] at which min_event_density and count_contrast_box_px are stated (the 640x480
  /// simulated camera they were tuned on). A camera with a shorter fx has both scaled by fx / this:
  /// the same object's image, and the events per pixel it fires, shrink with the focal length in
  /// pixels (docs/DETECTION.md, "Any apparent size"). 0 = the values as given, at any resolution.
  double gate_focal_px = 536.3;

  /// Tracks' gates (DetectionPrior), searched by sources 2-4: prior_gate_scale × a confirmed
  /// track's predicted box, half-sides at least prior_min_gate_px.
  double prior_gate_scale = 2.0;     ///< as the depth ROI (issue: the track's box × 2)
  double prior_min_gate_px = 10.0;   ///< [px]

  // The winner's centre, time and box.
  /// Re-estimate the centre and time from the events themselves (docs/DETECTION.md, "centre and
  /// time"): events inside the box enlarged by this factor and within ±τ of the box's mean event
  /// time (τ as large as the window allows) give the centroid and mean time of a time-complete
  /// slice of the object, which removes the forward bias of the segmented region's centroid. 0 = off.
  double refine_box_scale = 2.0;
  /// Mean-shift passes of that region (re-centred on the events' centroid, same size) after the
  /// first, while the centroid moves by ≥ 0.25 px: residual background events in a region centred
  /// ahead of the object pull the centroid forwards; 0 = the region stays on the box.
  int refine_recenter_passes = 6;
  /// The square grows (× 1.5) while a side of the band just outside it holds at least this × its
  /// own event density: the box was a fragment of a larger object, whose events go on past the
  /// square. The box then becomes a square of the extent the last two squares bracket
  /// (docs/DETECTION.md, "A box on a fragment grows"). 0 = the square keeps its size.
  double refine_grow_density = 0.4;
  /// ... and at least this × the slice's mean density over the image, so that it grows over an
  /// object, not over textured background. 0 = that test is off.
  double refine_grow_contrast = 8.0;
  /// A grown square holds a large object's whole outline: its centre is then the centre of an
  /// ellipse fitted to the outline's pixels, not the events' centroid, which the edges that sweep
  /// the most pixels pull their way (docs/DETECTION.md, "A grown square's centre is its outline's").
  bool refine_fit_outline = true;
  /// Report the box as a square of its longer side on the (refined) centre: the segmented sweep
  /// is often a thin crescent across the motion, whose longer side is the object's extent across
  /// the motion; a round object is as long along it (docs/DETECTION.md, "The box").
  bool square_box = true;

  // Several objects and large ones (docs/DETECTION.md, "Several objects", "Any apparent size").
  /// Most objects reported per window: after each, its region is blanked and the search goes on.
  int max_objects = 4;
  /// A region or reported box with a side longer than this fraction of the image's shorter side is
  /// no detection: a connected region that large which passes the evidence gates, or a reported
  /// box, gives the window the status "object fills the view" (docs/DETECTION.md, "Any apparent
  /// size").
  double fills_view_fraction = 0.5;

  // Whole-window guards.
  int min_window_events = 30;  ///< fewer compensated events: no detection ("too few events")
  /// More than this fraction of the image above θ means the compensation failed or a burst
  /// flooded the window: no detection ("segmentation flooded"), rather than a random one.
  double max_segmented_fraction = 0.25;
  /// Sensor pixels learned hot (steady firing, no spatial support), whose events Perception drops
  /// before compensation: kept out of every source (hot_pixels.h; docs/DETECTION.md, "Hot pixels").
  HotPixelOptions hot_pixels;

  // The candidate sources, tried in this order.
  GaussianFitSourceOptions gaussian_fit;
  TrackAidedSourceOptions track_aided;
  DenseMotionSourceOptions dense_motion;
  CountContrastSourceOptions count_contrast;
  EvidenceSourceOptions evidence;

  /// The shared fields' rules, then each source's; "" when valid.
  std::string validate() const;
};

/// The shared keys, then each source's (flat: see above).
template <class V>
void describe(V& v, DetectorOptions& o) {
  v("threshold_a_s_per_rad", o.threshold_a_s_per_rad, "1/(rad/s)", "a in θ = mean(N) + a‖ω‖ + b‖v‖ + c (§IV-B.1), ≥ 0; tuned");
  v("threshold_b_s_per_m", o.threshold_b_s_per_m, "1/(m/s)", "b in θ, ≥ 0; tuned");
  v("threshold_c", o.threshold_c, "-", "c in θ, in [-1, 1] (N is in [0, 1]); tuned");
  v("min_pixel_events", o.min_pixel_events, "events", "events per pixel to join S (1 = the paper); tuned");
  v("mean_filter_px", o.mean_filter_px, "px", "mean filter size (odd), paper §IV-B.2; provisional");
  v("opening_px", o.opening_px, "px", "opening's structuring element (odd), paper §IV-B.2; provisional");
  v("fit_max_iterations", o.fit_max_iterations, "-", "K of Algorithm 1; provisional");
  v("fit_delta_center_px", o.fit_delta_center_px, "px", "δ_C: the fit has converged below this centre change");
  v("fit_delta_size_px", o.fit_delta_size_px, "px", "δ_L: ... and below this change of each side");
  v("fit_delta_fraction", o.fit_delta_fraction, "-", "both δ are at least this fraction of the current side L");
  v("fit_min_size_px", o.fit_min_size_px, "px", "floor of L");
  v("region_min_area_px", o.region_min_area_px, "px", "moving-region retrieval ignores smaller components");
  v("roi_max_aspect", o.roi_max_aspect, "-", "a box's long side / short side above this is implausible");
  v("roi_min_events", o.roi_min_events, "events", "fewer compensated events in a box is implausible");
  v("min_event_density", o.min_event_density, "events/px", "evidence gate of a candidate box, at gate_focal_px; tuned");
  v("gate_focal_px", o.gate_focal_px, "px", "focal length of min_event_density and count_contrast_box_px; a shorter fx scales both by fx / this (0 = as given)");
  v("prior_gate_scale", o.prior_gate_scale, "-", "a confirmed track's predicted box × this = its gate");
  v("prior_min_gate_px", o.prior_min_gate_px, "px", "smallest gate half-side");
  v("refine_box_scale", o.refine_box_scale, "-", "centre and time re-estimated from the events in the box × this (0 = off)");
  v("refine_recenter_passes", o.refine_recenter_passes, "-", "mean-shift re-centring passes of that region (0 = stays on the box)");
  v.removed("refine_recentre_passes", "renamed refine_recenter_passes");
  v("refine_grow_density", o.refine_grow_density, "-", "that region grows × 1.5 while a side of the band around it is this × as dense (0 = off)");
  v("refine_grow_contrast", o.refine_grow_contrast, "-", "... and this × as dense as the whole image's events in the slice");
  v("refine_fit_outline", o.refine_fit_outline, "-", "a grown square's centre is that of an ellipse fitted to its pixels with events");
  v("square_box", o.square_box, "-", "report the box as a square of its longer side on the refined centre");
  v("max_objects", o.max_objects, "-", "most objects reported per window (each found one is blanked, the search goes on)");
  v("fills_view_fraction", o.fills_view_fraction, "-", "a longer visible side above this × the image's shorter side: \"object fills the view\"");
  v("min_window_events", o.min_window_events, "events", "fewer compensated events in a window: no detection");
  v("max_segmented_fraction", o.max_segmented_fraction, "-", "more of the image above θ: no detection (flooded)");
  describe(v, o.hot_pixels);
  describe(v, o.gaussian_fit);
  describe(v, o.track_aided);
  describe(v, o.dense_motion);
  describe(v, o.count_contrast);
  describe(v, o.evidence);
}

}  // namespace fdv
