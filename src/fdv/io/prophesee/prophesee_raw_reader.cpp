#include "fdv/io/prophesee/prophesee_raw_reader.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <optional>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/prophesee/evt_decoder.h"
#include "fdv/io/text_fields.h"

namespace fdv {
namespace fs = std::filesystem;
namespace {

/// A header longer than this is not a RAW header (real ones are a few hundred bytes).
constexpr std::size_t kMaxHeaderBytes = 1 << 20;
/// Events decoded per slice between two EventSanitizer passes (bounds the raw buffer).
constexpr std::size_t kSliceEvents = 8192;
/// Largest sensor EVT 2.0 / 3.0 can address (11-bit coordinates).
constexpr int kMaxSensorSide = 2048;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool parse_int(std::string_view s, int& out) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && !s.empty();
}

bool valid_side(int v) { return v > 0 && v <= kMaxSensorSide; }

const std::string* find_key(const RawHeader& h, const std::string& key) {
  const auto it = h.keys.find(key);
  return it == h.keys.end() ? nullptr : &it->second;
}

/// `format EVT3;height=720;width=1280` -> "height" -> "720".
std::optional<std::string> format_field(const std::string& format, const std::string& name) {
  std::size_t start = format.find(';');
  while (start != std::string::npos) {
    const std::size_t end = format.find(';', start + 1);
    const std::string item =
        format.substr(start + 1, end == std::string::npos ? std::string::npos : end - start - 1);
    const std::size_t eq = item.find('=');
    if (eq != std::string::npos && lower(item.substr(0, eq)) == name) return item.substr(eq + 1);
    start = end;
  }
  return std::nullopt;
}

void decide_encoding(const std::string& path, RawHeader& h) {
  if (const auto* evt = find_key(h, "evt")) {
    if (*evt == "2.0")
      h.encoding = "evt2";
    else if (*evt == "3.0")
      h.encoding = "evt3";
    else
      throw InputError(path, "key evt",
                       "EVT " + escape_non_utf8(*evt) + " is not supported (only EVT 2.0 and 3.0)");
    h.encoding_source = "`evt` header line";
    return;
  }
  if (const auto* format = find_key(h, "format")) {
    const std::string name = lower(format->substr(0, format->find(';')));
    if (name == "evt2")
      h.encoding = "evt2";
    else if (name == "evt3")
      h.encoding = "evt3";
    else
      throw InputError(path, "key format",
                       "encoding '" + escape_non_utf8(name) +
                           "' is not supported (only EVT2 and EVT3)");
    h.encoding_source = "`format` header line";
    return;
  }
  if (const auto* plugin = find_key(h, "plugin_name")) {
    // Prophesee: Gen3 sensors record EVT 2.0 by default, Gen4 / IMX636 sensors EVT 3.0.
    const std::string p = lower(*plugin);
    if (p.find("gen3") != std::string::npos)
      h.encoding = "evt2";
    else if (p.find("gen4") != std::string::npos || p.find("imx636") != std::string::npos)
      h.encoding = "evt3";
    if (!h.encoding.empty()) {
      h.encoding_source = "plugin_name '" + escape_non_utf8(*plugin) + "' (no `evt` header line)";
      return;
    }
  }
  if (find_key(h, "version"))
    throw InputError(path, "byte 0",
                     "header has a `Version` line and no `evt` line: a Prophesee DAT file, which "
                     "is not supported (convert it to RAW or HDF5)");
  throw InputError(path, "key evt",
                   "header names no event encoding (no `evt` or `format` line, and no "
                   "plugin_name of a known sensor)");
}

void decide_geometry(const std::string& path, RawHeader& h) {
  if (const auto* g = find_key(h, "geometry")) {
    const std::size_t x = g->find('x');
    int w = 0, ht = 0;
    if (x == std::string::npos || !parse_int(std::string_view(*g).substr(0, x), w) ||
        !parse_int(std::string_view(*g).substr(x + 1), ht) || !valid_side(w) || !valid_side(ht))
      throw InputError(path, "key geometry",
                       "expected WIDTHxHEIGHT with sides in 1..2048, got '" +
                           escape_non_utf8(*g) + "'");
    h.width = w;
    h.height = ht;
    h.geometry_source = "`geometry` header line";
    return;
  }
  if (const auto* format = find_key(h, "format")) {
    const auto w = format_field(*format, "width");
    const auto ht = format_field(*format, "height");
    if (w || ht) {
      if (!w || !ht || !parse_int(*w, h.width) || !parse_int(*ht, h.height) ||
          !valid_side(h.width) || !valid_side(h.height))
        throw InputError(path, "key format",
                         "width/height fields missing or not in 1..2048: '" +
                             escape_non_utf8(*format) + "'");
      h.geometry_source = "`format` header line";
      return;
    }
  }
  const auto* w = find_key(h, "width");
  const auto* ht = find_key(h, "height");
  if (w && ht) {
    if (!parse_int(*w, h.width) || !parse_int(*ht, h.height) || !valid_side(h.width) ||
        !valid_side(h.height))
      throw InputError(path, "key width", "width/height not integers in 1..2048");
    h.geometry_source = "`width` and `height` header lines";
    return;
  }
  const auto* plugin = find_key(h, "plugin_name");
  if (plugin) {
    // Sensor sizes from Prophesee's sensor pages: Gen3 / Gen3.1 VGA 640x480; Gen4 / Gen4.1 /
    // IMX636 HD 1280x720; GenX320 320x320.
    const std::string p = lower(*plugin);
    if (p.find("gen3") != std::string::npos) {
      h.width = 640;
      h.height = 480;
    } else if (p.find("gen4") != std::string::npos || p.find("imx636") != std::string::npos) {
      h.width = 1280;
      h.height = 720;
    } else if (p.find("genx320") != std::string::npos) {
      h.width = 320;
      h.height = 320;
    }
    if (h.width > 0) {
      h.geometry_source =
          "plugin_name '" + escape_non_utf8(*plugin) + "' (no `geometry` header line)";
      return;
    }
  }
  throw InputError(path, "key geometry",
                   "header gives no sensor size (no `geometry`, `format` or `width`/`height` "
                   "line) and plugin_name '" +
                       (plugin ? escape_non_utf8(*plugin) : std::string("(none)")) +
                       "' is not a known sensor");
}

template <typename Decoder>
class RawReader final : public RecordingReader {
 public:
  using Word = typename Decoder::Word;

  RawReader(std::unique_ptr<std::istream> in, const std::string& path, const RawHeader& header,
            const ReaderOptions& options, const PropheseeRawOptions& raw_options)
      : path_(path),
        chunk_events_(std::max<std::size_t>(1, options.chunk_events)),
        sanitizer_(header.width, header.height),
        in_(std::move(in)) {
    in_->clear();  // the header read may have hit the end of a short file
    in_->seekg(0, std::ios::end);
    const std::streamoff end = in_->tellg();
    in_->seekg(static_cast<std::streamoff>(header.data_offset));
    if (!*in_ || end < 0 || static_cast<std::uint64_t>(end) < header.data_offset)
      throw InputError(path, "", "cannot read (not a seekable file)");
    next_byte_ = header.data_offset;
    bytes_left_ = static_cast<std::uint64_t>(end) - header.data_offset;
    buffer_.resize(raw_options.read_buffer_bytes / sizeof(Word));
    raw_.resize(kSliceEvents + Decoder::kMaxEventsPerWord - 1);

    info_.path = path;
    info_.format = header.encoding;
    info_.width = header.width;
    info_.height = header.height;
    info_.streams = {StreamKind::kEvents};
    info_.notes.push_back(std::string(sizeof(Word) == 4 ? "EVT 2.0" : "EVT 3.0") +
                          " encoding, from the " + header.encoding_source);
    info_.notes.push_back("sensor size " + std::to_string(header.width) + "x" +
                          std::to_string(header.height) + ", from the " + header.geometry_source);
    // fdv's EVT 3.0 writer keeps the first event's time here (evt3_writer.h).
    if (const auto* offset = find_key(header, "time_offset_us")) {
      std::int64_t us = 0;
      const auto [ptr, ec] = std::from_chars(offset->data(), offset->data() + offset->size(), us);
      constexpr std::int64_t kMaxUs = std::numeric_limits<TimeNs>::max() / kNsPerUs;
      if (ec != std::errc() || ptr != offset->data() + offset->size() || us > kMaxUs || us < -kMaxUs)
        throw InputError(path, "key time_offset_us",
                         "expected an integer number of microseconds, got '" + escape_non_utf8(*offset) + "'");
      offset_ns_ = us * kNsPerUs;
      info_.notes.push_back("times moved by time_offset_us " + std::to_string(us) + " (header line)");
    }
    for (const char* key : {"plugin_name", "serial_number", "date"})
      if (const auto* v = find_key(header, key))
        info_.notes.push_back(std::string(key) + ": " + escape_non_utf8(*v));
    info_.notes.push_back(
        "CD events before the first TIME_HIGH have no known time: dropped and counted");
  }

  const RecordingInfo& info() const override { return info_; }
  const ReadReport& report() const override { return report_; }

  bool read(SensorChunk& chunk) override {
    chunk.clear();
    while (chunk.events.size() < chunk_events_) {
      if (pos_ == n_words_ && !refill()) break;
      const std::size_t want = std::min(chunk_events_ - chunk.events.size(), kSliceEvents);
      DecodeCounts counts;
      std::size_t consumed = 0;
      std::size_t n = decoder_.decode(buffer_.data() + pos_, n_words_ - pos_, raw_.data(),
                                            want, consumed, counts);
      const std::uint64_t slice_byte = buffer_byte_ + pos_ * sizeof(Word);
      account(counts, slice_byte);
      if (offset_ns_ != 0) shift(n, slice_byte);
      if (n > 0)
        sanitizer_.append(raw_.data(), raw_.data() + n, chunk.events, report_, [&](std::size_t i) {
          return "byte " + std::to_string(slice_byte) + " (words from there), event " + std::to_string(i) + " decoded";
        });
      pos_ += consumed;
    }
    if (chunk.events.empty()) {
      finish();
      return false;
    }
    return true;
  }

 private:
  /// Adds the header's time offset to the n decoded events; one that would leave int64 ns is
  /// dropped and counted (raw_ is compacted in place).
  void shift(std::size_t& n, std::uint64_t slice_byte) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n; ++i) {
      Event e = raw_[i];
      if (__builtin_add_overflow(e.t, offset_ns_, &e.t)) continue;
      raw_[kept++] = e;
    }
    if (kept != n)
      report_.drop("event time beyond the int64 nanosecond range (time counter wrapped too often)",
                   "byte " + std::to_string(slice_byte), n - kept);
    n = kept;
  }

  /// Loads the next buffer of whole words; false at the end of the data.
  bool refill() {
    pos_ = n_words_ = 0;
    if (bytes_left_ == 0) return false;
    const std::size_t want = static_cast<std::size_t>(
        std::min<std::uint64_t>(bytes_left_, buffer_.size() * sizeof(Word)));
    buffer_byte_ = next_byte_;
    in_->read(reinterpret_cast<char*>(buffer_.data()), static_cast<std::streamsize>(want));
    if (static_cast<std::size_t>(in_->gcount()) != want)
      throw InputError(path_, "byte " + std::to_string(next_byte_ + in_->gcount()),
                       "read failed (file shrank or I/O error)");
    next_byte_ += want;
    bytes_left_ -= want;
    n_words_ = want / sizeof(Word);
    if (want % sizeof(Word) != 0)  // only the last read of a file can end mid-word
      report_.drop("truncated trailing word",
                   "byte " + std::to_string(buffer_byte_ + n_words_ * sizeof(Word)));
    return n_words_ > 0;
  }

  void account(const DecodeCounts& c, std::uint64_t slice_byte) {
    const auto at = [&](std::size_t index) {
      return "byte " + std::to_string(slice_byte + index * sizeof(Word));
    };
    if (c.before_time)
      report_.drop("event before the first TIME_HIGH", at(c.first_before_time), c.before_time);
    if (c.missing_address)
      report_.drop("event before the first ADDR_Y / VECT_BASE_X", at(c.first_missing_address),
                   c.missing_address);
    if (c.unknown)
      report_.drop(
          std::string("unknown ") + (sizeof(Word) == 4 ? "EVT 2.0" : "EVT 3.0") + " word type",
          at(c.first_unknown), c.unknown);
    if (c.wraps) report_.repair("time counter wrapped", at(c.first_wrap), c.wraps);
    if (c.time_overflow)
      report_.drop("event time beyond the int64 nanosecond range (time counter wrapped too often)",
                   at(c.first_time_overflow), c.time_overflow);
    if (c.glitch_events)
      report_.drop("event under a TIME_HIGH far ahead of the stream (held until the next TIME_HIGH)",
                   at(c.first_glitch_event), c.glitch_events);
    time_high_glitches_ += c.time_high_glitches;
    triggers_ += c.triggers;
    vendor_ += c.vendor;
    time_high_backwards_ += c.time_high_backwards;
  }

  void finish() {
    if (finished_) return;
    finished_ = true;
    info_.notes.push_back("external trigger words skipped: " + std::to_string(triggers_));
    info_.notes.push_back("vendor words (OTHERS / CONTINUED) skipped: " + std::to_string(vendor_));
    if (time_high_glitches_)
      info_.notes.push_back("TIME_HIGH jumped far ahead and the next one came back " +
                            std::to_string(time_high_glitches_) + " time(s): taken as corrupt words");
    if (time_high_backwards_)
      info_.notes.push_back("TIME_HIGH went backwards " + std::to_string(time_high_backwards_) +
                            " time(s); events until the time recovered were dropped");
  }

  std::string path_;
  std::size_t chunk_events_;
  RecordingInfo info_;
  ReadReport report_;
  EventSanitizer sanitizer_;
  Decoder decoder_;
  std::unique_ptr<std::istream> in_;
  std::uint64_t next_byte_ = 0;    ///< file offset of the next read
  std::uint64_t bytes_left_ = 0;   ///< data bytes not yet read
  std::uint64_t buffer_byte_ = 0;  ///< file offset of buffer_[0]
  std::vector<Word> buffer_;
  std::size_t n_words_ = 0, pos_ = 0;
  std::vector<Event> raw_;
  TimeNs offset_ns_ = 0;  ///< `% time_offset_us`, added to every decoded time
  std::uint64_t triggers_ = 0, vendor_ = 0, time_high_backwards_ = 0, time_high_glitches_ = 0;
  bool finished_ = false;
};

}  // namespace

std::string PropheseeRawOptions::validate() const {
  if (read_buffer_bytes < 4 || read_buffer_bytes % 4 != 0)
    return "read_buffer_bytes must be a positive multiple of 4 (whole words), got " +
           std::to_string(read_buffer_bytes);
  return {};
}

bool looks_like_prophesee_raw(std::string_view head) {
  return head.size() >= 2 && head[0] == '%' && head[1] == ' ';
}

RawHeader read_prophesee_raw_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open file");
  return read_prophesee_raw_header(in, path);
}

RawHeader read_prophesee_raw_header(std::istream& in, const std::string& path) {
  std::string buf(kMaxHeaderBytes, '\0');
  in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
  buf.resize(static_cast<std::size_t>(in.gcount()));
  const bool whole_file = buf.size() < kMaxHeaderBytes;

  RawHeader h;
  std::size_t pos = 0;
  // A header line is "% keyword value\n"; the data starts at the first line that does not start
  // with "% ", or right after "% end" (Prophesee's RAW format page).
  while (pos + 1 < buf.size() && buf[pos] == '%' && buf[pos + 1] == ' ') {
    const std::size_t nl = buf.find('\n', pos);
    if (nl == std::string::npos)
      throw InputError(path, "byte " + std::to_string(pos),
                       whole_file ? "header line not terminated (truncated header)"
                                  : "header longer than 1 MiB (not a Prophesee RAW file?)");
    std::string_view content(buf.data() + pos + 2, nl - pos - 2);
    if (!content.empty() && content.back() == '\r') content.remove_suffix(1);
    pos = nl + 1;
    if (content == "end") break;
    const std::size_t space = content.find(' ');
    std::string key(content.substr(0, space));
    std::string_view value =
        space == std::string_view::npos ? std::string_view{} : content.substr(space + 1);
    while (!value.empty() && value.front() == ' ') value.remove_prefix(1);
    if (!key.empty()) h.keys.emplace(lower(key), std::string(value));
  }
  h.data_offset = pos;
  decide_encoding(path, h);
  decide_geometry(path, h);
  return h;
}

std::unique_ptr<RecordingReader> open_prophesee_raw(std::unique_ptr<std::istream> in,
                                                    const std::string& name,
                                                    const ReaderOptions& options,
                                                    const PropheseeRawOptions& raw_options) {
  if (const std::string why = raw_options.validate(); !why.empty())
    throw ConfigError("PropheseeRawOptions: " + why);
  if (!in || !*in) throw InputError(name, "", "cannot open file");
  const RawHeader header = read_prophesee_raw_header(*in, name);
  if (header.encoding == "evt2")
    return std::make_unique<RawReader<Evt2Decoder>>(std::move(in), name, header, options,
                                                    raw_options);
  return std::make_unique<RawReader<Evt3Decoder>>(std::move(in), name, header, options,
                                                  raw_options);
}

std::unique_ptr<RecordingReader> open_prophesee_raw(const std::string& path,
                                                    const ReaderOptions& options,
                                                    const PropheseeRawOptions& raw_options) {
  if (const std::string why = raw_options.validate(); !why.empty())
    throw ConfigError("PropheseeRawOptions: " + why);
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a folder, not a file");
  auto in = std::make_unique<std::ifstream>(path, std::ios::binary);
  if (!*in) throw InputError(path, "", "cannot open file");
  return open_prophesee_raw(std::move(in), path, options, raw_options);
}

}  // namespace fdv
