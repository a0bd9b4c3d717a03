#pragma once
/// Hot pixels learned while running: sensor pixels that fire window after window while their
/// neighbours do not. Their events are taken out of the window before anything else sees it
/// (compensation, time images, every candidate source), so that no source can report a "ball" on a
/// few pixels of sensor noise (docs/DETECTION.md, "Hot pixels").
///
///   HotPixelFilter hot(options.hot_pixels, camera.width, camera.height);
///   for (each window k, in order) {
///     const std::size_t dropped = hot.filter(window_events, k);   // erases the hot pixels' events
///     ...
///   }
///
/// Model, per raw pixel p, over the windows k (causal, incremental, memory W·H·5 bytes):
///   f_p ← α·f_p + (1 − α)·[p fired in window k],    α = 1 − 1 / memory_windows,
/// the pixel's firing fraction (an exponentially decayed share of windows in which it fired,
/// decayed lazily: O(events) per window). After window k's events are counted, p is hot when
///   f_p ≥ min_firing  and  mean of f over its 8 neighbours (those in the sensor) ≤ max_neighbour_firing,
/// and its events of window k are dropped. A steady pixel is learned in n windows, the least n with
/// 1 − αⁿ ≥ min_firing (8 with the defaults); one window of noise gives f = 1 − α < min_firing.
/// Raw pixels, not the compensated grid: a hot pixel is the sensor's, and a rotating camera's warp
/// would smear it into a streak that looks like a moving object. Not thread-safe.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/sensor_data.h"

namespace fdv {

struct HotPixelOptions {
  /// YAML `hot_pixels`. Off by default: learning costs 1.2-3 ms per window on the front end's
  /// benchmark scenes (+35-75 %, docs/BENCHMARKS.md), over what detection may spend on it; on a
  /// sensor with hot pixels, switch it on.
  bool enabled = false;
  /// 1 / (1 − α): the firing fraction's memory in windows (> 1). YAML `hot_pixels_memory_windows`
  double memory_windows = 5.0;
  /// f_p at or above this: the pixel fires steadily [-]. YAML `hot_pixels_min_firing`
  double min_firing = 0.8;
  /// ... and its neighbours' mean f at or below this: no spatial support [-]. 0.15 lets a pair of
  /// adjacent hot pixels (1 of 8 neighbours, 0.125) be learned but not a 1 px line of texture that
  /// fires every window (2 of 8, 0.25). YAML `hot_pixels_max_neighbour_firing`
  double max_neighbour_firing = 0.15;
  std::string validate() const;
};

template <class V>
void describe(V& v, HotPixelOptions& o) {
  v("hot_pixels", o.enabled, "-", "learn hot pixels while running and drop their events before compensation");
  v("hot_pixels_memory_windows", o.memory_windows, "windows",
    "1 / (1 − α) of a pixel's firing fraction f ← α·f + (1 − α)·[fired] (> 1)");
  v("hot_pixels_min_firing", o.min_firing, "-", "hot when f ≥ this ...");
  v("hot_pixels_max_neighbour_firing", o.max_neighbour_firing, "-", "... and its 8 neighbours' mean f ≤ this");
}

class HotPixelFilter {
 public:
  /// Throws ConfigError for invalid options or a non-positive size.
  HotPixelFilter(const HotPixelOptions& options, int width, int height);

  /// Learns from window `window_index`'s events (indices increase from call to call; a jump
  /// decays the state as that many windows without events), then erases the events of the pixels
  /// that are hot, keeping the others' order. Returns how many it erased. Events outside the
  /// sensor are kept (the compensation counts them) and not learned from.
  std::size_t filter(std::vector<Event>& events, std::uint64_t window_index);

  bool is_hot(int x, int y) const;
  std::size_t hot_pixels() const { return hot_list_.size(); }
  /// f of pixel (x, y) as of the last window filtered.
  double firing(int x, int y) const;
  /// Windows of steady firing after which an isolated pixel is hot: the least n with 1 − αⁿ ≥ min_firing.
  int windows_to_learn() const;

 private:
  /// 4 bytes, so that a 640x480 sensor's state (1.2 MB) stays in L2: the per-event loop is bound
  /// by its random reads. A state older than kForgetAge windows is zeroed by a sweep every
  /// kForgetAge windows, so the 16-bit age never wraps (αⁿ is 0 long before).
  struct PixelState {
    std::uint16_t firing = 0;  ///< f · 65535 as of window `last`
    std::uint16_t last = 0;    ///< the window f was last updated in, mod 2¹⁶
  };
  static constexpr std::int32_t kForgetAge = 16384;
  float decayed(const PixelState& s) const;
  void forget_old();
  bool evaluate(std::int32_t pixel) const;

  HotPixelOptions options_;
  int width_, height_;
  float alpha_;
  std::vector<float> alpha_pow_;  ///< αⁿ for n < its size; 0 beyond
  std::vector<PixelState> state_;
  std::vector<std::uint8_t> hot_;  ///< the verdict, per pixel
  std::vector<std::int32_t> steady_, hot_list_, next_hot_;  ///< steady_: fired now with f ≥ min_firing
  std::int32_t now_ = -1;  ///< the current window, relative to the first
  std::uint64_t first_window_ = 0;
};

}  // namespace fdv
