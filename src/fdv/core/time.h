#pragma once
/// The project's one time base: signed 64-bit integer nanoseconds.
///
/// The epoch is the input's own (a sensor's clock, ROS time, or 0 at the start of a simulated
/// scene); readers convert every timestamp to nanoseconds and never shift it, so outputs can be
/// matched against the input's own time stamps. Durations use the same type.
#include <cmath>
#include <cstdint>
#include <optional>

namespace fdv {

using TimeNs = std::int64_t;

inline constexpr TimeNs kNsPerUs = 1'000;
inline constexpr TimeNs kNsPerMs = 1'000'000;
inline constexpr TimeNs kNsPerS = 1'000'000'000;

constexpr double to_seconds(TimeNs t_ns) { return static_cast<double>(t_ns) * 1e-9; }
inline TimeNs from_seconds(double t_s) { return static_cast<TimeNs>(std::llround(t_s * 1e9)); }
/// Whole microseconds at or before t (the formats that store µs round time down, negatives too).
constexpr std::int64_t floor_us(TimeNs t) { return t >= 0 ? t / 1000 : -((-t + 999) / 1000); }

/// The times a sensor sample may carry: |t| < 2^62 ns (146 years either side of the input's epoch,
/// Unix time until 2116). Outside, the time is corrupt (e.g. INT64_MIN from a damaged record), and
/// the difference of two valid times always fits in TimeNs. Readers and Perception drop the rest.
inline constexpr TimeNs kMaxAbsTimeNs = TimeNs{1} << 62;
constexpr bool valid_time(TimeNs t) { return t > -kMaxAbsTimeNs && t < kMaxAbsTimeNs; }

/// Checked time arithmetic for values read from files: a hostile stamp must give an error or a
/// counted drop, never a wrapped time (signed overflow is undefined behaviour).
inline std::optional<TimeNs> checked_add(TimeNs a, TimeNs b) {
  TimeNs sum;
  if (__builtin_add_overflow(a, b, &sum)) return std::nullopt;
  return sum;
}
inline std::optional<TimeNs> checked_sub(TimeNs a, TimeNs b) {
  TimeNs difference;
  if (__builtin_sub_overflow(a, b, &difference)) return std::nullopt;
  return difference;
}
inline std::optional<TimeNs> checked_mul(TimeNs a, TimeNs b) {
  TimeNs product;
  if (__builtin_mul_overflow(a, b, &product)) return std::nullopt;
  return product;
}

}  // namespace fdv
