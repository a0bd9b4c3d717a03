// ROS 2 bags in rosbag2's sqlite3 storage: tables `topics` (id, name, type,
// serialization_format, ...) and `messages` (id, topic_id, timestamp, data), one database per
// bag file; a bag folder lists its files in metadata.yaml. Messages are read with SQLite in
// timestamp order, one row at a time, and decoded from CDR here (ros_messages.h).
#include <sqlite3.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <utility>

#include "fdv/core/error.h"
#include "fdv/io/rosbag/bag_reader.h"
#include "fdv/io/rosbag/rosbag_reader.h"

namespace fdv {
namespace fs = std::filesystem;
namespace {

/// Owns one sqlite3 connection, read-only.
class Database {
 public:
  explicit Database(const std::string& path) : path_(path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      db_ = nullptr;
      throw InputError(path, "", "cannot open as an SQLite database: " + why);
    }
  }
  ~Database() { sqlite3_close(db_); }
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;
  sqlite3* get() const { return db_; }
  const std::string& path() const { return path_; }
  std::string error() const { return sqlite3_errmsg(db_); }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

/// Owns one prepared statement.
class Statement {
 public:
  Statement() = default;
  Statement(const Database& db, const std::string& sql, const std::string& where) {
    if (sqlite3_prepare_v2(db.get(), sql.c_str(), -1, &stmt_, nullptr) != SQLITE_OK) {
      const int code = sqlite3_errcode(db.get());
      if (code == SQLITE_NOTADB)
        throw InputError(db.path(), "byte 0", "not an SQLite database (a ROS 2 bag file is one)");
      throw InputError(db.path(), where, "not a ROS 2 bag database: " + db.error());
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(Statement&& o) noexcept : stmt_(std::exchange(o.stmt_, nullptr)) {}
  Statement& operator=(Statement&& o) noexcept {
    std::swap(stmt_, o.stmt_);
    return *this;
  }
  sqlite3_stmt* get() const { return stmt_; }
  explicit operator bool() const { return stmt_ != nullptr; }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

std::string column_text(sqlite3_stmt* s, int i) {
  const unsigned char* t = sqlite3_column_text(s, i);
  return t ? reinterpret_cast<const char*>(t) : "";
}

struct FileTopic {
  std::string name, type, serialization;
};

/// One .db3 file of the bag: its topics, checked layout.
struct BagFile {
  std::string path;
  std::map<std::int64_t, FileTopic> topics;      ///< topics.id -> topic
  std::map<std::int64_t, std::size_t> selected;  ///< topics.id -> selected topic index
};

/// Throws unless the database has the two tables of a ROS 2 bag; reads its topics.
void read_topics(const Database& db, BagFile& file, std::map<std::string, TopicInfo>& listing,
                 std::map<std::string, TimeNs>& first, std::map<std::string, TimeNs>& last) {
  {
    Statement tables(db, "SELECT name FROM sqlite_master WHERE type = 'table'", "");
    bool has_topics = false, has_messages = false;
    int rc;
    while ((rc = sqlite3_step(tables.get())) == SQLITE_ROW) {
      const std::string name = column_text(tables.get(), 0);
      has_topics |= name == "topics";
      has_messages |= name == "messages";
    }
    if (rc == SQLITE_NOTADB)
      throw InputError(db.path(), "byte 0", "not an SQLite database (a ROS 2 bag file is one)");
    if (rc != SQLITE_DONE) throw InputError(db.path(), "", "unreadable database: " + db.error());
    if (!has_topics || !has_messages)
      throw InputError(db.path(), has_topics ? "table messages" : "table topics",
                       std::string("not a ROS 2 bag: the database has no `") +
                           (has_topics ? "messages" : "topics") + "` table");
  }
  Statement topics(db, "SELECT id, name, type, serialization_format FROM topics", "table topics");
  while (sqlite3_step(topics.get()) == SQLITE_ROW) {
    FileTopic t{column_text(topics.get(), 1), column_text(topics.get(), 2),
                column_text(topics.get(), 3)};
    auto& entry = listing[t.name];
    entry.topic = t.name;
    entry.type = t.type;
    file.topics[sqlite3_column_int64(topics.get(), 0)] = std::move(t);
  }
  Statement counts(db,
                   "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages "
                   "GROUP BY topic_id",
                   "table messages");
  int rc;
  while ((rc = sqlite3_step(counts.get())) == SQLITE_ROW) {
    const auto it = file.topics.find(sqlite3_column_int64(counts.get(), 0));
    if (it == file.topics.end()) continue;  // messages of an unlisted topic cannot be decoded
    const std::string& name = it->second.name;
    listing[name].count += static_cast<std::uint64_t>(sqlite3_column_int64(counts.get(), 1));
    const TimeNs lo = sqlite3_column_int64(counts.get(), 2);
    const TimeNs hi = sqlite3_column_int64(counts.get(), 3);
    first[name] = first.count(name) ? std::min(first[name], lo) : lo;
    last[name] = last.count(name) ? std::max(last[name], hi) : hi;
  }
  if (rc != SQLITE_DONE)
    throw InputError(db.path(), "table messages", "unreadable database: " + db.error());
}

/// The .db3 files of a bag path (a file, or a folder with metadata.yaml), in reading order.
std::vector<std::string> bag_files(const std::string& path) {
  if (!fs::is_directory(path)) return {path};
  const fs::path dir(path);
  const fs::path meta = dir / "metadata.yaml";
  std::vector<std::string> files;
  if (fs::exists(meta)) {
    YAML::Node info;
    try {
      info = YAML::LoadFile(meta.string())["rosbag2_bagfile_information"];
    } catch (const YAML::Exception& e) {
      throw InputError(meta.string(), "line " + std::to_string(e.mark.line + 1),
                       "unreadable metadata: " + e.msg);
    }
    if (info && info["storage_identifier"] &&
        info["storage_identifier"].as<std::string>("") != "sqlite3")
      throw InputError(meta.string(), "key storage_identifier",
                       "storage '" + info["storage_identifier"].as<std::string>("") +
                           "' is not supported: only sqlite3 (.db3) bags are read (Debian ships "
                           "no MCAP library; `ros2 bag convert` can rewrite a bag as sqlite3)");
    if (info && info["relative_file_paths"] && info["relative_file_paths"].IsSequence())
      for (const auto& f : info["relative_file_paths"]) {
        fs::path p = dir / f.as<std::string>("");
        if (!fs::exists(p) && fs::exists(dir / p.filename())) p = dir / p.filename();
        files.push_back(p.string());
      }
  }
  if (files.empty()) {
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".db3") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
  }
  if (files.empty()) throw InputError(path, "", "bag folder without .db3 files");
  for (const auto& f : files)
    if (!fs::exists(f)) throw InputError(f, "", "bag file listed in metadata.yaml is missing");
  return files;
}

class Ros2BagReader final : public bag::BagReader {
 public:
  Ros2BagReader(const std::string& path, const ReaderOptions& options)
      : bag::BagReader(path, options, bag::Dialect::kCdr, "ros2_bag") {
    std::map<std::string, TopicInfo> listing;
    std::map<std::string, TimeNs> first, last;
    for (const auto& f : bag_files(path)) {
      files_.push_back({f, {}, {}});
      Database db(f);
      read_topics(db, files_.back(), listing, first, last);
    }
    std::vector<TopicInfo> topics;
    for (auto& [name, t] : listing) {
      const double span_s = t.count > 1 ? to_seconds(last[name] - first[name]) : 0.0;
      if (span_s > 0) t.rate_hz = static_cast<double>(t.count - 1) / span_s;
      topics.push_back(t);
    }
    setup(std::move(topics));
    for (auto& f : files_)
      for (const auto& [id, t] : f.topics)
        for (std::size_t i = 0; i < selected().size(); ++i)
          if (selected()[i].topic == t.name) f.selected[id] = i;
  }

 protected:
  const char* position_label() const override { return "messages.id "; }

  void check_selected() override {
    for (const auto& f : files_)
      for (const auto& [id, t] : f.topics)
        for (const auto& s : selected())
          if (s.topic == t.name && t.serialization != "cdr")
            throw InputError(
                f.path, "topic " + t.name,
                "serialization format '" + t.serialization + "' is not supported (only cdr)");
  }

  bool peek_event_message(std::vector<std::uint8_t>& bytes) override {
    for (const auto& s : selected()) {
      if (s.stream != StreamKind::kEvents) continue;
      for (const auto& f : files_) {
        for (const auto& [id, t] : f.topics) {
          if (t.name != s.topic) continue;
          Database db(f.path);
          Statement q(db,
                      "SELECT data FROM messages WHERE topic_id = " + std::to_string(id) +
                          " ORDER BY timestamp, id LIMIT 1",
                      "table messages");
          if (sqlite3_step(q.get()) != SQLITE_ROW) continue;
          const auto* data = static_cast<const std::uint8_t*>(sqlite3_column_blob(q.get(), 0));
          bytes.assign(data, data + sqlite3_column_bytes(q.get(), 0));
          return true;
        }
      }
    }
    return false;
  }

  bool next_message(bag::RawMessage& m) override {
    while (true) {
      if (!stmt_ && !open_next_file()) return false;
      const int rc = sqlite3_step(stmt_.get());
      if (rc == SQLITE_ROW) {
        m.position = static_cast<std::uint64_t>(sqlite3_column_int64(stmt_.get(), 0));
        last_id_ = m.position;
        const auto sel = files_[file_ - 1].selected.find(sqlite3_column_int64(stmt_.get(), 1));
        if (sel == files_[file_ - 1].selected.end()) continue;  // not possible with the query
        m.selected = sel->second;
        m.bag_time = sqlite3_column_int64(stmt_.get(), 2);
        m.data = static_cast<const std::uint8_t*>(sqlite3_column_blob(stmt_.get(), 3));
        m.size = static_cast<std::size_t>(sqlite3_column_bytes(stmt_.get(), 3));
        if (!m.data) m.size = 0;
        return true;
      }
      if (rc != SQLITE_DONE)
        report_.drop("bag database damaged, the rest of the file is unreadable: " + db_->error(),
                     files_[file_ - 1].path + ": after messages.id " + std::to_string(last_id_));
      stmt_ = Statement();
      db_.reset();
    }
  }

 private:
  bool open_next_file() {
    while (file_ < files_.size()) {
      const BagFile& f = files_[file_++];
      if (f.selected.empty()) continue;
      std::string ids;
      for (const auto& [id, _] : f.selected) ids += (ids.empty() ? "" : ",") + std::to_string(id);
      db_ = std::make_unique<Database>(f.path);
      stmt_ = Statement(*db_,
                        "SELECT id, topic_id, timestamp, data FROM messages WHERE topic_id IN (" +
                            ids + ") ORDER BY timestamp, id",
                        "table messages");
      return true;
    }
    return false;
  }

  std::vector<BagFile> files_;
  std::size_t file_ = 0;  ///< index of the next file to open
  std::unique_ptr<Database> db_;
  Statement stmt_;
  std::uint64_t last_id_ = 0;
};

}  // namespace

std::unique_ptr<RecordingReader> open_ros2_bag(const std::string& path,
                                               const ReaderOptions& options) {
  return std::make_unique<Ros2BagReader>(path, options);
}

bool is_ros2_bag_folder(const std::string& dir) {
  if (!fs::is_directory(dir) || !fs::exists(fs::path(dir) / "metadata.yaml")) return false;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".db3" || e.path().extension() == ".mcap") return true;
  return false;
}

}  // namespace fdv
