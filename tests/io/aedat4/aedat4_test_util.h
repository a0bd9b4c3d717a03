#pragma once
// Test-only tools for AEDAT 4.0, independent of the reader under test:
//  - IndependentDecode: walks a file's packets by hand, decompresses with LZ4 / Zstd directly and
//    reads the FlatBuffers by raw offsets (no generated schema code, no XML parser);
//  - Aedat4Synthesizer: synthesises small files byte by byte with FlatBuffers' generic builder;
//  - read_all: what a reader under test hands out, gathered.
#include <flatbuffers/flatbuffers.h>
#include <lz4frame.h>
#include <lz4hc.h>
#include <zstd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "fdv/io/recording.h"

namespace fdv::test::aedat4 {

/// Everything a reader handed out, and its report and info once exhausted.
struct Result {
  std::vector<Event> events;
  std::vector<ImuSample> imu;
  ReadReport report;
  RecordingInfo info;
};

inline Result read_all(std::unique_ptr<RecordingReader> reader) {
  Result r;
  SensorChunk chunk;
  while (reader->read(chunk)) {
    r.events.insert(r.events.end(), chunk.events.begin(), chunk.events.end());
    r.imu.insert(r.imu.end(), chunk.imu.begin(), chunk.imu.end());
  }
  r.report = reader->report();
  r.info = reader->info();
  return r;
}

using Bytes = std::vector<std::uint8_t>;

inline Bytes read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}
inline void write_bytes(const std::string& path, const Bytes& b) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

template <typename T>
T load(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// ---- independent decoder -------------------------------------------------------------------

struct RawEvent {
  std::int64_t t_us;
  std::int16_t x, y;
  bool polarity;
};
struct RawImu {
  std::int64_t t_us;
  float accel_g[3];
  float gyro_deg_s[3];
};
struct RawPacket {
  std::uint64_t offset;  // of the packet header
  std::int32_t stream_id;
  std::int32_t size;                             // payload bytes
  std::string identifier;                        // of the decompressed FlatBuffer, e.g. "EVTS"
  std::size_t first_event = 0, event_count = 0;  // into RawFile::events (EVTS only)
  std::size_t first_imu = 0, imu_count = 0;      // into RawFile::imu (IMUS only)
};
struct RawFile {
  int compression = -1;
  std::int64_t data_table_position = -1;
  std::string info_xml;
  std::uint64_t packets_begin = 0;
  std::vector<RawPacket> packets;
  std::vector<RawEvent> events;
  std::vector<RawImu> imu;
};

/// Position of field `index` of the table at `table` (0 when absent); `b` = FlatBuffer start.
inline std::size_t field_at(const std::uint8_t* b, std::size_t table, int index) {
  const std::size_t vtable = table - static_cast<std::size_t>(load<std::int32_t>(b + table));
  const std::uint16_t vtable_bytes = load<std::uint16_t>(b + vtable);
  const std::size_t slot = 4 + 2 * static_cast<std::size_t>(index);
  if (slot + 2 > vtable_bytes) return 0;
  const std::uint16_t o = load<std::uint16_t>(b + vtable + slot);
  return o ? table + o : 0;
}
inline std::size_t deref(const std::uint8_t* b, std::size_t at) {
  return at + load<std::uint32_t>(b + at);
}

inline Bytes decompress(int compression, const std::uint8_t* p, std::size_t n) {
  if (compression == 0) return Bytes(p, p + n);
  Bytes out;
  if (compression == 1 || compression == 2) {
    LZ4F_dctx* ctx = nullptr;
    LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION);
    std::size_t in_pos = 0;
    std::uint8_t buf[1 << 16];
    for (;;) {
      std::size_t dst = sizeof buf, src = n - in_pos;
      const std::size_t r = LZ4F_decompress(ctx, buf, &dst, p + in_pos, &src, nullptr);
      if (LZ4F_isError(r)) {
        LZ4F_freeDecompressionContext(ctx);
        throw std::runtime_error("independent decoder: LZ4 error");
      }
      out.insert(out.end(), buf, buf + dst);
      in_pos += src;
      if (r == 0) break;
      if (dst == 0 && src == 0) {
        LZ4F_freeDecompressionContext(ctx);
        throw std::runtime_error("independent decoder: LZ4 frame truncated");
      }
    }
    LZ4F_freeDecompressionContext(ctx);
    return out;
  }
  const unsigned long long size = ZSTD_getFrameContentSize(p, n);
  if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN)
    throw std::runtime_error("independent decoder: Zstd frame without content size");
  out.resize(size);
  if (ZSTD_isError(ZSTD_decompress(out.data(), out.size(), p, n)))
    throw std::runtime_error("independent decoder: Zstd error");
  return out;
}

/// Walks the packets from the end of the header to the data table (or the end of the file),
/// stopping before a packet that does not fit in the file.
inline RawFile independent_decode(const Bytes& f) {
  RawFile r;
  const std::uint8_t* h = f.data() + 18;  // IOHeader FlatBuffer, after magic and size prefix
  const std::size_t root = load<std::uint32_t>(h);
  if (std::size_t a = field_at(h, root, 0))
    r.compression = load<std::int32_t>(h + a);
  else
    r.compression = 0;
  if (std::size_t a = field_at(h, root, 1)) r.data_table_position = load<std::int64_t>(h + a);
  if (std::size_t a = field_at(h, root, 2)) {
    const std::size_t s = deref(h, a);
    r.info_xml.assign(reinterpret_cast<const char*>(h + s + 4), load<std::uint32_t>(h + s));
  }
  std::uint64_t off = 18 + load<std::uint32_t>(f.data() + 14);
  r.packets_begin = off;
  std::uint64_t end = f.size();
  if (r.data_table_position > 0)
    end = std::min<std::uint64_t>(end, static_cast<std::uint64_t>(r.data_table_position));
  while (off + 8 <= end) {
    RawPacket p;
    p.offset = off;
    p.stream_id = load<std::int32_t>(f.data() + off);
    p.size = load<std::int32_t>(f.data() + off + 4);
    if (p.size < 0 || off + 8 + static_cast<std::uint64_t>(p.size) > end) break;
    const Bytes u = decompress(r.compression, f.data() + off + 8, static_cast<std::size_t>(p.size));
    const std::uint8_t* b = u.data() + 4;  // past the size prefix
    p.identifier.assign(reinterpret_cast<const char*>(b + 4), 4);
    // EVTS and IMUS: field 0 of the root table is the vector of elements (other types differ).
    const bool has_elements = p.identifier == "EVTS" || p.identifier == "IMUS";
    const std::size_t table = deref(b, 0);
    const std::size_t vec_field = has_elements ? field_at(b, table, 0) : 0;
    const std::size_t vec = vec_field ? deref(b, vec_field) : 0;
    const std::uint32_t count = vec ? load<std::uint32_t>(b + vec) : 0;
    if (p.identifier == "EVTS") {
      p.first_event = r.events.size();
      p.event_count = count;
      for (std::uint32_t i = 0; i < count; ++i) {
        const std::uint8_t* e = b + vec + 4 + 16 * static_cast<std::size_t>(i);
        r.events.push_back({load<std::int64_t>(e), load<std::int16_t>(e + 8),
                            load<std::int16_t>(e + 10), e[12] != 0});
      }
    } else if (p.identifier == "IMUS") {
      p.first_imu = r.imu.size();
      p.imu_count = count;
      for (std::uint32_t i = 0; i < count; ++i) {
        const std::size_t s = deref(b, vec + 4 + 4 * static_cast<std::size_t>(i));
        RawImu m{};
        if (std::size_t a = field_at(b, s, 0)) m.t_us = load<std::int64_t>(b + a);
        for (int k = 0; k < 3; ++k) {
          if (std::size_t a = field_at(b, s, 2 + k)) m.accel_g[k] = load<float>(b + a);
          if (std::size_t a = field_at(b, s, 5 + k)) m.gyro_deg_s[k] = load<float>(b + a);
        }
        r.imu.push_back(m);
      }
    }
    r.packets.push_back(p);
    off += 8 + static_cast<std::uint64_t>(p.size);
  }
  return r;
}

// ---- writer for synthesised files ----------------------------------------------------------

struct TestStream {
  int id;
  std::string type;  // "EVTS", "IMUS", "FRME", "TRIG"
  int width = 0, height = 0;
};

inline std::string info_xml(const std::vector<TestStream>& streams) {
  std::string x = "<dv version=\"2.0\">\n<node name=\"outInfo\" path=\"/outInfo/\">\n";
  for (const auto& s : streams) {
    x += "<node name=\"" + std::to_string(s.id) + "\" path=\"/outInfo/" + std::to_string(s.id) +
         "/\">\n<attr key=\"compression\" type=\"string\">X</attr>\n"
         "<attr key=\"typeIdentifier\" type=\"string\">" +
         s.type + "</attr>\n";
    x += "<node name=\"info\" path=\"/outInfo/" + std::to_string(s.id) + "/info/\">\n";
    if (s.width > 0)
      x += "<attr key=\"sizeX\" type=\"int\">" + std::to_string(s.width) +
           "</attr>\n<attr key=\"sizeY\" type=\"int\">" + std::to_string(s.height) + "</attr>\n";
    x += "<attr key=\"source\" type=\"string\">TEST_CAMERA</attr>\n</node>\n</node>\n";
  }
  return x + "</node>\n</dv>\n";
}

inline Bytes finished(flatbuffers::FlatBufferBuilder& fbb) {
  return Bytes(fbb.GetBufferPointer(), fbb.GetBufferPointer() + fbb.GetSize());
}

/// Size-prefixed IOHeader: fields compression (slot 4), dataTablePosition (6), infoNode (8).
inline Bytes io_header(int compression, std::int64_t data_table_position, const std::string& xml) {
  flatbuffers::FlatBufferBuilder fbb;
  fbb.ForceDefaults(true);
  const auto info = fbb.CreateString(xml);
  const auto start = fbb.StartTable();
  fbb.AddElement<std::int64_t>(6, data_table_position, -1);
  fbb.AddOffset(8, info);
  fbb.AddElement<std::int32_t>(4, compression, 0);
  fbb.FinishSizePrefixed(flatbuffers::Offset<flatbuffers::Table>(fbb.EndTable(start)), "IOHE");
  return finished(fbb);
}

struct alignas(8) TestEvent {
  std::int64_t t_us;
  std::int16_t x, y;
  std::uint8_t polarity;
  std::uint8_t pad[3] = {0, 0, 0};
};
static_assert(sizeof(TestEvent) == 16);

inline Bytes events_payload(const std::vector<TestEvent>& events) {
  flatbuffers::FlatBufferBuilder fbb;
  const auto vec = fbb.CreateVectorOfStructs(events.data(), events.size());
  const auto start = fbb.StartTable();
  fbb.AddOffset(4, vec);
  fbb.FinishSizePrefixed(flatbuffers::Offset<flatbuffers::Table>(fbb.EndTable(start)), "EVTS");
  return finished(fbb);
}

struct TestImu {
  std::int64_t t_us;
  float accel_g[3];
  float gyro_deg_s[3];
};

inline Bytes imu_payload(const std::vector<TestImu>& samples) {
  flatbuffers::FlatBufferBuilder fbb;
  fbb.ForceDefaults(true);
  std::vector<flatbuffers::Offset<flatbuffers::Table>> tables;
  for (const auto& s : samples) {
    const auto start = fbb.StartTable();
    fbb.AddElement<std::int64_t>(4, s.t_us, 0);
    fbb.AddElement<float>(6, 25.0f, 0.0f);  // temperature
    for (int k = 0; k < 3; ++k) {
      fbb.AddElement<float>(static_cast<flatbuffers::voffset_t>(8 + 2 * k), s.accel_g[k], 0.0f);
      fbb.AddElement<float>(static_cast<flatbuffers::voffset_t>(14 + 2 * k), s.gyro_deg_s[k], 0.0f);
      fbb.AddElement<float>(static_cast<flatbuffers::voffset_t>(20 + 2 * k), 1.0f,
                            0.0f);  // magnetometer
    }
    tables.emplace_back(fbb.EndTable(start));
  }
  const auto vec = fbb.CreateVector(tables);
  const auto start = fbb.StartTable();
  fbb.AddOffset(4, vec);
  fbb.FinishSizePrefixed(flatbuffers::Offset<flatbuffers::Table>(fbb.EndTable(start)), "IMUS");
  return finished(fbb);
}

inline Bytes compress(int compression, const Bytes& in) {
  if (compression == 0) return in;
  if (compression == 1 || compression == 2) {
    LZ4F_preferences_t prefs{};
    prefs.compressionLevel = compression == 2 ? LZ4HC_CLEVEL_MAX : 0;
    Bytes out(LZ4F_compressFrameBound(in.size(), &prefs));
    const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
    if (LZ4F_isError(n)) throw std::runtime_error("test writer: LZ4 error");
    out.resize(n);
    return out;
  }
  Bytes out(ZSTD_compressBound(in.size()));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), in.data(), in.size(),
                                      compression == 4 ? ZSTD_maxCLevel() : 3);
  if (ZSTD_isError(n)) throw std::runtime_error("test writer: Zstd error");
  out.resize(n);
  return out;
}

/// Builds a file: magic, IOHeader, packets, optional trailing data-table bytes.
class Aedat4Synthesizer {
 public:
  Aedat4Synthesizer(int compression, std::vector<TestStream> streams)
      : compression_(compression), streams_(std::move(streams)) {}
  /// Appends a packet; returns its offset relative to the end of the header.
  std::size_t packet(std::int32_t stream_id, const Bytes& flatbuffer) {
    return raw_packet(stream_id, compress(compression_, flatbuffer));
  }
  std::size_t raw_packet(std::int32_t stream_id, const Bytes& payload) {
    const std::size_t at = body_.size();
    append_i32(stream_id);
    append_i32(static_cast<std::int32_t>(payload.size()));
    body_.insert(body_.end(), payload.begin(), payload.end());
    return at;
  }
  /// The file; `table` bytes are appended after the packets. `table_position`: -2 = the real
  /// position of the table, otherwise written as given (e.g. -1 or a wrong value).
  Bytes file(const Bytes& table = {}, std::int64_t table_position = -1) const {
    const std::string xml = info_xml(streams_);
    const std::size_t header_bytes = io_header(compression_, 1, xml).size();
    const std::int64_t begin = 14 + static_cast<std::int64_t>(header_bytes);
    if (table_position == -2) table_position = begin + static_cast<std::int64_t>(body_.size());
    Bytes f = {'#', '!', 'A', 'E', 'R', '-', 'D', 'A', 'T', '4', '.', '0', '\r', '\n'};
    const Bytes h = io_header(compression_, table_position, xml);
    f.insert(f.end(), h.begin(), h.end());
    f.insert(f.end(), body_.begin(), body_.end());
    f.insert(f.end(), table.begin(), table.end());
    return f;
  }
  std::size_t header_end() const {
    return 14 + io_header(compression_, 1, info_xml(streams_)).size();
  }

 private:
  void append_i32(std::int32_t v) {
    std::uint8_t b[4];
    std::memcpy(b, &v, 4);
    body_.insert(body_.end(), b, b + 4);
  }
  int compression_;
  std::vector<TestStream> streams_;
  Bytes body_;
};

}  // namespace fdv::test::aedat4
