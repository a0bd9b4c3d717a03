#include "fdv/io/rosbag/event_packet_decoder.h"

#include <bit>
#include <cstring>
#include <optional>

#include "fdv/io/text_fields.h"

namespace fdv::bag {
namespace {

constexpr std::size_t kRecordBytes = 8;  // libcaer and mono records
constexpr std::int64_t kLibcaerPeriodUs = std::int64_t{1} << 31;
constexpr std::size_t kEvt3Slice = 4096;  // events per Evt3Decoder call

template <typename T>
T load(const std::uint8_t* p, bool big_endian) {
  T v;
  std::memcpy(&v, p, sizeof v);
  if (big_endian != (std::endian::native == std::endian::big)) v = byte_swap(v);
  return v;
}

/// The packet's time_base as a signed time; nothing above the int64 nanosecond range.
std::optional<TimeNs> signed_time_base(const EventPacketView& p) {
  if (p.time_base > static_cast<std::uint64_t>(std::numeric_limits<TimeNs>::max()))
    return std::nullopt;
  return static_cast<TimeNs>(p.time_base);
}

constexpr const char* kTimeOverflow =
    "event packet: event time outside the 64-bit nanosecond range";

void report_tail(std::size_t bytes, std::size_t unit, const char* reason, ReadReport& report,
                 const std::string& where) {
  if (bytes % unit != 0) report.drop(reason, where);
}

}  // namespace

void EventPacketDecoder::decode(const EventPacketView& p, std::vector<Event>& out,
                                ReadReport& report, const std::string& where) {
  if (p.encoding == "libcaer") {
    decode_libcaer(p, out, report, where);
  } else if (p.encoding == "mono") {
    decode_mono(p, out, report, where);
  } else if (p.encoding == "evt3") {
    decode_evt3(p, out, report, where);
  } else {
    // One fixed reason (a bag may name a different encoding in every packet); the first
    // encoding met, shortened, goes with the place.
    report.drop("event packet: unsupported encoding",
                where + " (encoding '" + escape_non_utf8(p.encoding.substr(0, 64)) + "')");
  }
}

void EventPacketDecoder::decode_libcaer(const EventPacketView& p, std::vector<Event>& out,
                                        ReadReport& report, const std::string& where) {
  report_tail(p.events_bytes, kRecordBytes, "libcaer: packet size not a multiple of 8 bytes",
              report, where);
  const std::size_t n = p.events_bytes / kRecordBytes;
  const std::size_t first = out.size();
  out.resize(first + n);
  std::size_t k = first;
  std::uint64_t invalid = 0, negative = 0, rollovers = 0, overflows = 0;
  const std::optional<TimeNs> time_base = signed_time_base(p);
  if (!time_base) {
    out.resize(first);
    report.drop(kTimeOverflow, where, n);
    return;
  }
  // Time of the counter's zero; nothing once a rollover has left the int64 range.
  std::optional<TimeNs> high_ns = time_base;
  std::int32_t last_ts = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* r = p.events + i * kRecordBytes;
    const std::uint32_t data = load<std::uint32_t>(r, p.big_endian);
    const std::int32_t ts = static_cast<std::int32_t>(load<std::uint32_t>(r + 4, p.big_endian));
    if (ts < 0) {
      ++negative;
      continue;
    }
    if (last_ts > ts && static_cast<std::int64_t>(last_ts) - ts > kLibcaerPeriodUs / 2) {
      // the 31-bit microsecond counter rolled over
      if (high_ns) high_ns = checked_add(*high_ns, kLibcaerPeriodUs * kNsPerUs);
      ++rollovers;
    }
    last_ts = ts;
    if ((data & 1u) == 0) {
      ++invalid;
      continue;
    }
    const std::optional<TimeNs> t =
        high_ns ? checked_add(*high_ns, static_cast<TimeNs>(ts) * kNsPerUs) : std::nullopt;
    if (!t) {
      ++overflows;
      continue;
    }
    out[k++] = Event{*t, static_cast<std::uint16_t>((data >> 17) & 0x7FFF),
                     static_cast<std::uint16_t>((data >> 2) & 0x7FFF), ((data >> 1) & 1u) != 0};
  }
  out.resize(k);
  if (invalid) report.drop("libcaer: event marked invalid", where, invalid);
  if (negative) report.drop("libcaer: negative timestamp", where, negative);
  if (overflows) report.drop(kTimeOverflow, where, overflows);
  if (rollovers)
    report.repair("libcaer: time counter rolled over inside a packet", where, rollovers);
}

void EventPacketDecoder::decode_mono(const EventPacketView& p, std::vector<Event>& out,
                                     ReadReport& report, const std::string& where) {
  report_tail(p.events_bytes, kRecordBytes, "mono: packet size not a multiple of 8 bytes", report,
              where);
  const std::size_t n = p.events_bytes / kRecordBytes;
  const std::size_t first = out.size();
  const std::optional<TimeNs> base = signed_time_base(p);
  if (!base) {
    report.drop(kTimeOverflow, where, n);
    return;
  }
  out.resize(first + n);
  std::size_t k = first;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t w = load<std::uint64_t>(p.events + i * kRecordBytes, p.big_endian);
    const std::optional<TimeNs> t = checked_add(*base, static_cast<TimeNs>(w & 0xFFFFFFFFu));
    if (!t) continue;  // counted below
    out[k++] = Event{*t, static_cast<std::uint16_t>((w >> 32) & 0xFFFF),
                     static_cast<std::uint16_t>((w >> 48) & 0x7FFF), (w >> 63) != 0};
  }
  if (const std::size_t lost = first + n - k) report.drop(kTimeOverflow, where, lost);
  out.resize(k);
  shift(p, out, first, report, where);
}

void EventPacketDecoder::decode_evt3(const EventPacketView& p, std::vector<Event>& out,
                                     ReadReport& report, const std::string& where) {
  report_tail(p.events_bytes, 2, "evt3: packet size not a multiple of 2 bytes", report, where);
  const std::size_t n = p.events_bytes / 2;
  words_.resize(n);
  if (n > 0) std::memcpy(words_.data(), p.events, n * 2);  // aligned copy
  if (p.big_endian)
    for (auto& w : words_) w = byte_swap(w);
  evt3_out_.resize(kEvt3Slice + Evt3Decoder::kMaxEventsPerWord);
  const std::size_t first = out.size();
  DecodeCounts counts;
  std::size_t done = 0;
  while (done < n) {
    std::size_t consumed = 0;
    const std::size_t k = evt3_.decode(words_.data() + done, n - done, evt3_out_.data(), kEvt3Slice,
                                       consumed, counts);
    out.insert(out.end(), evt3_out_.begin(), evt3_out_.begin() + static_cast<std::ptrdiff_t>(k));
    done += consumed;
  }
  if (counts.before_time)
    report.drop("evt3: event before the first time word", where, counts.before_time);
  if (counts.missing_address)
    report.drop("evt3: event before its row or vector base", where, counts.missing_address);
  if (counts.unknown) report.drop("evt3: word of a reserved type", where, counts.unknown);
  if (counts.triggers) report.drop("evt3: external trigger (not used)", where, counts.triggers);
  if (counts.wraps) report.repair("evt3: time counter wrapped", where, counts.wraps);
  shift(p, out, first, report, where);
}

void EventPacketDecoder::shift(const EventPacketView& p, std::vector<Event>& out, std::size_t first,
                               ReadReport& report, const std::string& where) {
  if (out.size() == first) return;
  if (!anchored_) {
    const std::optional<TimeNs> offset = checked_sub(p.stamp, out[first].t);
    if (!offset) {
      // No offset can move this packet onto the bag's clock; the next packet may anchor.
      report.drop("event packet: sensor time too far from the header stamp to share its clock",
                  where, out.size() - first);
      out.resize(first);
      return;
    }
    offset_ns_ = *offset;
    anchored_ = true;
  }
  std::size_t k = first;
  for (std::size_t i = first; i < out.size(); ++i) {
    const std::optional<TimeNs> t = checked_add(out[i].t, offset_ns_);
    if (!t) continue;
    out[k] = out[i];
    out[k++].t = *t;
  }
  if (const std::size_t lost = out.size() - k) report.drop(kTimeOverflow, where, lost);
  out.resize(k);
}

}  // namespace fdv::bag
