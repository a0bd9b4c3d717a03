#pragma once
/// Cuts a time-ordered event stream into windows [t0, t0 + Δt) (paper §III-A, Δt = 25 ms),
/// streaming: push() event runs as they arrive, take each completed window. Windows start every
/// `step_ns` (Δs ≤ Δt, Δt a multiple of Δs): Δs = Δt gives consecutive windows (the paper), a
/// shorter step overlapping ones, each event in Δt / Δs of them, and a result every Δs.
///
///   EventWindower w(options);
///   w.push(events, [&](const EventWindow& win) { process(win); });
///   w.flush([&](const EventWindow& win) { process(win); });   // the last, partial window
///
/// Windows are aligned to multiples of Δs after the first event's time. A gap in the stream
/// yields empty windows (each is still reported, so the output has one row per window), up to
/// `max_empty_windows` in a row: the rest of a longer gap is skipped in one step and counted in
/// the next window (`skipped_before`), so that a corrupt far-future time cannot make billions of
/// windows.
/// Overload policy: a window holding more than `max_events_per_window` events is decimated
/// uniformly in time order (every k-th event kept) and the number dropped is reported in the
/// window, so latency stays bounded under bursts instead of falling behind.
/// The windower keeps the events of the windows still open (Δt of them) and no more: each window's
/// events are cut from that buffer, not gathered again.
/// The callback's window view is valid only during the call (or take the events: EventWindow::storage).
/// Not thread-safe.
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "fdv/core/sensor_data.h"

namespace fdv {

/// The longest window [ns]: a second holds a thrown ball's whole flight, and the compensation's
/// per-window tables grow with the length (a window of 1e8 ms allocated 3.7 GB).
inline constexpr TimeNs kMaxWindowNs = 1000 * kNsPerMs;
/// The most windows an event may lie in (Δt / Δs): every window is computed from scratch, so a
/// step of nanoseconds would process each event millions of times. 25 = a 1 ms step at 25 ms.
inline constexpr int kMaxWindowOverlap = 25;

struct EventWindowerOptions {
  TimeNs window_ns = 25 * kNsPerMs;  ///< Δt, paper §III-A
  TimeNs step_ns = 0;                ///< Δs: a window starts every Δs (0 = Δt: consecutive windows)
  std::size_t max_events_per_window = kDefaultMaxEventsPerWindow;  ///< decimation cap
  /// Gap policy: consecutive empty windows emitted before the rest of a gap is skipped
  /// (400 = 10 s at Δt = 25 ms; a live camera sees noise events far more often than that).
  std::uint64_t max_empty_windows = 400;
  /// Δs as set (Δt when step_ns is 0).
  TimeNs step() const { return step_ns > 0 ? step_ns : window_ns; }
  /// Δt / Δs: the windows each event lies in.
  int overlap() const { return static_cast<int>(window_ns / step()); }
  std::string validate() const;
};

struct EventWindow {
  TimeNs t_start = 0;
  TimeNs t_end = 0;  ///< exclusive
  std::span<const Event> events;
  std::uint64_t decimated = 0;  ///< events dropped by the overload policy
  std::uint64_t index = 0;           ///< (t_start − first window's t_start) / Δs
  std::uint64_t skipped_before = 0;  ///< empty windows skipped just before this one (gap policy)
  /// The windower's vector that holds `events`. A consumer that keeps the events may swap it with
  /// an empty vector of its own (whose capacity the windower then reuses) instead of copying them.
  std::vector<Event>* storage = nullptr;
};

class EventWindower {
 public:
  using Callback = std::function<void(const EventWindow&)>;
  explicit EventWindower(const EventWindowerOptions& options = {});
  /// Adds a time-ordered run of events; calls `on_window` for every window completed by it.
  void push(std::span<const Event> events, const Callback& on_window);
  /// Completes windows up to time `t` (e.g. when the stream is known to have moved past it).
  void advance_to(TimeNs t, const Callback& on_window);
  /// Emits the last, partial window (if it holds any events).
  void flush(const Callback& on_window);
  /// Windows emitted or skipped so far (the next window's index).
  std::uint64_t windows_passed() const { return next_index_; }
  /// Empty windows skipped by the gap policy so far.
  std::uint64_t windows_skipped() const { return skipped_total_; }

 private:
  void emit(const Callback& on_window);
  EventWindowerOptions options_;
  bool started_ = false;
  TimeNs t_start_ = 0;
  std::vector<Event> buffer_;  ///< the open windows' events, in arrival order
  std::size_t head_ = 0;       ///< buffer_'s first event still in an open window
  std::vector<Event> window_;  ///< the window handed out: decimated, or a copy when windows overlap
  std::uint64_t next_index_ = 0;
  std::uint64_t empty_run_ = 0;  ///< empty windows emitted in a row
  std::uint64_t skipped_pending_ = 0, skipped_total_ = 0;
};

}  // namespace fdv
