// ROS 2 bag reader: the two real bags (checked by a separate, deliberately plain decoder in this
// file and by the checksums event_camera_codecs publishes for the same files), and synthetic
// bags whose messages are serialized by eProsima Fast CDR (ROS 2's own middleware serializer).
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>

#include "fdv/core/error.h"
#include "fdv/io/recording.h"
#include "fdv/io/rosbag/rosbag_reader.h"
#include "test_support.h"

namespace fdv {
namespace {

namespace fs = std::filesystem;

// ------------------------------------------------------------------------------------------
// A plain, separate decoder for the real bags: rows fetched with SQLite, the EventPacket CDR
// walked with explicit offsets, the two encodings decoded the simplest way.

struct PlainPacket {
  TimeNs stamp = 0;
  std::uint32_t height = 0, width = 0;
  std::uint64_t time_base = 0;
  std::string encoding;
  std::vector<std::uint8_t> events;
};

std::vector<PlainPacket> plain_packets(const std::string& path) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* q = nullptr;
  EXPECT_EQ(
      sqlite3_prepare_v2(db, "SELECT data FROM messages ORDER BY timestamp, id", -1, &q, nullptr),
      SQLITE_OK);
  std::vector<PlainPacket> out;
  while (sqlite3_step(q) == SQLITE_ROW) {
    const auto* blob = static_cast<const std::uint8_t*>(sqlite3_column_blob(q, 0));
    const std::uint8_t* p = blob + 4;  // CDR little endian: payload after 00 01 00 00
    EXPECT_EQ(blob[1], 1);
    std::size_t o = 0;
    auto align = [&](std::size_t n) { o = (o + n - 1) / n * n; };
    auto u32 = [&] {
      std::uint32_t v;
      std::memcpy(&v, p + o, 4);
      o += 4;
      return v;
    };
    auto u64 = [&] {
      std::uint64_t v;
      std::memcpy(&v, p + o, 8);
      o += 8;
      return v;
    };
    PlainPacket pk;
    const std::int32_t sec = static_cast<std::int32_t>(u32());
    const std::uint32_t nsec = u32();
    pk.stamp = TimeNs{sec} * 1'000'000'000 + nsec;
    o += u32();  // frame_id
    align(4);
    pk.height = u32();
    pk.width = u32();
    align(8);
    (void)u64();  // seq
    pk.time_base = u64();
    const std::uint32_t len = u32();
    pk.encoding.assign(reinterpret_cast<const char*>(p + o), len - 1);
    o += len;
    o += 1;  // is_bigendian
    align(4);
    const std::uint32_t n = u32();
    pk.events.assign(p + o, p + o + n);
    out.push_back(std::move(pk));
  }
  sqlite3_finalize(q);
  sqlite3_close(db);
  return out;
}

/// libcaer: 8-byte records, t = time_base + ts us; ts going down inside a packet = rollover.
std::vector<Event> plain_libcaer(const std::vector<PlainPacket>& packets) {
  std::vector<Event> out;
  for (const auto& pk : packets) {
    std::uint64_t high = pk.time_base;
    std::int32_t last = 0;
    for (std::size_t i = 0; i + 8 <= pk.events.size(); i += 8) {
      std::uint32_t data;
      std::int32_t ts;
      std::memcpy(&data, pk.events.data() + i, 4);
      std::memcpy(&ts, pk.events.data() + i + 4, 4);
      if (ts < last) high += (std::uint64_t{1} << 31) * 1000;
      last = ts;
      out.push_back({static_cast<TimeNs>(high + static_cast<std::uint64_t>(ts) * 1000),
                     static_cast<std::uint16_t>(data >> 17),
                     static_cast<std::uint16_t>((data >> 2) & 0x7FFF), ((data >> 1) & 1) != 0});
    }
  }
  return out;
}

/// EVT 3.0 words, following Prophesee's format description: events count once a TIME_HIGH and
/// then a TIME_LOW have been seen; t in sensor microseconds.
struct PlainEvt3 {
  std::vector<Event> events;  // t in sensor us x 1000
  int triggers = 0;
};
PlainEvt3 plain_evt3(const std::vector<PlainPacket>& packets) {
  PlainEvt3 out;
  int high = -1, low = -1;
  std::uint16_t y = 0, base = 0;
  bool pol = false;
  for (const auto& pk : packets) {
    for (std::size_t i = 0; i + 2 <= pk.events.size(); i += 2) {
      const unsigned w = pk.events[i] | (pk.events[i + 1] << 8);
      const unsigned type = w >> 12;
      const bool timed = high >= 0 && low >= 0;
      const TimeNs t = (TimeNs{high} * 4096 + low) * 1000;
      auto emit = [&](unsigned x, bool p) {
        if (timed && x < pk.width && y < pk.height)
          out.events.push_back({t, static_cast<std::uint16_t>(x), y, p});
      };
      if (type == 0x8) high = static_cast<int>(w & 0xFFF), low = high >= 0 && low >= 0 ? low : -1;
      if (type == 0x6 && high >= 0) low = static_cast<int>(w & 0xFFF);
      if (type == 0x0) y = static_cast<std::uint16_t>(w & 0x7FF);
      if (type == 0x2) emit(w & 0x7FF, (w >> 11) & 1);
      if (type == 0x3) base = static_cast<std::uint16_t>(w & 0x7FF), pol = (w >> 11) & 1;
      if (type == 0x4 || type == 0x5) {
        const unsigned bits = type == 0x4 ? 12 : 8;
        for (unsigned b = 0; b < bits; ++b)
          if ((w >> b) & 1) emit(base + b, pol);
        base = static_cast<std::uint16_t>(base + bits);
      }
      if (type == 0xA) ++out.triggers;
    }
  }
  return out;
}

std::vector<Event> read_events(RecordingReader& reader) {
  std::vector<Event> all;
  SensorChunk chunk;
  while (reader.read(chunk)) all.insert(all.end(), chunk.events.begin(), chunk.events.end());
  return all;
}

struct Sums {
  std::uint64_t t = 0, x = 0, y = 0, on = 0;
};
Sums sums(const std::vector<Event>& events, TimeNs offset = 0) {
  Sums s;
  for (const auto& e : events) {
    s.t += static_cast<std::uint64_t>(e.t - offset);  // wraps mod 2^64 like the published sums
    s.x += e.x;
    s.y += e.y;
    s.on += e.polarity;
  }
  return s;
}

TEST(Ros2BagReal, LibcaerDvxplorerWithTimeCounterRollover) {
  const std::string path = test::real_data("dvxplorer_libcaer_ros2.db3");
  FDV_REQUIRE_REAL_FILE(path);
  auto reader = open_recording(path);
  EXPECT_EQ(reader->info().format, "ros2_bag");
  EXPECT_EQ(reader->info().width, 640);
  EXPECT_EQ(reader->info().height, 480);
  ASSERT_EQ(reader->info().topics.size(), 1u);
  EXPECT_EQ(reader->info().topics[0].topic, "/event_camera/events");
  EXPECT_EQ(reader->info().topics[0].type, "event_camera_msgs/msg/EventPacket");
  EXPECT_EQ(reader->info().topics[0].count, 201u);
  const std::vector<Event> events = read_events(*reader);
  EXPECT_EQ(reader->report().total_dropped(), 0u);

  // Route 1: the plain decoder in this file, event for event.
  const auto packets = plain_packets(path);
  ASSERT_EQ(packets.size(), 201u);
  EXPECT_EQ(events, plain_libcaer(packets));

  // Route 2: event_camera_codecs' own test of this file (test_data_libcaer_rollover,
  // test/decoder_test.cpp): checksums of t (ns, mod 2^64), x, y and ON events, and the first
  // event's time.
  const Sums s = sums(events);
  EXPECT_EQ(s.t, 15762826572202229126ULL);
  EXPECT_EQ(s.x, 111651612u);
  EXPECT_EQ(s.y, 82801007u);
  EXPECT_EQ(s.on, 181908u);
  ASSERT_EQ(events.size(), 334331u);
  EXPECT_EQ(events.front().t, 1702309120762236018);
  EXPECT_EQ(events.back().t, 1702309122762222018);  // span 1.999986 s

  // The rollover: the 31-bit microsecond counter wraps between packets 99 and 100; the driver
  // advanced time_base by exactly 2^31 us, so time runs on without a jump or a step back.
  int jumps = 0;
  for (std::size_t i = 1; i < packets.size(); ++i) {
    if (packets[i].time_base == packets[i - 1].time_base) continue;
    ++jumps;
    EXPECT_EQ(i, 100u);
    EXPECT_EQ(packets[i].time_base - packets[i - 1].time_base, (std::uint64_t{1} << 31) * 1000);
    std::int32_t last_ts, first_ts;
    std::memcpy(&last_ts, packets[i - 1].events.data() + packets[i - 1].events.size() - 4, 4);
    std::memcpy(&first_ts, packets[i].events.data() + 4, 4);
    EXPECT_GT(last_ts, (std::int64_t{1} << 31) - 20'000);  // within 20 ms of the wrap
    EXPECT_LT(first_ts, 20'000);
  }
  EXPECT_EQ(jumps, 1);
  for (std::size_t i = 1; i < events.size(); ++i) ASSERT_GE(events[i].t, events[i - 1].t) << i;
}

TEST(Ros2BagReal, Evt3WithTriggers) {
  const std::string path = test::real_data("evt3_trigger_ros2.db3");
  FDV_REQUIRE_REAL_FILE(path);
  auto reader = open_ros2_bag(path);
  EXPECT_EQ(reader->info().width, 1280);
  EXPECT_EQ(reader->info().height, 720);
  EXPECT_EQ(reader->info().topics.at(0).count, 105u);
  const std::vector<Event> events = read_events(*reader);

  // Sensor time is moved onto the header-stamp clock by one offset fixed at the first packet:
  // its header stamp (sec 0x6349D389, nanosec 0x32D0C0C3 in the first blob's hex dump) minus its
  // first event's sensor time, 14224870 us (decoded by hand from the first words: TIME_HIGH
  // 0xD90, TIME_LOW 0xDE6 -> 0xD90DE6 = 14224870).
  const TimeNs first_stamp = TimeNs{0x6349D389} * 1'000'000'000 + 0x32D0C0C3;
  const TimeNs offset = first_stamp - 14'224'870'000;

  // Route 1: the plain decoder in this file.
  const auto packets = plain_packets(path);
  const PlainEvt3 plain = plain_evt3(packets);
  ASSERT_EQ(events.size(), plain.events.size());
  for (std::size_t i = 0; i < events.size(); ++i) {
    Event e = events[i];
    e.t -= offset;
    ASSERT_EQ(e, plain.events[i]) << i;
  }
  // Route 2: event_camera_codecs' test of this file (test_data_evt3_trigger): checksums of the
  // sensor time in ns, x, y, ON events; and 2 trigger events, which the reader counts as unused.
  const Sums s = sums(events, offset);
  EXPECT_EQ(s.t, 1222326831810000ULL);
  EXPECT_EQ(s.x, 42078718u);
  EXPECT_EQ(s.y, 31656267u);
  EXPECT_EQ(s.on, 41439u);
  EXPECT_EQ(events.size(), 82469u);
  EXPECT_EQ(plain.triggers, 2);
  EXPECT_EQ(reader->report().dropped().at("evt3: external trigger (not used)").count, 2u);
  EXPECT_EQ(reader->report().total_dropped(), 2u);
  EXPECT_EQ(events.front().t, first_stamp);
  EXPECT_EQ(events.back().t - events.front().t, 1'251'317'000);  // 1.251317 s of sensor time
}

// ------------------------------------------------------------------------------------------
// Synthetic bags: rosbag2's sqlite3 schema, messages serialized by Fast CDR.

using Bytes = std::vector<std::uint8_t>;
using eprosima::fastcdr::Cdr;

Bytes cdr(const std::function<void(Cdr&)>& body,
          Cdr::Endianness endianness = Cdr::Endianness::LITTLE_ENDIANNESS) {
  eprosima::fastcdr::FastBuffer buffer;
  Cdr c(buffer, endianness, Cdr::DDS_CDR);
  c.serialize_encapsulation();
  body(c);
  return Bytes(buffer.getBuffer(), buffer.getBuffer() + c.getSerializedDataLength());
}

void header(Cdr& c, TimeNs t) {
  c << static_cast<std::int32_t>(t / 1'000'000'000) << static_cast<std::uint32_t>(t % 1'000'000'000)
    << std::string("frame");
}
void doubles(Cdr& c, std::initializer_list<double> v) {
  for (double d : v) c << d;
}
void zeros(Cdr& c, int n) {
  for (int i = 0; i < n; ++i) c << 0.0;
}

Bytes event_packet(TimeNs stamp, std::uint32_t w, std::uint32_t h, std::uint64_t time_base,
                   const std::string& encoding, const Bytes& events) {
  return cdr([&](Cdr& c) {
    header(c, stamp);
    c << h << w << std::uint64_t{7} << time_base << encoding << false << events;
  });
}

class Db3Writer {
 public:
  explicit Db3Writer(const std::string& path) {
    fs::remove(path);
    EXPECT_EQ(sqlite3_open(path.c_str(), &db_), SQLITE_OK);
    exec("PRAGMA synchronous=OFF; PRAGMA journal_mode=MEMORY;");  // a scratch file: no fsync
    exec(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);"
        "INSERT INTO schema VALUES(3,'humble');"
        "CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,metadata "
        "TEXT NOT NULL);"
        "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
        "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);"
        "CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
        "timestamp INTEGER NOT NULL, data BLOB NOT NULL);"
        "CREATE INDEX timestamp_idx ON messages (timestamp ASC);");
  }
  ~Db3Writer() { sqlite3_close(db_); }
  void exec(const std::string& sql) {
    char* err = nullptr;
    EXPECT_EQ(sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err), SQLITE_OK)
        << (err ? err : "");
    sqlite3_free(err);
  }
  int topic(const std::string& name, const std::string& type) {
    exec("INSERT INTO topics(name,type,serialization_format,offered_qos_profiles) VALUES('" + name +
         "','" + type + "','cdr','')");
    return static_cast<int>(sqlite3_last_insert_rowid(db_));
  }
  void message(int topic_id, TimeNs t, const Bytes& data) {
    sqlite3_stmt* q = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(db_, "INSERT INTO messages(topic_id,timestamp,data) VALUES(?,?,?)",
                                 -1, &q, nullptr),
              SQLITE_OK);
    sqlite3_bind_int(q, 1, topic_id);
    sqlite3_bind_int64(q, 2, t);
    sqlite3_bind_blob(q, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(q), SQLITE_DONE);
    sqlite3_finalize(q);
  }

 private:
  sqlite3* db_ = nullptr;
};

constexpr TimeNs kT0 = 1'700'000'000'000'000'000;

/// libcaer record: valid bit set.
void libcaer_record(Bytes& b, std::uint32_t x, std::uint32_t y, bool on, std::int32_t ts_us) {
  const std::uint32_t data = (x << 17) | (y << 2) | (on ? 2u : 0u) | 1u;
  const std::size_t at = b.size();
  b.resize(at + 8);
  std::memcpy(b.data() + at, &data, 4);
  std::memcpy(b.data() + at + 4, &ts_us, 4);
}

void mono_record(Bytes& b, std::uint64_t x, std::uint64_t y, bool on, std::uint32_t dt_ns) {
  const std::uint64_t w = (std::uint64_t{on} << 63) | (y << 48) | (x << 32) | dt_ns;
  const std::size_t at = b.size();
  b.resize(at + 8);
  std::memcpy(b.data() + at, &w, 8);
}

class Ros2SyntheticTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::scratch_dir("ros2_bag");
    path_ = dir_ + "/synthetic.db3";
    Db3Writer db(path_);
    const int mono = db.topic("/dvs/events", "event_camera_msgs/msg/EventPacket");
    const int caer = db.topic("/caer/events", "event_camera_msgs/msg/EventPacket");
    const int foo = db.topic("/foo/events", "event_camera_msgs/msg/EventPacket");
    const int imu = db.topic("/mavros/imu/data", "sensor_msgs/msg/Imu");
    const int depth = db.topic("/camera/depth/image_rect_raw", "sensor_msgs/msg/Image");
    const int odom = db.topic("/odom", "nav_msgs/msg/Odometry");
    const int vicon = db.topic("/vicon/ball", "geometry_msgs/msg/PoseStamped");
    const int tf = db.topic("/ball_tf", "geometry_msgs/msg/TransformStamped");
    db.topic("/empty", "sensor_msgs/msg/Imu");
    const int pro = db.topic("/prophesee/events", "prophesee_event_msgs/msg/EventArray");
    db.message(pro, kT0 + 700, cdr([&](Cdr& c) {
                 header(c, kT0 + 700);
                 c << std::uint32_t{48} << std::uint32_t{64} << std::uint32_t{2};
                 for (int k = 0; k < 2; ++k)  // Event: x, y, ts {sec, nanosec}, polarity
                   c << static_cast<std::uint16_t>(30 + k) << static_cast<std::uint16_t>(40 + k)
                     << std::int32_t{1'700'000'000} << static_cast<std::uint32_t>(600 + k)
                     << (k == 1);
               }));
    // mono: sensor time base 5 s; two packets.
    Bytes m0, m1;
    mono_record(m0, 10, 20, true, 1'000);
    mono_record(m0, 11, 21, false, 2'000);
    mono_record(m1, 12, 22, true, 500'000);
    db.message(mono, kT0 + 100, event_packet(kT0 + 50, 64, 48, 5'000'000'000, "mono", m0));
    db.message(mono, kT0 + 600'000, event_packet(kT0 + 499'000, 64, 48, 5'000'001'000, "mono", m1));
    // libcaer: the 31-bit counter wraps inside the packet.
    Bytes c0;
    libcaer_record(c0, 1, 2, true, 2'147'483'000);
    libcaer_record(c0, 3, 4, false, 2'147'483'600);
    libcaer_record(c0, 5, 6, true, 100);
    db.message(caer, kT0 + 200,
               event_packet(kT0 + 200, 64, 48, 1'000'000'000'000'000'000, "libcaer", c0));
    db.message(foo, kT0 + 300, event_packet(kT0 + 300, 64, 48, 0, "foo", Bytes(16, 0)));
    // IMU: little endian, then one big-endian message, one truncated blob.
    for (int i = 0; i < 3; ++i)
      db.message(imu, kT0 + 1'000 * i + 5, cdr([&](Cdr& c) {
                   header(c, kT0 + 1'000 * i);
                   doubles(c, {0, 0, 0, 1});
                   zeros(c, 9);
                   doubles(c, {0.1 * i, 0.2, 0.3});
                   zeros(c, 9);
                   doubles(c, {1.0, 2.0, 9.81 + i});
                   zeros(c, 9);
                 }));
    db.message(imu, kT0 + 3'005,
               cdr(
                   [&](Cdr& c) {
                     header(c, kT0 + 3'000);
                     doubles(c, {0, 0, 0, 1});
                     zeros(c, 9);
                     doubles(c, {-1, -2, -3});
                     zeros(c, 9);
                     doubles(c, {4, 5, 6});
                     zeros(c, 9);
                   },
                   Cdr::Endianness::BIG_ENDIANNESS));
    Bytes cut = cdr([&](Cdr& c) {
      header(c, kT0 + 4'000);
      zeros(c, 40);
    });
    cut.resize(30);
    db.message(imu, kT0 + 4'005, cut);
    // Depth: 16UC1 2x2 (mm), 32FC1 2x1 (m).
    db.message(depth, kT0 + 10'000, cdr([&](Cdr& c) {
                 header(c, kT0 + 9'000);
                 c << std::uint32_t{2} << std::uint32_t{2} << std::string("16UC1")
                   << std::uint8_t{0} << std::uint32_t{4}
                   << Bytes{0xE8, 0x03, 0x00, 0x00, 0xD0, 0x07, 0x01, 0x00};
               }));
    db.message(depth, kT0 + 11'000, cdr([&](Cdr& c) {
                 header(c, kT0 + 10'500);
                 float v[2] = {1.25f, NAN};
                 Bytes b(8);
                 std::memcpy(b.data(), v, 8);
                 c << std::uint32_t{1} << std::uint32_t{2} << std::string("32FC1")
                   << std::uint8_t{0} << std::uint32_t{8} << b;
               }));
    // Odometry: 90 degrees about z, body velocity (2, 0, 0) -> (0, 2, 0) in W.
    const double s45 = std::sqrt(0.5);
    db.message(odom, kT0 + 20'000, cdr([&](Cdr& c) {
                 header(c, kT0 + 20'000);
                 c << std::string("base_link");
                 doubles(c, {1, 2, 3, 0, 0, s45, s45});
                 zeros(c, 36);
                 doubles(c, {2, 0, 0, 0.1, 0.2, 0.3});
                 zeros(c, 36);
               }));
    db.message(vicon, kT0 + 30'000, cdr([&](Cdr& c) {
                 header(c, kT0 + 30'000);
                 doubles(c, {4, 5, 6, 0, 0, 0, 1});
               }));
    db.message(tf, kT0 + 40'000, cdr([&](Cdr& c) {
                 header(c, kT0 + 40'000);
                 c << std::string("ball");
                 doubles(c, {7, 8, 9, 0, 0, 0, 1});
               }));
  }
  std::string dir_, path_;
};

SensorChunk read_everything(RecordingReader& reader) {
  SensorChunk all, chunk;
  while (reader.read(chunk)) {
    all.events.insert(all.events.end(), chunk.events.begin(), chunk.events.end());
    all.imu.insert(all.imu.end(), chunk.imu.begin(), chunk.imu.end());
    all.depth.insert(all.depth.end(), chunk.depth.begin(), chunk.depth.end());
    all.odometry.insert(all.odometry.end(), chunk.odometry.begin(), chunk.odometry.end());
    all.ground_truth.insert(all.ground_truth.end(), chunk.ground_truth.begin(),
                            chunk.ground_truth.end());
  }
  return all;
}

TEST_F(Ros2SyntheticTest, DecodesEveryTypeFromFastCdr) {
  auto reader = open_recording(path_);
  const SensorChunk all = read_everything(*reader);
  const auto& r = reader->report();

  // mono on /dvs/events (the paper's name among three event topics): sensor time
  // time_base + dt, moved so the first event lands on its packet's header stamp.
  const TimeNs offset = (kT0 + 50) - (5'000'000'000 + 1'000);
  ASSERT_EQ(all.events.size(), 3u);
  EXPECT_EQ(all.events[0], (Event{5'000'001'000 + offset, 10, 20, true}));
  EXPECT_EQ(all.events[1], (Event{5'000'002'000 + offset, 11, 21, false}));
  EXPECT_EQ(all.events[2], (Event{5'000'001'000 + 500'000 + offset, 12, 22, true}));
  EXPECT_EQ(reader->info().width, 64);
  EXPECT_EQ(reader->info().height, 48);

  ASSERT_EQ(all.imu.size(), 4u);
  EXPECT_EQ(all.imu[2].t, kT0 + 2'000);
  EXPECT_EQ(all.imu[2].gyro_rad_s, Eigen::Vector3d(0.2, 0.2, 0.3));
  EXPECT_EQ(all.imu[2].accel_m_s2, Eigen::Vector3d(1.0, 2.0, 11.81));
  EXPECT_EQ(all.imu[3].gyro_rad_s, Eigen::Vector3d(-1, -2, -3));  // big-endian CDR
  EXPECT_EQ(all.imu[3].accel_m_s2, Eigen::Vector3d(4, 5, 6));
  EXPECT_EQ(r.dropped().at("imu: message truncated").count, 1u);
  EXPECT_EQ(r.dropped().at("imu: message truncated").first_where,
            "/mavros/imu/data messages.id 10");

  ASSERT_EQ(all.depth.size(), 2u);
  EXPECT_EQ(all.depth[0].t, kT0 + 9'000);
  const std::vector<float> mm = {1000, 0, 2000, 1};  // the bytes E8 03, 00 00, D0 07, 01 00
  ASSERT_EQ(all.depth[0].depth_m.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_FLOAT_EQ(all.depth[0].depth_m[i], mm[i] * 1e-3f);
  EXPECT_EQ(all.depth[1].depth_m, (std::vector<float>{1.25f, 0.0f}));

  ASSERT_EQ(all.odometry.size(), 1u);
  EXPECT_EQ(all.odometry[0].p_W_B, Eigen::Vector3d(1, 2, 3));
  EXPECT_NEAR((all.odometry[0].v_W - Eigen::Vector3d(0, 2, 0)).norm(), 0, 1e-12);
  EXPECT_EQ(all.odometry[0].omega_B, Eigen::Vector3d(0.1, 0.2, 0.3));

  ASSERT_EQ(all.ground_truth.size(), 1u);  // the Vicon pose; /ball_tf is not named like mocap
  EXPECT_EQ(all.ground_truth[0].p_W, Eigen::Vector3d(4, 5, 6));

  std::map<std::string, TopicInfo> topics;
  for (const auto& t : reader->info().topics) topics[t.topic] = t;
  EXPECT_EQ(topics.size(), 10u);
  EXPECT_EQ(topics["/mavros/imu/data"].count, 5u);
  EXPECT_NEAR(topics["/mavros/imu/data"].rate_hz, 4 / 4e-6, 1e-3);  // 5 msgs over 4000 ns
  EXPECT_EQ(topics["/empty"].count, 0u);
  EXPECT_EQ(topics["/empty"].type, "sensor_msgs/msg/Imu");
}

TEST_F(Ros2SyntheticTest, LibcaerRolloverInsideAPacket) {
  ReaderOptions options;
  options.events_topic = "/caer/events";
  auto reader = open_ros2_bag(path_, options);
  const SensorChunk all = read_everything(*reader);
  const TimeNs base = 1'000'000'000'000'000'000;
  ASSERT_EQ(all.events.size(), 3u);
  EXPECT_EQ(all.events[0], (Event{base + 2'147'483'000'000, 1, 2, true}));
  EXPECT_EQ(all.events[1], (Event{base + 2'147'483'600'000, 3, 4, false}));
  EXPECT_EQ(all.events[2], (Event{base + (TimeNs{1} << 31) * 1000 + 100'000, 5, 6, true}));
  EXPECT_EQ(
      reader->report().repaired().at("libcaer: time counter rolled over inside a packet").count,
      1u);
}

TEST_F(Ros2SyntheticTest, EventArrayInCdr) {
  ReaderOptions options;
  options.events_topic = "/prophesee/events";
  auto reader = open_ros2_bag(path_, options);
  const SensorChunk all = read_everything(*reader);
  ASSERT_EQ(all.events.size(), 2u);
  EXPECT_EQ(all.events[0], (Event{kT0 + 600, 30, 40, false}));
  EXPECT_EQ(all.events[1], (Event{kT0 + 601, 31, 41, true}));
  EXPECT_EQ(reader->info().width, 64);
}

TEST_F(Ros2SyntheticTest, UnknownEncodingIsDroppedAndCounted) {
  ReaderOptions options;
  options.events_topic = "/foo/events";
  auto reader = open_ros2_bag(path_, options);
  const SensorChunk all = read_everything(*reader);
  EXPECT_TRUE(all.events.empty());
  const auto& drop = reader->report().dropped().at("event packet: unsupported encoding");
  EXPECT_EQ(drop.count, 1u);
  EXPECT_NE(drop.first_where.find("(encoding 'foo')"), std::string::npos) << drop.first_where;
  EXPECT_FALSE(all.imu.empty());  // the rest of the bag is read
}

TEST_F(Ros2SyntheticTest, ExplicitTopicsEmptyTopicAndWrongType) {
  ReaderOptions options;
  options.imu_topic = "/empty";
  options.ground_truth_topic = "/ball_tf";
  auto reader = open_ros2_bag(path_, options);
  const SensorChunk all = read_everything(*reader);
  EXPECT_TRUE(all.imu.empty());
  bool noted = false;
  for (const auto& n : reader->info().notes) noted |= n == "imu topic /empty has no messages";
  EXPECT_TRUE(noted);
  ASSERT_EQ(all.ground_truth.size(), 1u);
  EXPECT_EQ(all.ground_truth[0].p_W, Eigen::Vector3d(7, 8, 9));

  ReaderOptions wrong;
  wrong.depth_topic = "/odom";
  try {
    open_ros2_bag(path_, wrong);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "topic /odom");
    EXPECT_NE(std::string(e.what()).find("nav_msgs/msg/Odometry"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sensor_msgs/msg/Image"), std::string::npos) << e.what();
  }
}

TEST_F(Ros2SyntheticTest, BagFolderWithMetadata) {
  const std::string folder = dir_ + "/run";
  fs::create_directories(folder);
  fs::copy_file(path_, folder + "/run_0.db3");
  std::ofstream(folder + "/metadata.yaml")
      << "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
         "  relative_file_paths:\n    - run_0.db3\n";
  EXPECT_TRUE(is_ros2_bag_folder(folder));
  auto reader = open_ros2_bag(folder);
  EXPECT_EQ(read_everything(*reader).imu.size(), 4u);

  std::ofstream(folder + "/metadata.yaml", std::ios::trunc)
      << "rosbag2_bagfile_information:\n  storage_identifier: mcap\n  relative_file_paths:\n"
         "    - run_0.mcap\n";
  try {
    open_ros2_bag(folder);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where(), "key storage_identifier");
    EXPECT_NE(std::string(e.what()).find("mcap"), std::string::npos) << e.what();
  }
}

std::string error_of(const std::string& path) {
  try {
    open_recording(path);
  } catch (const InputError& e) {
    return std::string(e.where()) + " | " + e.reason();
  }
  return "no error";
}

TEST(Ros2BagBadInput, NotABagDatabase) {
  const std::string dir = test::scratch_dir("ros2_bad");
  // SQLite's magic, then garbage: not a database.
  std::ofstream(dir + "/garbage.db3", std::ios::binary)
      << std::string("SQLite format 3\0", 16) << std::string(200, 'x');
  EXPECT_EQ(error_of(dir + "/garbage.db3"),
            "byte 0 | not an SQLite database (a ROS 2 bag file is one)");
  // A real SQLite database without the bag tables.
  {
    sqlite3* db = nullptr;
    sqlite3_open((dir + "/other.db3").c_str(), &db);
    sqlite3_exec(db, "CREATE TABLE t(x INTEGER)", nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  EXPECT_EQ(error_of(dir + "/other.db3"),
            "table topics | not a ROS 2 bag: the database has no `topics` table");
  {
    sqlite3* db = nullptr;
    sqlite3_open((dir + "/half.db3").c_str(), &db);
    sqlite3_exec(db,
                 "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT, "
                 "serialization_format TEXT)",
                 nullptr, nullptr, nullptr);
    sqlite3_close(db);
  }
  EXPECT_EQ(error_of(dir + "/half.db3"),
            "table messages | not a ROS 2 bag: the database has no `messages` table");
}

TEST(Ros2BagBadInput, RandomCorruptionIsAnInputErrorOrAReadableStream) {
  // Bytes changed anywhere in a real bag (SQLite pages, CDR blobs, event words): the reader either
  // stops with an InputError that names where and why (SQLite's own checks catch damaged pages),
  // or reads on; never another exception or a crash (the sanitizer build runs this too). What
  // it reads keeps the stream contract: pixels inside the sensor, time never going back.
  for (const char* name : {"dvxplorer_libcaer_ros2.db3", "evt3_trigger_ros2.db3"}) {
    const std::string src = test::real_data(name);
    FDV_REQUIRE_REAL_FILE(src);
    std::ifstream in(src, std::ios::binary);
    const std::string f{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    const std::string path = test::scratch_dir("ros2_fuzz") + "/f.db3";
    std::mt19937 rng(20261122);
    // Past SQLite's 100-byte file header; every third trial within the first pages (schema and
    // b-tree pages: most of a bag is message blobs).
    std::uniform_int_distribution<std::size_t> pos(100, f.size() - 1), early(100, 16'383);
    std::uniform_int_distribution<int> byte(0, 255), count(1, 8);
    int errors = 0;
    for (int trial = 0; trial < 30; ++trial) {
      std::string g = f;
      for (int k = count(rng); k > 0; --k)
        g[trial % 3 == 2 ? early(rng) : pos(rng)] = static_cast<char>(byte(rng));
      std::ofstream(path, std::ios::binary | std::ios::trunc) << g;
      std::vector<Event> events;
      int width = 0, height = 0;
      try {
        auto reader = open_recording(path);
        width = reader->info().width;
        height = reader->info().height;
        events = read_events(*reader);
      } catch (const InputError& e) {
        EXPECT_FALSE(std::string(e.reason()).empty()) << name << " trial " << trial;
        ++errors;
        continue;
      } catch (const std::exception& e) {
        ADD_FAILURE() << name << " trial " << trial << ": not an InputError: " << e.what();
        continue;
      }
      for (std::size_t i = 0; i < events.size(); ++i) {
        ASSERT_LT(events[i].x, width) << name << " trial " << trial;
        ASSERT_LT(events[i].y, height) << name << " trial " << trial;
        if (i > 0) {
          ASSERT_GE(events[i].t, events[i - 1].t) << name << " trial " << trial << " event " << i;
        }
      }
    }
    RecordProperty(std::string(name) + "_input_errors", errors);
  }
}

TEST(Ros2BagBadInput, DamagedPageMidFileKeepsWhatWasReadAndReportsTheRest) {
  // The 4-byte "next overflow page" pointer of page 300 of the real bag set to 0xFFFFFFFF: SQLite
  // reports the database malformed when it reaches the message whose blob runs through that page.
  // The reader keeps the messages before it (a prefix of the undamaged stream), counts the rest
  // as one drop naming the last message read, and does not throw.
  const std::string src = test::real_data("dvxplorer_libcaer_ros2.db3");
  FDV_REQUIRE_REAL_FILE(src);
  std::ifstream in(src, std::ios::binary);
  std::string g{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  constexpr std::size_t kPage = 4096;  // PRAGMA page_size of this bag
  g.replace(299 * kPage, 4, "\xFF\xFF\xFF\xFF");
  const std::string path = test::scratch_dir("ros2_damaged") + "/d.db3";
  std::ofstream(path, std::ios::binary) << g;

  const std::vector<Event> full = plain_libcaer(plain_packets(src));
  auto reader = open_recording(path);
  std::vector<Event> events;
  ASSERT_NO_THROW(events = read_events(*reader));
  ASSERT_GT(events.size(), 0u);
  ASSERT_LT(events.size(), full.size());
  EXPECT_TRUE(std::equal(events.begin(), events.end(), full.begin()));
  const auto& dropped = reader->report().dropped();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_EQ(
      dropped.begin()->first,
      "bag database damaged, the rest of the file is unreadable: database disk image is malformed");
  EXPECT_EQ(dropped.begin()->second.count, 1u);
  EXPECT_NE(dropped.begin()->second.first_where.find(path + ": after messages.id "),
            std::string::npos)
      << dropped.begin()->second.first_where;
}

// ------------------------------------------------------------------------------------------
// Hostile input (docs/FORMATS.md, "Bad input"): the fuzz findings, and bags built here to the
// same effect.

constexpr const char* kTimeOverflowDrop =
    "event packet: event time outside the 64-bit nanosecond range";
constexpr TimeNs kMaxTime = std::numeric_limits<TimeNs>::max();

/// A bag of one EventPacket topic, /dvs/events, with the given packets (stamp, time_base,
/// encoding, events bytes).
struct Packet {
  TimeNs stamp;
  std::uint64_t time_base;
  std::string encoding;
  Bytes events;
};
std::string packet_bag(const std::string& name, const std::vector<Packet>& packets) {
  const std::string path = test::scratch_dir("ros2_hostile") + "/" + name;
  Db3Writer db(path);
  const int topic = db.topic("/dvs/events", "event_camera_msgs/msg/EventPacket");
  TimeNs bag_time = kT0;
  for (const auto& p : packets)
    db.message(topic, bag_time++, event_packet(p.stamp, 64, 48, p.time_base, p.encoding, p.events));
  return path;
}

std::uint64_t dropped(const RecordingReader& reader, const std::string& reason) {
  const auto it = reader.report().dropped().find(reason);
  return it == reader.report().dropped().end() ? 0 : it->second.count;
}

TEST(Ros2BagHostile, LibcaerTimeBeyondInt64IsDroppedAndCounted) {
  // time_base 1 ms below the int64 maximum: an event 0.5 ms in is kept, one 2 ms in would wrap.
  // A packet whose time_base itself is above the int64 range loses all its events. A rollover
  // that leaves the range drops the events after it.
  Bytes near, above, roll;
  libcaer_record(near, 1, 1, true, 500);
  libcaer_record(near, 2, 2, true, 2'000);
  libcaer_record(above, 3, 3, true, 10);
  libcaer_record(roll, 4, 4, true, 2'147'483'000);
  libcaer_record(roll, 5, 5, true, 10);  // rolled over: + 2^31 us
  const auto base = [](TimeNs below_max) {
    return static_cast<std::uint64_t>(kMaxTime - below_max);
  };
  const std::string path =
      packet_bag("libcaer.db3", {{kT0, base(1'000'000), "libcaer", near},
                                 {kT0, std::uint64_t{1} << 63, "libcaer", above},
                                 {kT0, base(2'147'483'500'000), "libcaer", roll}});
  auto reader = open_ros2_bag(path);
  const std::vector<Event> events = read_events(*reader);
  // The two that fit in int64 (kMaxTime - 0.5 ms, and 2'147'483'000 us after the third
  // time_base) are beyond valid_time()'s 2^62 ns: corrupt times, dropped by the sanitizer.
  EXPECT_TRUE(events.empty());
  EXPECT_EQ(dropped(*reader, "event time out of range (corrupt)"), 2u);
  // The event 2 ms in, the packet above the range, the event after the rollover.
  EXPECT_EQ(dropped(*reader, kTimeOverflowDrop), 3u);
}

TEST(Ros2BagHostile, MonoTimeBaseAndClockOffsetBeyondInt64AreDroppedAndCounted) {
  Bytes two;
  mono_record(two, 1, 1, true, 0);
  mono_record(two, 2, 2, true, 1'000);
  // Packet 1: time_base above the int64 range (2 events). Packet 2: time_base 10 ns below the
  // int64 maximum, so its second event wraps; the first is near the maximum while the header
  // stamp is far negative, so no offset joins the clocks. Packet 3: anchors (offset kT0 - 1000).
  // Packet 4: a time_base that, moved by that offset, leaves the range for its second event.
  const std::string path = packet_bag(
      "mono.db3",
      {{kT0, std::uint64_t{1} << 63, "mono", two},
       {-2'000'000'000'000'000'000, static_cast<std::uint64_t>(kMaxTime - 10), "mono", two},
       {kT0, 1'000, "mono", two},
       {kT0, static_cast<std::uint64_t>(kMaxTime - kT0 + 500), "mono", two}});
  auto reader = open_ros2_bag(path);
  const std::vector<Event> events = read_events(*reader);
  ASSERT_GE(events.size(), 2u);
  EXPECT_EQ(events[0].t, kT0);
  EXPECT_EQ(events[1].t, kT0 + 1'000);
  for (const auto& e : events) EXPECT_GE(e.t, kT0);
  EXPECT_EQ(dropped(*reader, kTimeOverflowDrop), 2u + 1u + 1u);
  EXPECT_EQ(dropped(*reader,
                    "event packet: sensor time too far from the header stamp to share its clock"),
            1u);
}

TEST(Ros2BagHostile, FuzzFindingsF4EventTimeOverflow) {
  // Each file: no wrapped time reaches the stream; the overflow is counted (or the bag is an
  // InputError naming the file).
  for (const char* name : {"ros2/f4-libcaer-time-base.db3", "ros2/f4-libcaer-time-overflow-1.db3",
                           "ros2/f4-libcaer-time-overflow-2.db3", "ros2/f4-mono-offset.db3",
                           "ros2/f4-mono-time-base.db3"}) {
    const std::string path = test::fuzz_finding(name);
    FDV_REQUIRE_REAL_FILE(path);
    try {
      auto reader = open_recording(path);
      const std::vector<Event> events = read_events(*reader);
      for (std::size_t i = 1; i < events.size(); ++i) ASSERT_GE(events[i].t, events[i - 1].t);
      // A message declaring a side above 4096 is refused whole, before its times are computed.
      const std::uint64_t overflows =
          dropped(*reader, kTimeOverflowDrop) + dropped(*reader, "event time out of range (corrupt)") +
          dropped(*reader, "events: sensor size above the cap 4096") +
          dropped(*reader,
                  "event packet: sensor time too far from the header stamp to share its clock");
      EXPECT_GT(overflows, 0u) << name;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
    }
  }
}

TEST(Ros2BagHostile, TopicSpanBeyondInt64GivesANoteNotAWrappedRate) {
  const std::string path = test::scratch_dir("ros2_hostile") + "/span.db3";
  {
    Db3Writer db(path);
    const int imu = db.topic("/mavros/imu/data", "sensor_msgs/msg/Imu");
    const Bytes msg = cdr([&](Cdr& c) {
      header(c, kT0);
      zeros(c, 4 + 9 + 3 + 9 + 3 + 9);
    });
    db.message(imu, std::numeric_limits<TimeNs>::min() + 1, msg);
    db.message(imu, kMaxTime, msg);
  }
  auto reader = open_ros2_bag(path);
  ASSERT_EQ(reader->info().topics.size(), 1u);
  EXPECT_EQ(reader->info().topics[0].rate_hz, 0.0);
  bool noted = false;
  for (const auto& n : reader->info().notes)
    noted |= n.find("/mavros/imu/data: message timestamps span more than the 64-bit") !=
             std::string::npos;
  EXPECT_TRUE(noted);

  const std::string finding = test::fuzz_finding("ros2/f5-topic-span-overflow.db3");
  FDV_REQUIRE_REAL_FILE(finding);
  auto f5 = open_recording(finding);
  noted = false;
  for (const auto& n : f5->info().notes)
    noted |= n.find("/dvs/events: message timestamps span more than") != std::string::npos;
  EXPECT_TRUE(noted);
}

/// The InputError of opening `path`, as "file | where | reason".
std::string folder_error(const std::string& path) {
  try {
    open_ros2_bag(path);
  } catch (const InputError& e) {
    return e.file() + " | " + e.where() + " | " + e.reason();
  } catch (const std::exception& e) {
    return std::string("foreign exception: ") + e.what();
  }
  return "no error";
}

TEST(Ros2BagHostile, MetadataOfTheWrongShapeIsAnInputErrorNamingTheKey) {
  const std::string finding = test::fuzz_finding("ros2/f9-scalar-metadata-folder");
  FDV_REQUIRE_REAL_FILE(finding);
  EXPECT_EQ(folder_error(finding), finding +
                                       "/metadata.yaml | key rosbag2_bagfile_information | is not "
                                       "a mapping");

  const std::string dir = test::scratch_dir("ros2_metadata");
  {
    Db3Writer db(dir + "/bag_0.db3");
    db.topic("/imu", "sensor_msgs/msg/Imu");
  }
  const std::string meta = dir + "/metadata.yaml";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"just text", " |  | not a YAML mapping (rosbag2 metadata is one)"},
      {"rosbag2_bagfile_information: [1, 2]",
       " | key rosbag2_bagfile_information | is not a mapping"},
      {"rosbag2_bagfile_information: {storage_identifier: [sqlite3]}",
       " | key storage_identifier | is not a text value"},
      {"rosbag2_bagfile_information: {relative_file_paths: bag_0.db3}",
       " | key relative_file_paths | is not a list"},
      {"rosbag2_bagfile_information: {relative_file_paths: [{a: 1}]}",
       " | key relative_file_paths[0] | is not a file name"},
      {"rosbag2_bagfile_information: {relative_file_paths: [[bag_0.db3]]}",
       " | key relative_file_paths[0] | is not a file name"},
      {"rosbag2_bagfile_information: {relative_file_paths: [\"\"]}",
       " | key relative_file_paths[0] | is not a file name"},
  };
  for (const auto& [text, expected] : cases) {
    std::ofstream(meta, std::ios::trunc) << text << "\n";
    EXPECT_EQ(folder_error(dir), meta + expected) << text;
  }
  // Too large to be metadata: refused before yaml-cpp builds its tree.
  std::ofstream(meta, std::ios::trunc) << "# " << std::string(5 << 20, 'x') << "\n";
  EXPECT_EQ(folder_error(dir), meta + " |  | is " + std::to_string((5 << 20) + 3) +
                                   " bytes; a rosbag2 metadata file is at most 4 MiB");
  // A listed file that is not a regular file (a FIFO would block SQLite's open).
  fs::create_directories(dir + "/sub.db3");
  std::ofstream(meta, std::ios::trunc)
      << "rosbag2_bagfile_information: {relative_file_paths: [sub.db3]}\n";
  EXPECT_EQ(
      folder_error(dir),
      dir + "/sub.db3 |  | bag file listed in metadata.yaml is missing or not a regular file");
  // Well-formed metadata still reads.
  std::ofstream(meta, std::ios::trunc)
      << "rosbag2_bagfile_information: {storage_identifier: sqlite3, relative_file_paths: "
         "[bag_0.db3]}\n";
  EXPECT_EQ(folder_error(dir), "no error");
}

TEST(Ros2BagHostile, TextThatIsNotUtf8IsEscapedInTheSummary) {
  // An encoding name and a topic name with bytes that are not UTF-8: the summary (topics,
  // notes, report) must still serialize to JSON, which requires UTF-8.
  const std::string path = test::scratch_dir("ros2_hostile") + "/utf8.db3";
  {
    Db3Writer db(path);
    const int events = db.topic("/dvs/events", "event_camera_msgs/msg/EventPacket");
    const int imu = db.topic("/imu\xFE", "sensor_msgs/msg/Imu");
    db.message(events, kT0,
               event_packet(kT0, 64, 48, 0, std::string("li\xFF") + "caer", Bytes(8, 1)));
    db.message(imu, kT0, cdr([&](Cdr& c) {
                 header(c, kT0);
                 zeros(c, 4 + 9 + 3 + 9 + 3 + 9);
               }));
  }
  auto reader = open_ros2_bag(path);
  read_events(*reader);
  nlohmann::json j;
  j["notes"] = reader->info().notes;
  for (const auto& t : reader->info().topics) j["topics"].push_back({t.topic, t.type});
  j["report"] = reader->report().to_json();
  std::string text;
  ASSERT_NO_THROW(text = j.dump());
  EXPECT_NE(text.find("event encoding: li\\\\xFFcaer"), std::string::npos) << text;
  EXPECT_NE(text.find("/imu\\\\xFE"), std::string::npos) << text;
  // The escaped name is the topic's name for the options too.
  ReaderOptions options;
  options.imu_topic = "/imu\\xFE";
  auto chosen = open_ros2_bag(path, options);
  EXPECT_EQ(read_everything(*chosen).imu.size(), 1u);
}

TEST(Ros2BagHostile, AMessageBeyondTheLengthLimitIsNotAllocated) {
  // A `data` column generated as a 300 MB zero blob: SQLite materializes it only when asked,
  // and the reader's length limit (128 MiB) makes it refuse instead.
  const std::string path = test::scratch_dir("ros2_hostile") + "/big.db3";
  {
    Db3Writer db(path);
    db.exec(
        "DROP TABLE messages; CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, "
        "timestamp INTEGER, data BLOB GENERATED ALWAYS AS (zeroblob(300000000)) VIRTUAL);");
    const int topic = db.topic("/dvs/events", "event_camera_msgs/msg/EventPacket");
    db.exec("INSERT INTO messages(topic_id, timestamp) VALUES(" + std::to_string(topic) + ", 5)");
  }
  auto reader = open_ros2_bag(path);
  EXPECT_TRUE(read_events(*reader).empty());
  const auto& dropped = reader->report().dropped();
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_EQ(dropped.begin()->first,
            "a message is larger than the reader's limit of 128 MiB, the rest of the file is not "
            "read");
}

TEST(Ros2BagHostile, AnErrorWhileListingTopicsIsAnInputErrorNotAPartialListing) {
  // The second row of `topics` cannot be read (its generated name is above the length limit):
  // listing only the first topic would silently change which topics are chosen.
  const std::string path = test::scratch_dir("ros2_hostile") + "/topics.db3";
  {
    Db3Writer db(path);
    db.exec(
        "DROP TABLE topics; CREATE TABLE topics(id INTEGER PRIMARY KEY, type TEXT, "
        "serialization_format TEXT, name TEXT GENERATED ALWAYS AS (CASE WHEN id = 1 THEN "
        "'/imu' ELSE zeroblob(300000000) END) VIRTUAL);"
        "INSERT INTO topics(type, serialization_format) VALUES('sensor_msgs/msg/Imu', 'cdr'), "
        "('sensor_msgs/msg/Imu', 'cdr');");
  }
  const std::string error = error_of(path);
  EXPECT_EQ(error.rfind("table topics | unreadable database: ", 0), 0u) << error;
}

TEST(Ros2BagHostile, AVirtualBagTableIsAnInputError) {
  // A virtual table runs a module's code (here FTS4's) over the file's own data; rosbag2 writes
  // plain tables, so the reader refuses one before querying it.
  const std::string path = test::scratch_dir("ros2_hostile") + "/virtual.db3";
  {
    Db3Writer db(path);
    db.exec(
        "DROP TABLE messages; CREATE VIRTUAL TABLE messages USING fts4(id, topic_id, timestamp, "
        "data);");
  }
  EXPECT_EQ(error_of(path), "table messages | not a ROS 2 bag: `messages` is a virtual table");
}

TEST_F(Ros2SyntheticTest, BagFromMemoryReadsLikeTheFile) {
  std::ifstream in(path_, std::ios::binary);
  std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ReaderOptions options;
  options.events_topic = "/caer/events";
  auto from_file = open_ros2_bag(path_, options);
  auto from_memory = open_ros2_bag_bytes(bytes, "memory.db3", options);
  EXPECT_EQ(from_memory->info().path, "memory.db3");
  EXPECT_EQ(from_memory->info().topics.size(), from_file->info().topics.size());
  EXPECT_EQ(from_memory->info().notes, from_file->info().notes);
  const SensorChunk a = read_everything(*from_file), b = read_everything(*from_memory);
  EXPECT_EQ(a.events, b.events);
  EXPECT_EQ(a.imu.size(), b.imu.size());
  EXPECT_EQ(a.depth.size(), b.depth.size());
  EXPECT_EQ(a.odometry.size(), b.odometry.size());
  EXPECT_EQ(from_memory->report().dropped().size(), from_file->report().dropped().size());

  try {
    open_ros2_bag_bytes(std::string("SQLite format 3\0", 16) + std::string(200, 'x'), "junk.db3");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "junk.db3");
  }
  try {
    open_ros2_bag_bytes("", "empty.db3");
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "empty.db3");
  }
}

}  // namespace
}  // namespace fdv
