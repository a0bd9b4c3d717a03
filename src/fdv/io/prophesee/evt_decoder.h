#pragma once
/// Streaming decoders for Prophesee's EVT 2.0 (32-bit words) and EVT 3.0 (16-bit words) event
/// encodings, written from Prophesee's public format documentation (docs/FORMATS.md lists the
/// bit layouts). They keep their state (time base, current row, vector base) across calls, so a
/// file, a socket or a USB stream can be fed in pieces of any whole number of words.
///
///   Evt3Decoder dec;
///   std::vector<Event> out(kSlice + Evt3Decoder::kMaxEventsPerWord);
///   std::size_t consumed = 0;
///   DecodeCounts counts;
///   const std::size_t n = dec.decode(words, n_words, out.data(), kSlice, consumed, counts);
///   // out[0, n) are the decoded events (t in ns); words[consumed, n_words) are still to do.
///
/// Semantics (docs/FORMATS.md, "Prophesee RAW"):
///  - timestamps are microseconds on the sensor clock, returned as ns (x 1000), never shifted;
///  - CD events before the first TIME_HIGH (and, in EVT 3.0, before the first ADDR_Y or, for
///    vectors, VECT_BASE_X) have no known time or row: they are not output and are counted;
///  - a TIME_HIGH that goes back by more than half of its range is a counter wrap: the decoder
///    adds one full period (EVT 2.0: 2^34 us, EVT 3.0: 2^24 us) and counts it; a smaller step
///    back is taken as stated (the events after it then go back in time, and the reader's
///    EventSanitizer drops them until time catches up), and counted in `time_high_backwards`;
///  - a TIME_HIGH more than kMaxTimeHighJumpUs ahead (a single corrupt word would otherwise move
///    the time base far ahead, after which every correct word looks like a step back or a wrap:
///    the rest of the file dropped, or shifted by a wrap) is held as suspect, and the events
///    under it are not output (counted in `glitch_events`). The next TIME_HIGH decides: if it
///    follows the time before the suspect, the suspect was a glitch (`time_high_glitches`); if
///    it follows the suspect, the jump was real and decoding goes on from there;
///  - a wrap that would start a period whose times do not all fit int64 ns (after 536,869 EVT 2.0
///    or about 550 million EVT 3.0 wraps: 292 years on the sensor clock, only a corrupt or forged
///    stream gets there) is not applied: no later time can be represented, so every CD event
///    from there on is not output and is counted in `time_overflow` (checked arithmetic, no
///    undefined behaviour; the events before stay valid);
///  - EXT_TRIGGER, OTHERS and CONTINUED words are skipped and counted; words of a reserved type
///    are skipped and counted as unknown.
/// Events are not checked against the sensor size (the reader does that). No allocation; words
/// are little-endian as stored in RAW files and read on a little-endian host.
/// Not thread-safe; one decoder per stream.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "fdv/core/sensor_data.h"

namespace fdv {

/// A TIME_HIGH further ahead than this is suspect until the next TIME_HIGH confirms it.
inline constexpr std::int64_t kMaxTimeHighJumpUs = 1'000'000;

static_assert(std::endian::native == std::endian::little,
              "the Prophesee decoders read little-endian words in place");

/// What one decode() call skipped. Indices are word indices within that call's input
/// (kNone when nothing of the kind happened).
struct DecodeCounts {
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::uint64_t before_time = 0;  ///< CD events before the first TIME_HIGH (dropped)
  std::size_t first_before_time = kNone;
  std::uint64_t missing_address = 0;  ///< EVT 3.0: CD events before the first ADDR_Y / VECT_BASE_X
  std::size_t first_missing_address = kNone;
  std::uint64_t unknown = 0;  ///< words of a reserved type (skipped)
  std::size_t first_unknown = kNone;
  std::uint64_t wraps = 0;  ///< time counter wraps (repaired)
  std::size_t first_wrap = kNone;
  std::uint64_t time_high_backwards = 0;  ///< TIME_HIGH smaller than the last, not a wrap
  std::uint64_t time_high_glitches = 0;   ///< TIME_HIGH far ahead that the next one contradicted
  std::uint64_t glitch_events = 0;        ///< CD events under a suspect TIME_HIGH (dropped)
  std::size_t first_glitch_event = kNone;
  std::uint64_t time_overflow = 0;        ///< CD events after the time left int64 ns (dropped)
  std::size_t first_time_overflow = kNone;
  std::uint64_t triggers = 0;             ///< EXT_TRIGGER words (skipped)
  std::uint64_t vendor = 0;               ///< OTHERS / CONTINUED words (skipped)
};

class Evt2Decoder {
 public:
  using Word = std::uint32_t;
  static constexpr std::size_t kMaxEventsPerWord = 1;
  static constexpr std::uint64_t kTimeHighRange = std::uint64_t{1} << 28;  ///< TIME_HIGH values

  /// Decodes words[0, n) into out, stopping before the first word that starts when at least
  /// `max_events` events have been written (out must hold max_events + kMaxEventsPerWord - 1).
  /// Sets `consumed` to the number of words used; returns the number of events written.
  std::size_t decode(const Word* words, std::size_t n, Event* out, std::size_t max_events,
                     std::size_t& consumed, DecodeCounts& counts);

  /// Before the first decode(): starts the time base `wraps` counter periods (2^34 us) late, for
  /// a stream that continues one already decoded that far. False (nothing changed) when a time
  /// of that period would not fit int64 ns.
  bool start_after_wraps(std::uint64_t wraps);

 private:
  bool have_time_ = false;
  std::uint32_t time_high_ = 0;  ///< last TIME_HIGH payload (bits 33..6 of the time in us)
  std::int64_t epoch_us_ = 0;    ///< wraps x 2^34 us
  TimeNs high_ns_ = 0;           ///< (epoch + time_high << 6) in ns
  bool suspect_ = false;         ///< a TIME_HIGH far ahead waits for the next one
  std::uint32_t suspect_high_ = 0;
  bool overflow_ = false;  ///< a wrap would have left int64 ns: no time from here on
};

class Evt3Decoder {
 public:
  using Word = std::uint16_t;
  static constexpr std::size_t kMaxEventsPerWord = 12;                     ///< VECT_12
  static constexpr std::uint32_t kTimeHighRange = std::uint32_t{1} << 12;  ///< TIME_HIGH values

  /// As Evt2Decoder::decode (out must hold max_events + 11 events).
  std::size_t decode(const Word* words, std::size_t n, Event* out, std::size_t max_events,
                     std::size_t& consumed, DecodeCounts& counts);

  /// As Evt2Decoder::start_after_wraps (periods of 2^24 us).
  bool start_after_wraps(std::uint64_t wraps);

 private:
  // Cannot overflow: a wrap is only applied when every time of the new period fits int64 ns.
  void update_time() {
    t_ns_ = (epoch_us_ + (static_cast<std::int64_t>(time_high_) << 12) + time_low_) * kNsPerUs;
  }

  bool have_time_ = false;
  bool have_y_ = false;
  bool have_base_ = false;
  std::uint32_t time_high_ = 0;  ///< bits 23..12 of the time in us
  std::uint32_t time_low_ = 0;   ///< bits 11..0
  std::int64_t epoch_us_ = 0;    ///< wraps x 2^24 us
  TimeNs t_ns_ = 0;              ///< current time base in ns
  bool suspect_ = false;         ///< a TIME_HIGH far ahead waits for the next one
  std::uint32_t suspect_high_ = 0;
  bool overflow_ = false;  ///< a wrap would have left int64 ns: no time from here on
  std::uint16_t y_ = 0;
  std::uint16_t base_x_ = 0;
  bool base_polarity_ = false;
};

}  // namespace fdv
