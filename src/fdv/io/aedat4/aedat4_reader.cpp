#include "fdv/io/aedat4/aedat4_reader.h"

#include <lz4frame.h>
#include <tinyxml2.h>
#include <zstd.h>
#include <zstd_errors.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <numbers>
#include <optional>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/aedat4/event_packet_generated.h"
#include "fdv/io/aedat4/imu_packet_generated.h"
#include "fdv/io/aedat4/io_header_generated.h"
#include "fdv/io/text_fields.h"

namespace fdv {
namespace {

namespace fs = std::filesystem;

/// The IOHeader is a size-prefixed FlatBuffer right after the magic.
constexpr std::uint64_t kHeaderAt = kAedat4Magic.size();
/// Packet header: int32 stream id, int32 payload size (little-endian).
constexpr std::uint64_t kPacketHeaderBytes = 8;
/// Bound that keeps a damaged IOHeader size field from asking for absurd memory (a real header
/// is a few KiB: the XML description of a handful of streams).
constexpr std::uint32_t kMaxIoHeaderBytes = 64u << 20;
/// Largest stored (compressed) payload read: LZ4 and Zstd expand incompressible data by less
/// than 1/128 (LZ4 n/255 + 16 bytes per block, Zstd about n/256), so any packet that inflates
/// to at most kAedat4MaxPacketBytes fits.
constexpr std::size_t kMaxStoredPacketBytes = kAedat4MaxPacketBytes + kAedat4MaxPacketBytes / 128;
/// Zstd window limit: log2(kAedat4MaxPacketBytes). A frame cannot need a window larger than its
/// content, so a larger declared window is refused instead of allocated.
constexpr int kMaxZstdWindowLog = 26;
static_assert(std::size_t{1} << kMaxZstdWindowLog == kAedat4MaxPacketBytes);
constexpr const char* kPacketTooLarge = "decompressed packet larger than the 64 MiB limit";
/// IMU samples held back (waiting for the events to reach their time) before they are handed
/// out anyway; bounds memory for files with few or no events.
constexpr std::size_t kMaxPendingImu = 1 << 16;
/// Largest |time| in microseconds that is a valid time in nanoseconds (fdv/core/time.h).
constexpr std::int64_t kMaxTimeUs = kMaxAbsTimeNs / kNsPerUs;

using Compression = Aedat4Compression;

const char* to_string(Compression c) {
  switch (c) {
    case Compression::kNone:
      return "none";
    case Compression::kLz4:
      return "LZ4";
    case Compression::kLz4High:
      return "LZ4 high";
    case Compression::kZstd:
      return "Zstd";
    case Compression::kZstdHigh:
      return "Zstd high";
  }
  return "?";
}

std::string at_byte(std::uint64_t offset) { return "byte " + std::to_string(offset); }

std::uint32_t load_u32(const char* p) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

/// One stream as the XML stream description declares it.
struct StreamDesc {
  std::string type_id;        ///< four-character type identifier, e.g. "EVTS"
  int width = 0, height = 0;  ///< info node sizeX / sizeY; 0 when absent
  std::string source;         ///< info node source, e.g. "DAVIS346_00000133"
  std::uint64_t skipped_packets = 0;
};

// ---- XML stream description --------------------------------------------------------------

/// Text of <attr key="key">text</attr> among the children of `node`, or nullptr.
const char* attr_text(const tinyxml2::XMLElement* node, const char* key) {
  for (auto* a = node->FirstChildElement("attr"); a; a = a->NextSiblingElement("attr")) {
    const char* k = a->Attribute("key");
    if (k && std::strcmp(k, key) == 0) return a->GetText() ? a->GetText() : "";
  }
  return nullptr;
}

const tinyxml2::XMLElement* child_node(const tinyxml2::XMLElement* parent, const char* name) {
  for (auto* n = parent->FirstChildElement("node"); n; n = n->NextSiblingElement("node")) {
    const char* nm = n->Attribute("name");
    if (nm && std::strcmp(nm, name) == 0) return n;
  }
  return nullptr;
}

bool parse_trimmed_int(std::string_view s, int& out) {
  while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

/// Streams of the IOHeader's XML description, by stream id:
///   <dv><node name="outInfo"><node name="ID"><attr key="typeIdentifier">EVTS</attr>
///        <node name="info"><attr key="sizeX">346</attr><attr key="sizeY">260</attr>...
std::map<std::int32_t, StreamDesc> parse_streams(const char* xml, std::size_t size,
                                                 const std::string& path) {
  const auto fail = [&](const std::string& why) -> void {
    throw InputError(path, at_byte(kHeaderAt), "IOHeader stream description: " + why);
  };
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml, size) != tinyxml2::XML_SUCCESS)
    fail("not valid XML (" + escape_non_utf8(doc.ErrorStr()) + ")");  // may quote the text
  // Parse() accepts a document of only comments, text or a declaration: no element at all.
  const tinyxml2::XMLElement* root = doc.RootElement();
  if (!root) fail("not valid XML (no root element)");
  const tinyxml2::XMLElement* out_info = child_node(root, "outInfo");
  if (!out_info) fail("no <node name=\"outInfo\">");
  std::map<std::int32_t, StreamDesc> streams;
  for (auto* n = out_info->FirstChildElement("node"); n; n = n->NextSiblingElement("node")) {
    const char* name = n->Attribute("name");
    int id = 0;
    if (!name || !parse_trimmed_int(name, id) || id < 0)
      fail("stream node name \"" + escape_non_utf8(name ? name : "") +
           "\" is not a non-negative integer id");
    StreamDesc s;
    // The XML parser does not check UTF-8; these texts reach info().notes.
    if (const char* t = attr_text(n, "typeIdentifier")) s.type_id = escape_non_utf8(t);
    if (const auto* info = child_node(n, "info")) {
      for (auto [key, value] : {std::pair{"sizeX", &s.width}, std::pair{"sizeY", &s.height}}) {
        const char* text = attr_text(info, key);
        if (text && !parse_trimmed_int(text, *value))
          fail("stream " + std::to_string(id) + " " + key + " \"" + escape_non_utf8(text) +
               "\" is not an integer");
      }
      if (const char* src = attr_text(info, "source")) s.source = escape_non_utf8(src);
    }
    if (!streams.emplace(id, std::move(s)).second)
      fail("stream id " + std::to_string(id) + " is declared twice");
  }
  if (streams.empty()) fail("declares no streams");
  return streams;
}

// ---- decompression -----------------------------------------------------------------------

/// Decodes one LZ4 or Zstd frame into a reusable, grow-only buffer, never past
/// kAedat4MaxPacketBytes. A frame that declares its content size gets a buffer of exactly that
/// size (refused before allocating when above the limit); one that does not is decoded in steps
/// into a buffer that doubles up to the limit.
class Decompressor {
 public:
  Decompressor() {
    if (LZ4F_isError(LZ4F_createDecompressionContext(&lz4_, LZ4F_VERSION))) throw std::bad_alloc();
    zstd_ = ZSTD_createDCtx();
    if (!zstd_ ||
        ZSTD_isError(ZSTD_DCtx_setParameter(zstd_, ZSTD_d_windowLogMax, kMaxZstdWindowLog))) {
      ZSTD_freeDCtx(zstd_);
      LZ4F_freeDecompressionContext(lz4_);
      throw std::bad_alloc();
    }
  }
  ~Decompressor() {
    LZ4F_freeDecompressionContext(lz4_);
    ZSTD_freeDCtx(zstd_);
  }
  Decompressor(const Decompressor&) = delete;
  Decompressor& operator=(const Decompressor&) = delete;

  /// Decodes the frame in [in, in + in_len) into out[0, n). Returns nullptr on success, else a
  /// fixed reason phrase.
  const char* run(Compression c, const std::uint8_t* in, std::size_t in_len,
                  std::vector<std::uint8_t>& out, std::size_t& n) {
    n = 0;
    if (c == Compression::kZstd || c == Compression::kZstdHigh) return zstd(in, in_len, out, n);
    const char* why = lz4(in, in_len, out, n);
    if (why) {
      // A frame left unfinished leaves state that LZ4F_resetDecompressionContext does not clear
      // (liblz4 1.9.4: the remaining content size of a frame that declared one, which then fails
      // the next frame that does not): start the next packet from a new context.
      LZ4F_freeDecompressionContext(lz4_);
      lz4_ = nullptr;
      if (LZ4F_isError(LZ4F_createDecompressionContext(&lz4_, LZ4F_VERSION))) throw std::bad_alloc();
    }
    return why;
  }

 private:
  /// Makes out hold at least `size` bytes without copying what it held (nothing of it is kept).
  static void fresh(std::vector<std::uint8_t>& out, std::size_t size) {
    if (out.size() >= size) return;
    out.clear();
    out.resize(size);
  }
  /// Size to start with when the frame does not declare its content size.
  static std::size_t first_guess(std::size_t in_len) {
    return std::min(kAedat4MaxPacketBytes, std::max<std::size_t>(1 << 16, 4 * in_len));
  }
  /// Doubles out (keeping out[0, n)); false at the limit.
  static bool grow(std::vector<std::uint8_t>& out) {
    if (out.size() >= kAedat4MaxPacketBytes) return false;
    out.resize(std::min(kAedat4MaxPacketBytes, 2 * out.size()));
    return true;
  }

  const char* lz4(const std::uint8_t* in, std::size_t in_len, std::vector<std::uint8_t>& out,
                  std::size_t& n) {
    constexpr const char* kCorrupt = "corrupt compressed packet (LZ4 frame does not decode)";
    LZ4F_resetDecompressionContext(lz4_);
    LZ4F_frameInfo_t frame{};
    std::size_t consumed = in_len;
    if (LZ4F_isError(LZ4F_getFrameInfo(lz4_, &frame, in, &consumed))) return kCorrupt;
    if (frame.contentSize > kAedat4MaxPacketBytes) return kPacketTooLarge;
    fresh(out, frame.contentSize > 0 ? static_cast<std::size_t>(frame.contentSize)
                                     : first_guess(in_len));
    for (;;) {
      std::size_t produced = out.size() - n, taken = in_len - consumed;
      const std::size_t hint =
          LZ4F_decompress(lz4_, out.data() + n, &produced, in + consumed, &taken, nullptr);
      if (LZ4F_isError(hint)) return kCorrupt;
      n += produced;
      consumed += taken;
      if (hint == 0)
        return consumed == in_len ? nullptr
                                  : "corrupt compressed packet (bytes after the LZ4 frame)";
      if (produced == 0 && taken == 0) {
        if (n < out.size()) return "corrupt compressed packet (LZ4 frame ends early)";
        if (!grow(out)) return kPacketTooLarge;
      }
    }
  }

  const char* zstd(const std::uint8_t* in, std::size_t in_len, std::vector<std::uint8_t>& out,
                   std::size_t& n) {
    constexpr const char* kCorrupt = "corrupt compressed packet (Zstd frame does not decode)";
    const unsigned long long declared = ZSTD_getFrameContentSize(in, in_len);
    if (declared == ZSTD_CONTENTSIZE_ERROR) return kCorrupt;
    if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared > kAedat4MaxPacketBytes)
      return kPacketTooLarge;
    fresh(out, declared != ZSTD_CONTENTSIZE_UNKNOWN
                   ? std::max<std::size_t>(1, static_cast<std::size_t>(declared))
                   : first_guess(in_len));
    ZSTD_DCtx_reset(zstd_, ZSTD_reset_session_only);
    ZSTD_inBuffer src{in, in_len, 0};
    for (;;) {
      ZSTD_outBuffer dst{out.data() + n, out.size() - n, 0};
      const std::size_t before = src.pos;
      const std::size_t left = ZSTD_decompressStream(zstd_, &dst, &src);
      if (ZSTD_isError(left)) {
        return ZSTD_getErrorCode(left) == ZSTD_error_frameParameter_windowTooLarge
                   ? kPacketTooLarge
                   : kCorrupt;
      }
      n += dst.pos;
      if (left == 0 && src.pos == src.size) return nullptr;
      if (dst.pos == 0 && src.pos == before) {  // no progress: needs room, or more input
        if (n < out.size()) return "corrupt compressed packet (Zstd frame ends early)";
        if (!grow(out)) return kPacketTooLarge;
      }
    }
  }

  LZ4F_dctx* lz4_ = nullptr;
  ZSTD_DCtx* zstd_ = nullptr;
};

/// Moves the unconsumed tail [pos, end) of a hand-out buffer to its front.
template <typename T>
void compact(std::vector<T>& v, std::size_t& pos) {
  if (pos == 0) return;
  v.erase(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(pos));
  pos = 0;
}

// ---- the reader --------------------------------------------------------------------------

class Aedat4Reader final : public RecordingReader {
 public:
  Aedat4Reader(std::unique_ptr<std::istream> in, const std::string& name,
               const ReaderOptions& options)
      : path_(name), options_(options), in_(std::move(in)) {
    if (!in_ || !*in_) throw InputError(name, "", "cannot open");
    in_->seekg(0, std::ios::end);
    const std::streamoff end = in_->tellg();
    in_->seekg(0);
    if (!*in_ || end < 0) throw InputError(name, "", "cannot read (not a seekable file)");
    file_size_ = static_cast<std::uint64_t>(end);
    read_header();
    refresh_notes();
  }

  const RecordingInfo& info() const override { return info_; }
  const ReadReport& report() const override { return report_; }

  bool read(SensorChunk& chunk) override {
    chunk.clear();
    const std::size_t want = std::max<std::size_t>(1, options_.chunk_events);
    compact(pending_events_, event_pos_);
    compact(pending_imu_, imu_pos_);
    while (!eof_ && pending_events_.size() < want && pending_imu_.size() < kMaxPendingImu)
      read_packet();

    const std::size_t n = std::min(want, pending_events_.size());
    chunk.events.assign(pending_events_.begin(),
                        pending_events_.begin() + static_cast<std::ptrdiff_t>(n));
    event_pos_ = n;
    if (n > 0) last_event_out_ = chunk.events.back().t;

    // IMU follows the events: samples up to the last event handed out (all once the events are
    // exhausted), and the oldest ones regardless when too many wait.
    const bool events_done = eof_ && event_pos_ == pending_events_.size();
    const TimeNs horizon = events_done ? std::numeric_limits<TimeNs>::max() : last_event_out_;
    while (imu_pos_ < pending_imu_.size() && (pending_imu_[imu_pos_].t <= horizon ||
                                              pending_imu_.size() - imu_pos_ >= kMaxPendingImu))
      chunk.imu.push_back(pending_imu_[imu_pos_++]);

    refresh_notes();
    return !chunk.empty();
  }

 private:
  // -- header --

  void read_header() {
    char magic[kAedat4Magic.size()] = {};
    in_->read(magic, sizeof magic);
    const auto got = static_cast<std::size_t>(in_->gcount());
    if (got < sizeof magic && std::memcmp(magic, kAedat4Magic.data(), got) == 0)
      throw InputError(path_, at_byte(got), "truncated header: the file ends inside the magic");
    if (std::memcmp(magic, kAedat4Magic.data(), sizeof magic) != 0)
      throw InputError(path_, at_byte(0), "wrong magic (expected \"#!AER-DAT4.0\\r\\n\")");

    char prefix[4];
    in_->read(prefix, 4);
    if (in_->gcount() != 4)
      throw InputError(path_, at_byte(kHeaderAt),
                       "truncated header: the file ends before the IOHeader size");
    const std::uint32_t size = load_u32(prefix);
    if (size < 8 || size > kMaxIoHeaderBytes)
      throw InputError(path_, at_byte(kHeaderAt),
                       "IOHeader size " + std::to_string(size) + " is not plausible");
    if (kHeaderAt + 4 + size > file_size_)
      throw InputError(path_, at_byte(kHeaderAt),
                       "truncated header: the IOHeader of " + std::to_string(size) +
                           " bytes runs past the end of the file (" + std::to_string(file_size_) +
                           " bytes)");
    std::vector<std::uint8_t> header(4 + std::size_t{size});
    std::memcpy(header.data(), prefix, 4);
    in_->read(reinterpret_cast<char*>(header.data() + 4), size);
    if (in_->gcount() != static_cast<std::streamsize>(size))
      throw InputError(path_, at_byte(kHeaderAt + 4), "read error in the IOHeader");

    flatbuffers::Verifier verifier(header.data(), header.size());
    if (!aedat4::fb::VerifySizePrefixedIOHeaderBuffer(verifier))
      throw InputError(path_, at_byte(kHeaderAt),
                       "IOHeader is not a valid FlatBuffer with identifier IOHE");
    const auto* h = aedat4::fb::GetSizePrefixedIOHeader(header.data());
    const auto c = static_cast<int>(h->compression());
    if (c < 0 || c > 4)
      throw InputError(path_, at_byte(kHeaderAt), "unknown compression " + std::to_string(c));
    compression_ = static_cast<Compression>(c);
    data_table_at_ = h->data_table_position();
    if (!h->info_node())
      throw InputError(path_, at_byte(kHeaderAt), "IOHeader has no stream description (infoNode)");
    streams_ = parse_streams(h->info_node()->c_str(), h->info_node()->size(), path_);
    offset_ = stream_at_ = kHeaderAt + 4 + size;

    info_.path = path_;
    info_.format = "aedat4";
    for (auto& [id, s] : streams_) {
      if (s.type_id == "EVTS" && events_id_ < 0) {
        if (s.width <= 0 || s.height <= 0 || s.width > 65535 || s.height > 65535)
          throw InputError(path_, at_byte(kHeaderAt),
                           "events stream " + std::to_string(id) +
                               " has no valid sensor size (sizeX/sizeY) in its info node");
        events_id_ = id;
        info_.width = s.width;
        info_.height = s.height;
        info_.streams.push_back(StreamKind::kEvents);
      } else if (s.type_id == "IMUS" && imu_id_ < 0) {
        imu_id_ = id;
        info_.streams.push_back(StreamKind::kImu);
      }
    }
    sanitizer_.emplace(info_.width, info_.height);

    base_notes_.push_back(std::string("compression: ") + to_string(compression_));
    if (events_id_ >= 0) {
      const auto& s = streams_[events_id_];
      base_notes_.push_back("events: stream " + std::to_string(events_id_) + ", " +
                            std::to_string(s.width) + "x" + std::to_string(s.height) +
                            (s.source.empty() ? "" : ", source " + s.source));
    }
    if (imu_id_ >= 0)
      base_notes_.push_back("imu: stream " + std::to_string(imu_id_) +
                            " (accelerometer g -> m/s^2, gyroscope deg/s -> rad/s)");
  }

  void refresh_notes() {
    info_.notes = base_notes_;
    for (const auto& [id, s] : streams_) {
      if (s.skipped_packets == 0) continue;
      std::string what;
      if (s.type_id == "FRME")
        what = "frames";
      else if (s.type_id == "TRIG")
        what = "triggers";
      else
        what = "stream " + std::to_string(id) + " (" + s.type_id + ")";
      info_.notes.push_back(what + ": " + std::to_string(s.skipped_packets) + " packets skipped");
    }
  }

  // -- packets --

  /// Reads the packet at offset_ and appends what it holds to the pending buffers.
  void read_packet() {
    const std::uint64_t at = offset_;
    const std::uint64_t left = file_size_ - at;
    const bool at_data_table =
        data_table_at_ >= 0 && static_cast<std::uint64_t>(data_table_at_) == at;
    if (left == 0) {
      eof_ = true;
      return;
    }
    if (left < kPacketHeaderBytes) {
      if (!at_data_table)
        report_.drop("truncated packet header at the end of the file", at_byte(at));
      eof_ = true;
      return;
    }
    char head[kPacketHeaderBytes];
    if (stream_at_ != at) in_->seekg(static_cast<std::streamoff>(at));  // after a skipped payload
    in_->read(head, sizeof head);
    stream_at_ = at + kPacketHeaderBytes;
    if (in_->gcount() != static_cast<std::streamsize>(sizeof head)) {  // the file shrank under us
      report_.drop("read error", at_byte(at));
      eof_ = true;
      return;
    }
    std::int32_t id, size;
    std::memcpy(&id, head, 4);
    std::memcpy(&size, head + 4, 4);
    const auto it = streams_.find(id);
    const bool fits = size >= 0 && static_cast<std::uint64_t>(size) <= left - kPacketHeaderBytes;
    // A valid packet wins over the header's index position; the index is only recognised where
    // the bytes are not a packet, so a damaged dataTablePosition cannot hide data.
    if ((!fits || it == streams_.end()) && at_data_table) {
      eof_ = true;
      return;
    }
    if (!fits) {
      report_.drop(size < 0 ? "packet header with a negative size (rest of the file unreadable)"
                            : "packet runs past the end of the file (truncated file)",
                   at_byte(at));
      eof_ = true;
      return;
    }
    offset_ = at + kPacketHeaderBytes + static_cast<std::uint64_t>(size);
    if (it == streams_.end()) {
      report_.drop("packet with a stream id not in the header", at_byte(at));
      return;
    }
    if (id != events_id_ && id != imu_id_) {
      ++it->second.skipped_packets;
      return;
    }

    const std::size_t stored_limit =
        compression_ == Compression::kNone ? kAedat4MaxPacketBytes : kMaxStoredPacketBytes;
    if (static_cast<std::size_t>(size) > stored_limit) {  // skipped unread
      report_.drop(compression_ == Compression::kNone ? "packet larger than the 64 MiB limit"
                                                      : "stored packet larger than the 64 MiB limit",
                   at_byte(at));
      return;
    }
    payload_.resize(static_cast<std::size_t>(size));
    in_->read(reinterpret_cast<char*>(payload_.data()), size);
    stream_at_ += static_cast<std::uint64_t>(size);
    if (in_->gcount() != size) {  // the file shrank under us
      report_.drop("read error", at_byte(at));
      eof_ = true;
      return;
    }
    const std::uint8_t* data = payload_.data();
    std::size_t len = payload_.size();
    if (compression_ != Compression::kNone) {
      std::size_t inflated_len = 0;
      if (const char* why = decompressor_.run(compression_, payload_.data(), payload_.size(),
                                              inflated_, inflated_len)) {
        // A packet that inflates past the limit is no camera's: a decompression bomb is refused
        // as a whole file, not skipped (docs/FORMATS.md "Bad input"). Other damage is a drop.
        if (why == kPacketTooLarge)
          throw InputError(path_, "packet at " + at_byte(at), std::string(kPacketTooLarge) +
                                                                  " (a decompression bomb or a damaged file)");
        report_.drop(why, at_byte(at));
        return;
      }
      data = inflated_.data();
      len = inflated_len;
    }
    flatbuffers::Verifier verifier(data, len);
    if (id == events_id_) {
      if (!aedat4::fb::VerifySizePrefixedEventPacketBuffer(verifier)) {
        report_.drop("events packet is not a valid EVTS FlatBuffer", at_byte(at));
        return;
      }
      decode_events(*aedat4::fb::GetSizePrefixedEventPacket(data), at);
    } else {
      if (!aedat4::fb::VerifySizePrefixedImuPacketBuffer(verifier)) {
        report_.drop("imu packet is not a valid IMUS FlatBuffer", at_byte(at));
        return;
      }
      decode_imu(*aedat4::fb::GetSizePrefixedImuPacket(data), at);
    }
  }

  void decode_events(const aedat4::fb::EventPacket& packet, std::uint64_t at) {
    const auto* elements = packet.elements();
    if (!elements || elements->size() == 0) return;
    raw_.resize(elements->size());
    index_.resize(elements->size());
    std::size_t k = 0, i = 0;
    std::uint64_t out_of_range = 0;
    std::size_t first_out_of_range = 0;
    for (const aedat4::fb::Event* e : *elements) {
      const std::int64_t t_us = e->timestamp_us();
      if (t_us > kMaxTimeUs || t_us < -kMaxTimeUs) {
        if (out_of_range++ == 0) first_out_of_range = i;
        ++i;
        continue;
      }
      index_[k] = i++;
      Event& r = raw_[k++];
      r.t = t_us * kNsPerUs;
      // int16 -> uint16: a negative coordinate becomes >= 32768, outside any sensor, and is
      // dropped by the sanitizer.
      r.x = static_cast<std::uint16_t>(e->x());
      r.y = static_cast<std::uint16_t>(e->y());
      r.polarity = e->polarity();
    }
    const auto where = [&](std::size_t element) { return at_byte(at) + ", event " + std::to_string(element); };
    if (out_of_range) report_.drop("event timestamp out of range", where(first_out_of_range), out_of_range);
    sanitizer_->append(raw_.data(), raw_.data() + k, pending_events_, report_,
                       [&](std::size_t j) { return where(index_[j]); });
  }

  void decode_imu(const aedat4::fb::ImuPacket& packet, std::uint64_t at) {
    const auto* elements = packet.elements();
    if (!elements) return;
    for (const aedat4::fb::Imu* s : *elements) {
      const std::int64_t t_us = s->timestamp_us();
      const float v[6] = {s->accelerometer_x_g(), s->accelerometer_y_g(), s->accelerometer_z_g(),
                          s->gyroscope_x_deg_s(), s->gyroscope_y_deg_s(), s->gyroscope_z_deg_s()};
      if (t_us > kMaxTimeUs || t_us < -kMaxTimeUs) {
        report_.drop("imu timestamp out of range", at_byte(at));
      } else if (!std::all_of(v, v + 6, [](float x) { return std::isfinite(x); })) {
        report_.drop("imu sample with a non-finite (NaN or infinite) value", at_byte(at));
      } else if (t_us * kNsPerUs < last_imu_t_) {
        report_.drop("imu timestamp went backwards", at_byte(at));
      } else {
        ImuSample& out = pending_imu_.emplace_back();
        out.t = last_imu_t_ = t_us * kNsPerUs;
        out.accel_m_s2 = Eigen::Vector3d(v[0], v[1], v[2]) * kAedat4Gravity_m_s2;
        out.gyro_rad_s = Eigen::Vector3d(v[3], v[4], v[5]) * kAedat4RadPerDeg;
      }
    }
  }

  std::string path_;
  ReaderOptions options_;
  RecordingInfo info_;
  std::vector<std::string> base_notes_;
  ReadReport report_;
  std::unique_ptr<std::istream> in_;
  std::uint64_t file_size_ = 0;
  std::uint64_t offset_ = 0;     ///< next packet header
  std::uint64_t stream_at_ = 0;  ///< where in_ stands (saves a seek per packet)
  bool eof_ = false;
  Compression compression_ = Compression::kNone;
  std::int64_t data_table_at_ = -1;
  std::map<std::int32_t, StreamDesc> streams_;
  std::int32_t events_id_ = -1, imu_id_ = -1;

  Decompressor decompressor_;
  std::vector<std::uint8_t> payload_, inflated_;
  std::vector<Event> raw_;
  std::vector<std::size_t> index_;  ///< raw_[k] is element index_[k] of its packet
  std::optional<EventSanitizer> sanitizer_;
  std::vector<Event> pending_events_;
  std::size_t event_pos_ = 0;
  std::vector<ImuSample> pending_imu_;
  std::size_t imu_pos_ = 0;
  TimeNs last_event_out_ = std::numeric_limits<TimeNs>::min();
  TimeNs last_imu_t_ = std::numeric_limits<TimeNs>::min();
};

}  // namespace

std::unique_ptr<RecordingReader> open_aedat4(std::unique_ptr<std::istream> in,
                                             const std::string& name,
                                             const ReaderOptions& options) {
  return std::make_unique<Aedat4Reader>(std::move(in), name, options);
}

std::unique_ptr<RecordingReader> open_aedat4(const std::string& path,
                                             const ReaderOptions& options) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a folder, not a file");
  auto in = std::make_unique<std::ifstream>(path, std::ios::binary);
  if (!*in) throw InputError(path, "", "cannot open");
  return open_aedat4(std::move(in), path, options);
}

}  // namespace fdv
