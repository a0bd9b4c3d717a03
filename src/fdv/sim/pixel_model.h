#pragma once
/// The DVS pixel: threshold crossings of log intensity between two samples.
///
///   PixelMemory m{.reference = L0};
///   emit_crossings(m, t0, L0, t1, L1, {.on = 0.25f, .off = 0.25f}, refractory_ns,
///                  [&](double t_ns, bool on) { ... });
///
/// Between two samples the log intensity is taken as linear in time, and every crossing of
/// reference ± C is an event at the interpolated time (several per interval when the change is
/// large). After an event the pixel is held in reset for the refractory period: its reference
/// follows the input and is latched at the end of the period (so a steady ramp gives one event
/// per refractory period + C / |dL/dt|, as a real pixel does); with refractory 0 the reference
/// simply steps by ±C. Allocation-free; pure function of its arguments and the memory.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <cmath>
#include <cstdint>
#include <limits>

#include "fdv/core/time.h"

namespace fdv::sim {

struct PixelThresholds {
  float on = 0.25f;   ///< log-intensity increase for an ON event
  float off = 0.25f;  ///< log-intensity decrease for an OFF event
};

struct PixelMemory {
  static constexpr TimeNs kNoLatch = std::numeric_limits<TimeNs>::min();
  float reference = 0;         ///< log intensity at the last reset
  TimeNs latch_at = kNoLatch;  ///< end of the running refractory period, or kNoLatch
};

/// Emits the events of the linear ramp (t0, L0) -> (t1, L1), t0 < t1, in time order, through
/// emit(double t_ns, bool on). Updates the memory.
template <class Emit>
inline void emit_crossings(PixelMemory& m, TimeNs t0, float L0, TimeNs t1, float L1,
                           PixelThresholds c, TimeNs refractory_ns, Emit&& emit) {
  // Fast path (most pixels, most samples): no reset running and no threshold reached.
  if (m.latch_at == PixelMemory::kNoLatch && L1 - m.reference < c.on && m.reference - L1 < c.off)
    return;
  const double span = static_cast<double>(t1 - t0);
  const double slope = (static_cast<double>(L1) - L0) / span;  // per ns
  auto level_at = [&](TimeNs t) {
    return static_cast<float>(L0 + slope * static_cast<double>(t - t0));
  };
  double start = static_cast<double>(t0);
  if (m.latch_at != PixelMemory::kNoLatch) {
    if (m.latch_at > t1) return;  // still in reset for this whole interval
    const TimeNs t_latch = m.latch_at < t0 ? t0 : m.latch_at;
    m.reference = level_at(t_latch);
    m.latch_at = PixelMemory::kNoLatch;
    start = static_cast<double>(t_latch);
  }
  for (;;) {
    float level;
    bool on;
    if (L1 - m.reference >= c.on) {
      level = m.reference + c.on, on = true;
    } else if (m.reference - L1 >= c.off) {
      level = m.reference - c.off, on = false;
    } else {
      return;
    }
    // Crossing time on the ramp (slope != 0 here: |L1 - reference| >= C while the reference
    // was within C of the ramp at `start`).
    double t = static_cast<double>(t0) + (static_cast<double>(level) - L0) / slope;
    if (t < start) t = start;
    if (t > static_cast<double>(t1)) t = static_cast<double>(t1);
    emit(t, on);
    if (refractory_ns <= 0) {
      m.reference = level;
      start = t;
      continue;
    }
    const TimeNs release = std::llround(t) + refractory_ns;
    if (release > t1) {
      m.reference = level;
      m.latch_at = release;
      return;
    }
    m.reference = level_at(release);
    start = static_cast<double>(release);
  }
}

}  // namespace fdv::sim
