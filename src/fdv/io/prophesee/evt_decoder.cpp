#include "fdv/io/prophesee/evt_decoder.h"

#include <bit>
#include <limits>
#include <optional>

#include "fdv/core/time.h"

namespace fdv {
namespace {

// Word types, from Prophesee's EVT 2.0 / EVT 3.0 format pages (type in the 4 most significant
// bits).
namespace evt2 {
constexpr std::uint32_t kCdOff = 0x0, kCdOn = 0x1, kTimeHigh = 0x8, kExtTrigger = 0xA,
                        kOthers = 0xE, kContinued = 0xF;
}
namespace evt3 {
constexpr std::uint32_t kAddrY = 0x0, kAddrX = 0x2, kVectBaseX = 0x3, kVect12 = 0x4, kVect8 = 0x5,
                        kTimeLow = 0x6, kContinued4 = 0x7, kTimeHigh = 0x8, kExtTrigger = 0xA,
                        kOthers = 0xE, kContinued12 = 0xF;
}

// Rare paths, kept out of the hot loops.
[[gnu::cold]] void count(std::uint64_t& n, std::size_t& first, std::size_t index,
                         std::uint64_t how_many = 1) {
  if (n == 0) first = index;
  n += how_many;
}

/// Whether every time of the counter period starting at `epoch_us` fits int64 nanoseconds.
bool period_fits(std::int64_t epoch_us, std::int64_t period_us) {
  const std::optional<TimeNs> last_us = checked_add(epoch_us, period_us - 1);
  return last_us && checked_mul(*last_us, kNsPerUs);
}

/// Moves `epoch_us` to the next period of `period_us`; false (epoch unchanged) when a time of
/// that period would not fit int64 nanoseconds.
[[gnu::cold]] bool next_epoch(std::int64_t& epoch_us, std::int64_t period_us) {
  const std::optional<TimeNs> next = checked_add(epoch_us, period_us);
  if (!next || !period_fits(*next, period_us)) return false;
  epoch_us = *next;
  return true;
}

/// epoch_us = wraps x period_us, when every time of that period fits int64 nanoseconds.
bool epoch_after(std::uint64_t wraps, std::int64_t period_us, std::int64_t& epoch_us) {
  if (wraps > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) return false;
  const std::optional<TimeNs> start = checked_mul(static_cast<std::int64_t>(wraps), period_us);
  if (!start || !period_fits(*start, period_us)) return false;
  epoch_us = *start;
  return true;
}

// TIME_HIGH steps, values in [0, range): b is behind a when smaller by at most half the range
// (a step back, taken as stated); otherwise b is ahead (across a wrap when smaller).
bool behind(std::uint64_t a, std::uint64_t b, std::uint64_t range) { return b < a && a - b <= range / 2; }
std::uint64_t ahead(std::uint64_t a, std::uint64_t b, std::uint64_t range) { return (b + range - a) % range; }
/// Whether TIME_HIGH b plausibly comes after a: not behind it, at most max_step periods ahead.
bool follows(std::uint64_t a, std::uint64_t b, std::uint64_t range, std::uint64_t max_step) {
  return !behind(a, b, range) && ahead(a, b, range) <= max_step;
}

/// The TIME_HIGH values to set, in order, after one TIME_HIGH word.
struct TimeHighStep {
  std::uint32_t values[2] = {0, 0};
  int n = 0;
};

/// The hold of a TIME_HIGH far ahead (evt_decoder.h), for both encodings: given the current
/// TIME_HIGH (if any) and the new word h, updates the hold and says which values to set (none
/// while a word is held: its events are then not output).
TimeHighStep on_time_high(bool have_time, std::uint32_t current, std::uint32_t h, bool& suspect,
                          std::uint32_t& suspect_high, std::uint64_t range, std::uint64_t max_step,
                          DecodeCounts& counts) {
  TimeHighStep step;
  if (have_time && suspect) {
    if (follows(current, h, range, max_step)) {  // the held word was corrupt
      ++counts.time_high_glitches;
    } else if (follows(suspect_high, h, range, max_step)) {  // a real jump
      step.values[step.n++] = suspect_high;
    } else {
      suspect_high = h;  // no sense yet: the newest word is the suspect
      return step;
    }
    suspect = false;
  } else if (have_time && !behind(current, h, range) && ahead(current, h, range) > max_step) {
    suspect = true;
    suspect_high = h;
    return step;
  }
  step.values[step.n++] = h;
  return step;
}

}  // namespace

bool Evt2Decoder::start_after_wraps(std::uint64_t wraps) {
  return epoch_after(wraps, static_cast<std::int64_t>(kTimeHighRange) << 6, epoch_us_);
}

bool Evt3Decoder::start_after_wraps(std::uint64_t wraps) {
  return epoch_after(wraps, std::int64_t{1} << 24, epoch_us_);
}

std::size_t Evt2Decoder::decode(const Word* words, std::size_t n, Event* out,
                                std::size_t max_events, std::size_t& consumed,
                                DecodeCounts& counts) {
  std::size_t k = 0;
  std::size_t i = 0;
  TimeNs high_ns = high_ns_;
  bool have_time = have_time_;
  bool emitting = have_time && !suspect_ && !overflow_;  // a known, trusted time base
  constexpr std::uint64_t kMaxStep = kMaxTimeHighJumpUs >> 6;
  const auto set_high = [&](std::uint32_t h) {
    if (overflow_) return;
    if (have_time && h < time_high_) {
      if (time_high_ - h > kTimeHighRange / 2) {
        if (!next_epoch(epoch_us_, static_cast<std::int64_t>(kTimeHighRange) << 6)) {
          overflow_ = true;
          return;
        }
        count(counts.wraps, counts.first_wrap, i);
      } else {
        ++counts.time_high_backwards;
      }
    }
    have_time = true;
    time_high_ = h;
    high_ns = (epoch_us_ + (static_cast<std::int64_t>(h) << 6)) * kNsPerUs;
  };
  for (; i < n && k < max_events; ++i) {
    const std::uint32_t w = words[i];
    const std::uint32_t type = w >> 28;
    if (type == evt2::kCdOff || type == evt2::kCdOn) [[likely]] {
      // [27:22] time low 6 bits, [21:11] x, [10:0] y; polarity = type (CD_ON = 1).
      if (emitting) [[likely]] {
        out[k++] = Event{high_ns + static_cast<TimeNs>((w >> 22) & 0x3F) * kNsPerUs,
                         static_cast<std::uint16_t>((w >> 11) & 0x7FF),
                         static_cast<std::uint16_t>(w & 0x7FF), type == evt2::kCdOn};
      } else if (!have_time) {
        count(counts.before_time, counts.first_before_time, i);
      } else if (overflow_) {
        count(counts.time_overflow, counts.first_time_overflow, i);
      } else {
        count(counts.glitch_events, counts.first_glitch_event, i);
      }
      continue;
    }
    switch (type) {
      case evt2::kTimeHigh: {  // [27:0] bits 33..6 of the time in us
        const TimeHighStep step = on_time_high(have_time, time_high_, w & 0x0FFFFFFF, suspect_,
                                               suspect_high_, kTimeHighRange, kMaxStep, counts);
        for (int j = 0; j < step.n; ++j) set_high(step.values[j]);
        emitting = have_time && !suspect_ && !overflow_;
        break;
      }
      case evt2::kExtTrigger:
        ++counts.triggers;
        break;
      case evt2::kOthers:
      case evt2::kContinued:
        ++counts.vendor;
        break;
      default:
        count(counts.unknown, counts.first_unknown, i);
        break;
    }
  }
  high_ns_ = high_ns;
  have_time_ = have_time;
  consumed = i;
  return k;
}

std::size_t Evt3Decoder::decode(const Word* words, std::size_t n, Event* out,
                                std::size_t max_events, std::size_t& consumed,
                                DecodeCounts& counts) {
  std::size_t k = 0;
  std::size_t i = 0;
  // The state lives in locals inside the loop (registers); written back at the end.
  TimeNs t = t_ns_;
  std::uint16_t y = y_;
  std::uint16_t base_x = base_x_;
  bool base_polarity = base_polarity_;
  bool ready = have_time_ && have_y_ && !suspect_ && !overflow_;  // single events can be output
  bool vector_ready = ready && have_base_;          // vector events can be output
  constexpr std::uint64_t kMaxStep = kMaxTimeHighJumpUs >> 12;
  // Events that cannot be output, by reason.
  const auto not_ready = [&](std::size_t index, std::uint64_t how_many) {
    if (!have_time_) {
      count(counts.before_time, counts.first_before_time, index, how_many);
    } else if (overflow_) {
      count(counts.time_overflow, counts.first_time_overflow, index, how_many);
    } else if (suspect_) {
      count(counts.glitch_events, counts.first_glitch_event, index, how_many);
    } else {
      count(counts.missing_address, counts.first_missing_address, index, how_many);
    }
  };
  for (; i < n && k < max_events; ++i) {
    const std::uint32_t w = words[i];
    // ADDR_X is most words of a dense stream: tested before the switch's indirect jump.
    if ((w >> 12) == evt3::kAddrX) [[likely]] {  // [11] polarity, [10:0] x: one event
      if (ready) [[likely]] {
        out[k++] = Event{t, static_cast<std::uint16_t>(w & 0x7FF), y, ((w >> 11) & 1) != 0};
      } else {
        not_ready(i, 1);
      }
      continue;
    }
    switch (w >> 12) {
      case evt3::kAddrY:  // [11] system type (ignored), [10:0] y
        y = static_cast<std::uint16_t>(w & 0x7FF);
        have_y_ = true;
        ready = have_time_ && !suspect_ && !overflow_;
        vector_ready = ready && have_base_;
        break;
      case evt3::kVectBaseX:  // [11] polarity, [10:0] x of the next vector's bit 0
        base_x = static_cast<std::uint16_t>(w & 0x7FF);
        base_polarity = ((w >> 11) & 1) != 0;
        have_base_ = true;
        vector_ready = ready;
        break;
      case evt3::kVect12:
      case evt3::kVect8: {  // [11:0] or [7:0]: bit b set = event at base_x + b; base_x += 12 or 8
        const bool is12 = (w >> 12) == evt3::kVect12;
        const std::uint32_t mask = is12 ? (w & 0xFFF) : (w & 0xFF);
        if (vector_ready) [[likely]] {
          // Branch-free: write every candidate, advance only over the valid ones (out has
          // room for kMaxEventsPerWord - 1 events beyond max_events).
          for (std::uint32_t b = 0; b < 12; ++b) {
            out[k] = Event{t, static_cast<std::uint16_t>(base_x + b), y, base_polarity};
            k += (mask >> b) & 1;
          }
        } else if (mask != 0) {
          not_ready(i, static_cast<std::uint64_t>(std::popcount(mask)));
        }
        base_x = static_cast<std::uint16_t>(base_x + (is12 ? 12 : 8));
        break;
      }
      case evt3::kTimeLow:  // [11:0] bits 11..0 of the time in us
        time_low_ = w & 0xFFF;
        update_time();
        t = t_ns_;
        break;
      case evt3::kTimeHigh: {  // [11:0] bits 23..12 of the time in us
        const std::uint32_t h = w & 0xFFF;
        const auto set_high = [&](std::uint32_t v) {
          if (overflow_) return;
          if (!have_time_ || v != time_high_) {
            if (have_time_ && v < time_high_) {
              if (time_high_ - v > kTimeHighRange / 2) {
                if (!next_epoch(epoch_us_, std::int64_t{1} << 24)) {
                  overflow_ = true;
                  return;
                }
                count(counts.wraps, counts.first_wrap, i);
              } else {
                ++counts.time_high_backwards;
              }
            }
            // A new TIME_HIGH value starts a new 4096 us period: the last TIME_LOW belongs to
            // the previous one, so the time base is the period's start until a TIME_LOW comes.
            time_high_ = v;
            time_low_ = 0;
            update_time();
            t = t_ns_;
          }
          have_time_ = true;
        };
        const TimeHighStep step = on_time_high(have_time_, time_high_, h, suspect_, suspect_high_,
                                               kTimeHighRange, kMaxStep, counts);
        for (int j = 0; j < step.n; ++j) set_high(step.values[j]);
        ready = have_time_ && have_y_ && !suspect_ && !overflow_;
        vector_ready = ready && have_base_;
        break;
      }
      case evt3::kExtTrigger:
        ++counts.triggers;
        break;
      case evt3::kContinued4:
      case evt3::kOthers:
      case evt3::kContinued12:
        ++counts.vendor;
        break;
      default:
        count(counts.unknown, counts.first_unknown, i);
        break;
    }
  }
  y_ = y;
  base_x_ = base_x;
  base_polarity_ = base_polarity;
  consumed = i;
  return k;
}

}  // namespace fdv
