#pragma once
/// ROS bags as recordings, with no ROS installation running (docs/FORMATS.md, "ROS 1 bags" and
/// "ROS 2 bags"):
///
///   fdv::ReaderOptions options;
///   options.events_topic = "/dvs/events";        // optional: empty = chosen by message type
///   auto reader = fdv::open_ros1_bag("run.bag", options);   // or fdv::open_recording(...)
///   fdv::SensorChunk chunk;
///   while (reader->read(chunk)) { /* events, imu, depth, odometry, ground_truth */ }
///   reader->info().topics;   // every topic: type, message count, rate
///
/// ROS 1 `.bag` files (format 2.0) are read with Debian's rosbag storage library; ROS 2 bags
/// with SQLite (`.db3`, or the bag folder with metadata.yaml). Messages are decoded from their
/// serialized bytes by this module (ROS 1 serialization, CDR), so no message package is needed;
/// for ROS 1 each selected topic's MD5 sum must match the definition decoded here.
///
/// Streaming: messages are read one at a time in bag (receive) time order and handed out in
/// chunks of about ReaderOptions::chunk_events events, with the IMU / depth / odometry / ground
/// truth messages that came in between. Times: events from their own stamps (or, for event
/// packets, their encoding's rules); every other message from header.stamp (0 -> bag time,
/// counted). Not thread-safe.
#include <memory>
#include <string>
#include <string_view>

#include "fdv/io/recording.h"

namespace fdv {

/// The first bytes of a ROS 1 bag (format version 2.0).
inline constexpr std::string_view kRos1BagMagic = "#ROSBAG V2.0\n";
/// The first bytes of every SQLite 3 database (ROS 2's default bag storage).
inline constexpr std::string_view kSqliteMagic{"SQLite format 3\0", 16};

/// Opens a ROS 1 bag. Throws InputError for a file that is not a v2.0 bag, a truncated or
/// unindexed bag (with the hint to run `rosbag reindex`), a requested topic that is missing or
/// of the wrong type, or an MD5 sum that differs from the definition decoded here.
std::unique_ptr<RecordingReader> open_ros1_bag(const std::string& path,
                                               const ReaderOptions& options = {});

/// Opens a ROS 2 bag: a `.db3` file, or a bag folder (metadata.yaml and its .db3 files, read in
/// order). Throws InputError for a file that is not an SQLite database, a database without the
/// ROS 2 bag tables, MCAP storage (not supported: Debian ships no MCAP library), or a requested
/// topic that is missing or of the wrong type.
std::unique_ptr<RecordingReader> open_ros2_bag(const std::string& path,
                                               const ReaderOptions& options = {});

/// Opens a ROS 2 bag `.db3` file given as its bytes (for fuzzing and in-memory use): the same
/// reader as open_ros2_bag on a file, with SQLite reading the image in place, read-only
/// (sqlite3_deserialize). `name` stands for the file in errors and in info().path.
std::unique_ptr<RecordingReader> open_ros2_bag_bytes(std::string bytes, const std::string& name,
                                                     const ReaderOptions& options = {});

/// Opens a ROS 1 bag given as its bytes: the same reader as open_ros1_bag. Debian's rosbag
/// storage library opens bags by path only, so the bytes are written to an anonymous memory
/// file (memfd_create) that the reader reads as /proc/self/fd/N and closes when destroyed; no
/// disk file and no state is left between calls. `name` stands for the file in errors and in
/// info().path.
std::unique_ptr<RecordingReader> open_ros1_bag_bytes(const std::string& bytes,
                                                     const std::string& name,
                                                     const ReaderOptions& options = {});

/// True when `dir` is a ROS 2 bag folder (metadata.yaml beside at least one .db3 or .mcap file).
bool is_ros2_bag_folder(const std::string& dir);

}  // namespace fdv
