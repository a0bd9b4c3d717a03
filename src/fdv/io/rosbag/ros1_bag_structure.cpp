#include "fdv/io/rosbag/ros1_bag_structure.h"

#include <bzlib.h>
#include <roslz4/lz4s.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

namespace fdv::bag {
namespace {

constexpr std::uint8_t kOpMessageData = 0x02, kOpBagHeader = 0x03, kOpIndexData = 0x04,
                       kOpChunk = 0x05, kOpChunkInfo = 0x06, kOpConnection = 0x07;
constexpr std::uint64_t kMagicSize = 13;  // "#ROSBAG V2.0\n"
/// No record header of a well-formed bag comes near this (they hold a few short fields); a larger
/// length is damage, and is not allocated.
constexpr std::uint32_t kMaxHeaderLength = 1u << 20;
/// Likewise for a connection record's data (its connection header: type, MD5 sum, message
/// definition): a damaged length above this is not allocated.
constexpr std::uint32_t kMaxConnectionDataLength = 16u << 20;
/// Connections (topic and publisher pairs) in the index; real bags have tens to hundreds.
/// rosbag::View matches each connection against the ranges it has so far, time quadratic in
/// their number: 4096 connections of one topic take about a second.
constexpr std::uint32_t kMaxConnections = 4096;
/// A chunk's records once decompressed. rosbag closes a chunk once it passes 768 KiB (its
/// default), so a chunk is that plus one message; 128 MiB leaves room for large images while
/// the check's buffer, the library's (it decompresses the chunk again) and one message copied
/// out stay well under 1 GB however small the compressed chunk is.
constexpr std::uint32_t kMaxChunkSize = 128u << 20;

using Fields = std::map<std::string, std::string>;

/// Header fields from bytes [p, p + n): each a uint32 length then "name=value". False when a
/// field runs past the end or has no '=' (ros::Header::parse would read past its buffer, or fail).
bool parse_fields(const std::uint8_t* p, std::size_t n, Fields& out) {
  out.clear();
  std::size_t o = 0;
  while (o < n) {
    if (n - o < 4) return false;
    std::uint32_t len = 0;
    std::memcpy(&len, p + o, 4);
    o += 4;
    if (len > n - o) return false;
    const char* f = reinterpret_cast<const char*>(p + o);
    const void* eq = std::memchr(f, '=', len);
    if (!eq) return false;
    const auto k = static_cast<std::size_t>(static_cast<const char*>(eq) - f);
    out[std::string(f, k)] = std::string(f + k + 1, len - k - 1);
    o += len;
  }
  return true;
}

/// A fixed-size little-endian field; nothing when missing or of another size.
template <class T>
std::optional<T> field(const Fields& f, const char* name) {
  const auto it = f.find(name);
  if (it == f.end() || it->second.size() != sizeof(T)) return std::nullopt;
  T v;
  std::memcpy(&v, it->second.data(), sizeof(T));
  return v;
}

/// ROS time as stored: uint32 sec, then uint32 nsec.
TimeNs ros_time_ns(std::uint64_t v) {
  return static_cast<TimeNs>(v & 0xFFFFFFFFu) * 1'000'000'000 + static_cast<TimeNs>(v >> 32);
}

/// One record: its header's fields and where its data lies (in the file, or in a chunk's records).
struct Record {
  Fields fields;
  std::uint8_t op = 0;
  std::uint64_t data_pos = 0;
  std::uint32_t data_len = 0;
  std::uint64_t end = 0;  ///< first byte after the record
};

/// Parses the record at `pos` of bytes that end at `size`, read through `read(pos, dst, n)`.
/// Returns the reason when it does not fit.
template <class Read>
std::optional<std::string> parse_record(std::uint64_t pos, std::uint64_t size, Read read,
                                        Record& r) {
  std::uint32_t header_len = 0;
  if (pos > size || size - pos < 4) return "record cut short (no header length)";
  read(pos, &header_len, 4);
  if (header_len > kMaxHeaderLength || header_len > size - pos - 4)
    return "record header length " + std::to_string(header_len) + " runs past the end";
  if (header_len == 0) return "record header is empty (no `op` field)";
  std::vector<std::uint8_t> header(header_len);
  read(pos + 4, header.data(), header_len);
  if (!parse_fields(header.data(), header.size(), r.fields))
    return "record header fields do not fit in its header (a length runs past it, or a field has "
           "no '=')";
  const auto op = field<std::uint8_t>(r.fields, "op");
  if (!op) return "record header has no one-byte `op` field";
  r.op = *op;
  r.data_pos = pos + 4 + header_len + 4;
  if (r.data_pos > size) return "record cut short (no data length)";
  read(pos + 4 + header_len, &r.data_len, 4);
  if (r.data_len > size - r.data_pos)
    return "record data length " + std::to_string(r.data_len) + " runs past the end";
  r.end = r.data_pos + r.data_len;
  return std::nullopt;
}

std::string op_name(std::uint8_t op) {
  switch (op) {
    case kOpMessageData:
      return "message data";
    case kOpBagHeader:
      return "bag header";
    case kOpIndexData:
      return "index data";
    case kOpChunk:
      return "chunk";
    case kOpChunkInfo:
      return "chunk info";
    case kOpConnection:
      return "connection";
    default:
      return "unknown op " + std::to_string(op);
  }
}

class BagFile {
 public:
  BagFile(const std::string& path, const std::string& name)
      : path_(name), in_(path, std::ios::binary) {
    std::error_code ec;
    size_ = std::filesystem::file_size(path, ec);
    if (ec || !in_) throw InputError(name, "", "cannot read the file: " + ec.message());
  }

  std::uint64_t size() const { return size_; }

  void read(std::uint64_t pos, void* dst, std::size_t n) {
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(pos));
    in_.read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
    if (!in_) fail(pos, "cannot read " + std::to_string(n) + " bytes");
  }

  /// The record at `pos`, which must be of kind `op`; `what` names it in the error.
  Record record(std::uint64_t pos, std::uint8_t op, const std::string& what) {
    Record r;
    const auto reason = parse_record(
        pos, size_, [&](std::uint64_t p, void* dst, std::size_t n) { read(p, dst, n); }, r);
    if (reason) fail(pos, what + ": " + *reason);
    if (r.op != op) fail(pos, what + ": a " + op_name(r.op) + " record is there instead");
    return r;
  }

  template <class T>
  T required(const Record& r, std::uint64_t pos, const char* name, const std::string& what) {
    const auto v = field<T>(r.fields, name);
    if (!v) fail(pos, what + ": no " + std::to_string(sizeof(T)) + "-byte `" + name + "` field");
    return *v;
  }

  [[noreturn]] void fail(std::uint64_t pos, const std::string& reason) const {
    throw InputError(path_, "byte " + std::to_string(pos),
                     reason + ": the bag is truncated or damaged; `rosbag reindex` may recover it");
  }

 private:
  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
};

}  // namespace

Ros1BagStructure::Ros1BagStructure(const std::string& path, const std::string& name)
    : path_(path), name_(name.empty() ? path : name) {
  BagFile f(path, name_);
  const Record header = f.record(kMagicSize, kOpBagHeader, "bag header record");
  const auto index_pos =
      f.required<std::uint64_t>(header, kMagicSize, "index_pos", "bag header record");
  const auto conn_count =
      f.required<std::uint32_t>(header, kMagicSize, "conn_count", "bag header record");
  const auto chunk_count =
      f.required<std::uint32_t>(header, kMagicSize, "chunk_count", "bag header record");
  if (index_pos == 0) return;                          // unindexed: the library reports it
  if (index_pos < header.end || index_pos > f.size())  // = size: a bag without connections
    f.fail(kMagicSize, "bag header record: index_pos " + std::to_string(index_pos) +
                           " is outside the file's records");

  if (conn_count > kMaxConnections)
    throw InputError(name_, "byte " + std::to_string(kMagicSize),
                     "bag header record: conn_count " + std::to_string(conn_count) +
                         " is above the reader's limit of " + std::to_string(kMaxConnections) +
                         " connections");

  // The index section: connection records, then chunk info records.
  std::set<std::uint32_t> connections;
  std::uint64_t pos = index_pos;
  Fields connection_header;
  for (std::uint32_t i = 0; i < conn_count; ++i) {
    const Record r = f.record(pos, kOpConnection, "connection record");
    const auto conn = f.required<std::uint32_t>(r, pos, "conn", "connection record");
    connections.insert(conn);
    const auto topic = r.fields.find("topic");
    if (topic == r.fields.end()) f.fail(pos, "connection record: no `topic` field");
    if (r.data_len > kMaxConnectionDataLength)
      f.fail(pos, "connection record: data length " + std::to_string(r.data_len) +
                      " is implausible (> 16 MiB)");
    std::vector<std::uint8_t> data(r.data_len);
    f.read(r.data_pos, data.data(), data.size());
    if (!parse_fields(data.data(), data.size(), connection_header))
      f.fail(pos, "connection record: its connection header's fields do not fit in it");
    // As the library keeps it: the first record of an id.
    connections_.emplace(
        conn, Connection{topic->second, connection_header["type"], connection_header["md5sum"]});
    pos = r.end;
  }
  struct Info {
    std::uint64_t at, chunk_pos;
    TimeNs start, end;
    std::set<std::uint32_t> connections;
  };
  std::vector<Info> infos;
  for (std::uint32_t i = 0; i < chunk_count; ++i) {
    const Record r = f.record(pos, kOpChunkInfo, "chunk info record");
    const std::string what = "chunk info record";
    if (f.required<std::uint32_t>(r, pos, "ver", what) != 1)
      f.fail(pos, what + ": version is not 1");
    Info info{pos,
              f.required<std::uint64_t>(r, pos, "chunk_pos", what),
              ros_time_ns(f.required<std::uint64_t>(r, pos, "start_time", what)),
              ros_time_ns(f.required<std::uint64_t>(r, pos, "end_time", what)),
              {}};
    const auto count = f.required<std::uint32_t>(r, pos, "count", what);
    if (r.data_len != 8ull * count)
      f.fail(pos, what + ": data length is not 8 bytes per connection");
    std::vector<std::uint32_t> pairs(2 * static_cast<std::size_t>(count));
    f.read(r.data_pos, pairs.data(), r.data_len);
    for (std::uint32_t k = 0; k < count; ++k) {
      if (!connections.count(pairs[2 * k]))
        f.fail(pos, what + ": names connection " + std::to_string(pairs[2 * k]) +
                        ", which the bag does not define");
      info.connections.insert(pairs[2 * k]);
    }
    if (info.chunk_pos < header.end || info.chunk_pos >= index_pos)
      f.fail(pos,
             what + ": chunk_pos " + std::to_string(info.chunk_pos) + " is outside the chunk area");
    if (info.start > info.end) f.fail(pos, what + ": start_time after end_time");
    infos.push_back(std::move(info));
    pos = r.end;
  }

  // Each chunk's header, then one index data record per connection in it.
  for (const Info& info : infos) {
    Chunk c;
    c.pos = info.chunk_pos;
    c.start = info.start;
    c.end = info.end;
    const Record r = f.record(c.pos, kOpChunk, "chunk record");
    const auto compression = r.fields.find("compression");
    if (compression == r.fields.end() ||
        (compression->second != "none" && compression->second != "bz2" &&
         compression->second != "lz4"))
      f.fail(c.pos, "chunk record: compression is missing or not none, bz2 or lz4");
    c.compression = compression->second;
    c.size = f.required<std::uint32_t>(r, c.pos, "size", "chunk record");
    if (c.size > kMaxChunkSize)
      f.fail(c.pos, "chunk record: size " + std::to_string(c.size) + " is implausible (> " +
                        std::to_string(kMaxChunkSize >> 20) + " MiB)");
    if (c.compression == "none" && c.size != r.data_len)
      f.fail(c.pos, "chunk record: uncompressed, but its size field differs from its data length");
    c.data_pos = r.data_pos;
    c.data_len = r.data_len;
    std::uint64_t at = r.end;
    for (std::size_t k = 0; k < info.connections.size(); ++k) {
      const Record ix = f.record(at, kOpIndexData, "index data record");
      const std::string what = "index data record";
      if (f.required<std::uint32_t>(ix, at, "ver", what) != 1)
        f.fail(at, what + ": version is not 1");
      const auto conn = f.required<std::uint32_t>(ix, at, "conn", what);
      if (!info.connections.count(conn))
        f.fail(at, what + ": connection " + std::to_string(conn) +
                       " is not in its chunk's info record");
      const auto count = f.required<std::uint32_t>(ix, at, "count", what);
      if (ix.data_len != 12ull * count)
        f.fail(at, what + ": data length is not 12 bytes per message");
      ConnectionStats& s = stats_[conn];
      std::vector<std::uint8_t> entries(ix.data_len);
      f.read(ix.data_pos, entries.data(), entries.size());
      for (std::uint32_t m = 0; m < count; ++m) {
        std::uint64_t t = 0;
        std::uint32_t offset = 0;
        std::memcpy(&t, entries.data() + 12 * static_cast<std::size_t>(m), 8);
        std::memcpy(&offset, entries.data() + 12 * static_cast<std::size_t>(m) + 8, 4);
        // Times inside the chunk's span: the reader checks a chunk before the first message
        // whose time reaches the chunk's start (Ros1BagReader).
        const TimeNs tn = ros_time_ns(t);
        if (tn < c.start || tn > c.end)
          f.fail(at, what + ": a message time lies outside its chunk's start and end times");
        if (offset >= c.size) f.fail(at, what + ": a message offset lies past its chunk's records");
        c.message_offsets.push_back(offset);
        s.first = s.count == 0 ? tn : std::min(s.first, tn);
        s.last = s.count == 0 ? tn : std::max(s.last, tn);
        ++s.count;
      }
      at = ix.end;
    }
    std::sort(c.message_offsets.begin(), c.message_offsets.end());
    chunks_.push_back(std::move(c));
  }
  std::stable_sort(chunks_.begin(), chunks_.end(),
                   [](const Chunk& a, const Chunk& b) { return a.start < b.start; });
}

std::optional<InputError> Ros1BagStructure::check_records(std::size_t i) const {
  const Chunk& c = chunks_.at(i);
  const auto error = [&](std::uint64_t pos, const std::string& reason) {
    return InputError(name_, "byte " + std::to_string(pos), reason);
  };
  std::vector<char> packed(c.data_len);
  {
    std::ifstream in(path_, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(c.data_pos));
    in.read(packed.data(), static_cast<std::streamsize>(packed.size()));
    if (!in) return error(c.data_pos, "chunk records cannot be read");
  }
  std::vector<char> records;
  if (c.compression == "none") {
    records = std::move(packed);
  } else {
    records.resize(c.size);
    unsigned int n = c.size;
    const bool ok = c.compression == "bz2"
                        ? BZ2_bzBuffToBuffDecompress(records.data(), &n, packed.data(), c.data_len,
                                                     0, 0) == BZ_OK
                        : roslz4_buffToBuffDecompress(packed.data(), c.data_len, records.data(),
                                                      &n) == ROSLZ4_OK;
    if (!ok || n != c.size)
      return error(c.pos, "chunk (" + c.compression + ") does not decompress to its size field's " +
                              std::to_string(c.size) + " bytes");
  }
  // Where a record of the chunk is: its byte in the file, or its offset in the decompressed data.
  const auto where = [&](std::uint64_t offset) {
    return c.compression == "none" ? c.data_pos + offset : c.pos;
  };
  const auto in_chunk = [&](std::uint64_t offset) {
    return c.compression == "none"
               ? std::string()
               : " (offset " + std::to_string(offset) + " of the decompressed chunk)";
  };
  const auto read = [&](std::uint64_t p, void* dst, std::size_t n) {
    std::memcpy(dst, records.data() + p, n);
  };
  std::vector<std::uint32_t> messages;
  Fields connection_header;
  for (std::uint64_t o = 0; o < records.size();) {
    Record r;
    if (const auto reason = parse_record(o, records.size(), read, r))
      return error(where(o), "record in a chunk" + in_chunk(o) + ": " + *reason);
    if (r.op == kOpMessageData) {
      if (!field<std::uint32_t>(r.fields, "conn") || !field<std::uint64_t>(r.fields, "time"))
        return error(where(o), "message data record" + in_chunk(o) +
                                   ": no 4-byte `conn` or 8-byte `time` field");
      messages.push_back(static_cast<std::uint32_t>(o));
    } else if (r.op == kOpConnection) {
      if (!parse_fields(reinterpret_cast<const std::uint8_t*>(records.data()) + r.data_pos,
                        r.data_len, connection_header))
        return error(where(o), "connection record" + in_chunk(o) +
                                   ": its connection header's fields do not fit in it");
    } else {
      return error(where(o), "a " + op_name(r.op) + " record inside a chunk" + in_chunk(o));
    }
    o = r.end;
  }
  for (const std::uint32_t offset : c.message_offsets)
    if (!std::binary_search(messages.begin(), messages.end(), offset))
      return error(where(offset), "the index places a message" + in_chunk(offset) +
                                      " where no message data record of its chunk starts");
  return std::nullopt;
}

}  // namespace fdv::bag
