#pragma once
/// The record structure of a ROS 1 bag (format 2.0), checked before Debian's rosbag storage
/// library reads it. The library trusts every length and offset in the file (ros::Header::parse,
/// Bag::readHeaderFromBuffer): one damaged byte can make it read past its buffers and crash.
/// Internal to src/fdv/io/rosbag (docs/FORMATS.md, "ROS 1 bags").
///
/// Format (ROS wiki, Bags/Format/2.0): after the 13-byte magic, records of
///   uint32 header_len, header (fields: uint32 len, "name=value"), uint32 data_len, data;
/// the header's `op` field gives the kind: bag header 0x03, chunk 0x05, connection 0x07, chunk
/// info 0x06, index data 0x04, message data 0x02 (inside chunks, with connection records).
/// Thread safety: const methods may be called concurrently once built.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/core/time.h"

namespace fdv::bag {

class Ros1BagStructure {
 public:
  struct Chunk {
    std::uint64_t pos = 0;       ///< byte of the chunk record
    TimeNs start = 0, end = 0;   ///< its messages' time span (chunk info record)
    std::string compression;     ///< none, bz2 or lz4
    std::uint32_t size = 0;      ///< size of its records once decompressed
    std::uint64_t data_pos = 0;  ///< byte of its (compressed) records
    std::uint32_t data_len = 0;
    /// Where its index records place messages: offsets into the decompressed records.
    std::vector<std::uint32_t> message_offsets;
  };

  /// Reads what the library reads when it opens the bag: the bag header record, the index
  /// section (connection and chunk info records) and, for each chunk, its header and the index
  /// records that follow it. Throws InputError (file, byte, reason) on any length, field or
  /// reference that does not fit. An unindexed bag (index_pos 0) is left to the library, which
  /// says so (no chunks listed). Errors name `name` (default: the path) as the file.
  explicit Ros1BagStructure(const std::string& path, const std::string& name = "");

  /// A connection record of the index section: the record's topic, and its connection header's
  /// type and md5sum (empty when missing), as the library reads them.
  struct Connection {
    std::string topic, type, md5sum;
  };
  /// What the index data records say of one connection's messages.
  struct ConnectionStats {
    std::uint64_t count = 0;
    TimeNs first = 0, last = 0;  ///< earliest and latest message time (when count > 0)
  };

  /// Chunks by start time.
  const std::vector<Chunk>& chunks() const { return chunks_; }
  /// Per connection id, from the index the library reads too: the topic listing takes counts
  /// and spans from here (one rosbag::View per topic costs time in the number of connections,
  /// quadratic over a bag of many topics).
  const std::map<std::uint32_t, ConnectionStats>& connection_stats() const { return stats_; }
  /// Per connection id. The reader lists topics and checks types from here rather than from a
  /// rosbag::View of the whole bag, whose construction is quadratic in the connections.
  const std::map<std::uint32_t, Connection>& connections() const { return connections_; }

  /// Reads and decompresses chunk i and walks its records: every record inside the chunk, each a
  /// message data or connection record, every index offset on a message data record. The reason
  /// (as an InputError naming the byte) when not.
  std::optional<InputError> check_records(std::size_t i) const;

 private:
  std::string path_, name_;
  std::vector<Chunk> chunks_;
  std::map<std::uint32_t, ConnectionStats> stats_;
  std::map<std::uint32_t, Connection> connections_;
};

}  // namespace fdv::bag
