#pragma once
/// Looming: the apparent diameter θ of a tracked object and its time to contact τ = θ / θ̇, from
/// the sizes of its detections, without knowing the object's size (Lee's τ; docs/ESTIMATION.md
/// "Looming").
///
///   LoomingFit fit(LoomingOptions{});     // one per track
///   fit.add(d.t, d.box_raw.width(), d.box_raw.height());   // each whole (uncut) detection
///   if (const auto l = fit.at(t_now)) l->tau_s ...
///
/// Model: a ball of diameter D at distance L looks θ = f D / L wide (small angles), so its inverse
/// size y = 1/θ = L / (f D) is linear in time while the ball closes at a constant speed, exactly
/// so head-on. The fit is the weighted least-squares line y(t) = y₀ + ẏ (t − t_ref) through the
/// newest `fit_detections` sizes, each weighted by its noise σ_y = σ_θ / θ² with
/// σ_θ = size_sigma_px + size_sigma_fraction · θ (the detector's size error). Then
///   θ(t) = 1 / y(t),   τ(t) = θ / θ̇ = −y(t) / ẏ  (> 0: closing, < 0: receding),
/// with σ(θ) and σ(τ) propagated from the fit's covariance (first order). τ is reported only when
/// the size visibly changes, |ẏ| > min_rate_sigmas σ(ẏ): a ball held at a constant distance, or
/// one too far for its growth to show, has no τ.
/// The measured size is the smaller side of the box: a ball moving across the image smears along
/// its motion within a window, not across it.
/// Not thread-safe; one per track.
#include <deque>
#include <optional>
#include <string>

#include "fdv/core/time.h"

namespace fdv {

struct LoomingOptions {
  /// Sizes in the fit: the newest this many whole detections (about 0.2 s at 25 ms windows).
  int fit_detections = 8;
  /// Fewest sizes for a fit (a line through two points has no residual to check it by).
  int min_detections = 3;
  /// The detector's size error σ_θ = size_sigma_px + size_sigma_fraction θ [px]; measured on
  /// training throws (docs/ESTIMATION.md "Looming").
  double size_sigma_px = 1.5;
  double size_sigma_fraction = 0.2;
  /// τ only when the inverse size's rate is this many of its σ away from zero.
  double min_rate_sigmas = 2.0;

  std::string validate() const;
};

/// The field list (fdv/core/field_list.h): YAML section `looming`.
template <class V>
void describe(V& v, LoomingOptions& o) {
  v("fit_detections", o.fit_detections, "-", "sizes in the fit: the newest this many whole detections");
  v("min_detections", o.min_detections, "-", "fewest sizes for a fit");
  v("size_sigma_px", o.size_sigma_px, "px", "detector's size error: this plus size_sigma_fraction times the size");
  v("size_sigma_fraction", o.size_sigma_fraction, "-", "... the part proportional to the size");
  v("min_rate_sigmas", o.min_rate_sigmas, "σ", "τ only when the inverse size's rate is this many σ from zero");
}

/// The fit at one time.
struct Looming {
  TimeNs t = 0;
  double size_px = 0, size_sigma_px = 0;  ///< apparent diameter θ(t) [raw px] and its σ
  /// Time to contact θ / θ̇ [s] (> 0 closing, < 0 receding) and its σ; nothing when the size does
  /// not visibly change (LoomingOptions::min_rate_sigmas).
  std::optional<double> tau_s, tau_sigma_s;
  int detections = 0;  ///< sizes in the fit
};

class LoomingFit {
 public:
  /// Throws ConfigError when the options are invalid.
  explicit LoomingFit(LoomingOptions options = {});
  /// One whole detection's box [raw px] at time t. Sizes that are not finite and positive, or
  /// older than the newest held, are ignored (returns false).
  bool add(TimeNs t, double width_px, double height_px);
  /// The fit evaluated at t; nothing with fewer than min_detections sizes.
  std::optional<Looming> at(TimeNs t) const;
  int detections() const { return static_cast<int>(sizes_.size()); }

 private:
  struct Size {
    TimeNs t;
    double size_px;
  };
  LoomingOptions options_;
  std::deque<Size> sizes_;
};

}  // namespace fdv
