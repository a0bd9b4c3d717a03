// ROS 2 bags in rosbag2's sqlite3 storage: tables `topics` (id, name, type,
// serialization_format, ...) and `messages` (id, topic_id, timestamp, data), one database per
// bag file; a bag folder lists its files in metadata.yaml. Messages are read with SQLite in
// timestamp order, one row at a time, and decoded from CDR here (ros_messages.h).
//
// A bag is untrusted input: SQLite opens it read-only with the settings SQLite recommends for
// databases from an untrusted source (defensive mode, untrusted schema, cell size checks, a
// value length limit), and every access of metadata.yaml is type-checked.
#include <sqlite3.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <utility>

#include "fdv/core/error.h"
#include "fdv/io/rosbag/bag_reader.h"
#include "fdv/io/rosbag/rosbag_reader.h"
#include "fdv/io/text_fields.h"

namespace fdv {
namespace fs = std::filesystem;
namespace {

/// Largest message (blob) read: SQLite's length limit on the connection, so a damaged or
/// generated value is refused by SQLite before it is allocated. Real messages (event packets,
/// depth images) are at most a few MiB; an event message's decoded events take twice its size.
constexpr int kMaxMessageBytes = 128 << 20;
/// Largest metadata.yaml read (rosbag2 writes a few KiB); yaml-cpp's tree of a larger file would
/// take many times its size.
constexpr std::uintmax_t kMaxMetadataBytes = 4u << 20;
/// Most .db3 files a metadata.yaml may list (rosbag2 splits a bag into files of at least a few
/// MiB each); each one is opened.
constexpr std::size_t kMaxBagFiles = 4096;

/// Owns one sqlite3 connection, read-only: to a file, or to a database image in memory
/// (`bytes`, which must outlive the connection; never written).
class Database {
 public:
  Database(const std::string& path, const std::string* bytes) : path_(path) {
    const int rc = bytes ? sqlite3_open_v2(":memory:", &db_, SQLITE_OPEN_READWRITE, nullptr)
                         : sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr);
    if (rc != SQLITE_OK) fail_open();
    // SQLite's advice for untrusted databases (sqlite.org/security.html).
    sqlite3_limit(db_, SQLITE_LIMIT_LENGTH, kMaxMessageBytes);
    sqlite3_db_config(db_, SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
    sqlite3_db_config(db_, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
    sqlite3_exec(db_, "PRAGMA cell_size_check = ON", nullptr, nullptr, nullptr);
    if (bytes) {
      auto* image = reinterpret_cast<unsigned char*>(const_cast<char*>(bytes->data()));
      const auto size = static_cast<sqlite3_int64>(bytes->size());
      if (sqlite3_deserialize(db_, "main", image, size, size, SQLITE_DESERIALIZE_READONLY) !=
          SQLITE_OK)
        fail_open();
    }
  }
  ~Database() { sqlite3_close(db_); }
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;
  sqlite3* get() const { return db_; }
  const std::string& path() const { return path_; }
  std::string error() const { return sqlite3_errmsg(db_); }

 private:
  [[noreturn]] void fail_open() {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw InputError(path_, "", "cannot open as an SQLite database: " + why);
  }

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

/// A text column as valid UTF-8 (topic names and types are printed and put into JSON).
std::string column_text(sqlite3_stmt* s, int i) {
  const auto* t = reinterpret_cast<const char*>(sqlite3_column_text(s, i));
  return t ? escape_non_utf8(
                 std::string_view(t, static_cast<std::size_t>(sqlite3_column_bytes(s, i))))
           : "";
}

/// Whether a CREATE statement from sqlite_master makes a virtual table (any case and spacing).
bool is_virtual(const std::string& sql) {
  std::string words;
  for (const char ch : sql.substr(0, 64))
    if (!std::isspace(static_cast<unsigned char>(ch)))
      words += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return words.rfind("createvirtual", 0) == 0;
}

struct FileTopic {
  std::string name, type, serialization;
};

/// One .db3 file of the bag: its topics, checked layout.
struct BagFile {
  std::string path;
  const std::string* bytes = nullptr;            ///< the database image when read from memory
  std::map<std::int64_t, FileTopic> topics;      ///< topics.id -> topic
  std::map<std::int64_t, std::size_t> selected;  ///< topics.id -> selected topic index
};

/// Throws unless the database has the two tables of a ROS 2 bag; reads its topics.
void read_topics(const Database& db, BagFile& file, std::map<std::string, TopicInfo>& listing,
                 std::map<std::string, TimeNs>& first, std::map<std::string, TimeNs>& last) {
  {
    Statement tables(db, "SELECT name, sql FROM sqlite_master WHERE type = 'table'", "");
    bool has_topics = false, has_messages = false;
    int rc;
    while ((rc = sqlite3_step(tables.get())) == SQLITE_ROW) {
      const std::string name = column_text(tables.get(), 0);
      const bool bag_table = name == "topics" || name == "messages";
      // A virtual table runs a module's code over the file's data (SQLite's advice for untrusted
      // databases): rosbag2 writes plain tables only.
      if (bag_table && is_virtual(column_text(tables.get(), 1)))
        throw InputError(db.path(), "table " + name,
                         "not a ROS 2 bag: `" + name + "` is a virtual table");
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
  int rc;
  while ((rc = sqlite3_step(topics.get())) == SQLITE_ROW) {
    FileTopic t{column_text(topics.get(), 1), column_text(topics.get(), 2),
                column_text(topics.get(), 3)};
    auto& entry = listing[t.name];
    entry.topic = t.name;
    entry.type = t.type;
    file.topics[sqlite3_column_int64(topics.get(), 0)] = std::move(t);
  }
  if (rc != SQLITE_DONE)  // not a partial listing: the topics decide what is read
    throw InputError(db.path(), "table topics", "unreadable database: " + db.error());
  Statement counts(db,
                   "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages "
                   "GROUP BY topic_id",
                   "table messages");
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

/// What a bag folder's metadata.yaml lists (rosbag2_bagfile_information: storage_identifier,
/// relative_file_paths), each access type-checked: an InputError naming metadata.yaml and the key,
/// never a yaml-cpp exception. Empty when the file lists no files.
std::vector<fs::path> metadata_files(const fs::path& dir, const std::string& meta) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(meta, ec);
  if (ec) throw InputError(meta, "", "cannot read: " + ec.message());
  if (size > kMaxMetadataBytes)
    throw InputError(meta, "",
                     "is " + std::to_string(size) + " bytes; a rosbag2 metadata file is at most " +
                         std::to_string(kMaxMetadataBytes >> 20) + " MiB");
  YAML::Node root;
  try {
    root = YAML::LoadFile(meta);
  } catch (const YAML::Exception& e) {
    throw InputError(meta, e.mark.is_null() ? "" : "line " + std::to_string(e.mark.line + 1),
                     "unreadable metadata: " + e.msg);
  }
  std::vector<fs::path> files;
  std::string key = "rosbag2_bagfile_information";
  try {
    if (root.IsNull()) return files;
    if (!root.IsMap()) throw InputError(meta, "", "not a YAML mapping (rosbag2 metadata is one)");
    const YAML::Node info = root[key];
    if (!info || info.IsNull()) return files;
    if (!info.IsMap()) throw InputError(meta, "key " + key, "is not a mapping");
    key = "storage_identifier";
    if (const YAML::Node storage = info[key]) {
      if (!storage.IsScalar()) throw InputError(meta, "key " + key, "is not a text value");
      if (storage.Scalar() != "sqlite3")
        throw InputError(meta, "key " + key,
                         "storage '" + escape_non_utf8(storage.Scalar().substr(0, 64)) +
                             "' is not supported: only sqlite3 (.db3) bags are read (Debian ships "
                             "no MCAP library; `ros2 bag convert` can rewrite a bag as sqlite3)");
    }
    key = "relative_file_paths";
    const YAML::Node paths = info[key];
    if (!paths || paths.IsNull()) return files;
    if (!paths.IsSequence()) throw InputError(meta, "key " + key, "is not a list");
    if (paths.size() > kMaxBagFiles)
      throw InputError(meta, "key " + key,
                       "lists " + std::to_string(paths.size()) + " files; at most " +
                           std::to_string(kMaxBagFiles) + " are read");
    for (std::size_t i = 0; i < paths.size(); ++i) {
      const YAML::Node f = paths[i];
      if (!f.IsScalar() || f.Scalar().empty() || f.Scalar().find('\0') != std::string::npos)
        throw InputError(meta, "key " + key + "[" + std::to_string(i) + "]", "is not a file name");
      fs::path p = dir / f.Scalar();
      if (!fs::exists(p, ec) && fs::exists(dir / p.filename(), ec)) p = dir / p.filename();
      files.push_back(p);
    }
  } catch (const YAML::Exception& e) {  // not expected after the checks above
    throw InputError(meta, "key " + key, "unreadable metadata: " + e.msg);
  }
  return files;
}

/// The .db3 files of a bag path (a file, or a folder with metadata.yaml), in reading order.
std::vector<std::string> bag_files(const std::string& path) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) return {path};
  const fs::path dir(path);
  const fs::path meta = dir / "metadata.yaml";
  std::vector<std::string> files;
  if (fs::exists(meta, ec))
    for (const auto& p : metadata_files(dir, meta.string())) files.push_back(p.string());
  if (files.empty()) {
    for (const auto& e : fs::directory_iterator(dir, ec))
      if (e.path().extension() == ".db3") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
  }
  if (files.empty()) throw InputError(path, "", "bag folder without .db3 files");
  for (const auto& f : files)
    if (!fs::is_regular_file(f, ec))  // not a FIFO or device either: SQLite would block on it
      throw InputError(escape_non_utf8(f), "",
                       "bag file listed in metadata.yaml is missing or not a regular file");
  return files;
}

class Ros2BagReader final : public bag::BagReader {
 public:
  Ros2BagReader(const std::string& path, const ReaderOptions& options)
      : bag::BagReader(path, options, bag::Dialect::kCdr, "ros2_bag") {
    for (const auto& f : bag_files(path)) files_.push_back({f, nullptr, {}, {}});
    open_files();
  }
  /// One database image in memory, named `name` in messages.
  Ros2BagReader(std::string bytes, const std::string& name, const ReaderOptions& options)
      : bag::BagReader(name, options, bag::Dialect::kCdr, "ros2_bag"), bytes_(std::move(bytes)) {
    files_.push_back({name, &bytes_, {}, {}});
    open_files();
  }

 private:
  void open_files() {
    std::map<std::string, TopicInfo> listing;
    std::map<std::string, TimeNs> first, last;
    for (auto& f : files_) {
      Database db(f.path, f.bytes);
      read_topics(db, f, listing, first, last);
    }
    std::vector<TopicInfo> topics;
    for (auto& [name, t] : listing) {
      if (t.count > 1) {
        // Stamps are the file's: their difference may leave the int64 range.
        if (const auto span = checked_sub(last[name], first[name])) {
          if (*span > 0) t.rate_hz = static_cast<double>(t.count - 1) / to_seconds(*span);
        } else {
          info_.notes.push_back("topic " + name +
                                ": message timestamps span more than the 64-bit nanosecond "
                                "range (about 292 years); no rate given");
        }
      }
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
          Database db(f.path, f.bytes);
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
      if (rc == SQLITE_TOOBIG)
        report_.drop("a message is larger than the reader's limit of " +
                         std::to_string(kMaxMessageBytes >> 20) +
                         " MiB, the rest of the file is not read",
                     files_[file_ - 1].path + ": after messages.id " + std::to_string(last_id_));
      else if (rc != SQLITE_DONE)
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
      db_ = std::make_unique<Database>(f.path, f.bytes);
      stmt_ = Statement(*db_,
                        "SELECT id, topic_id, timestamp, data FROM messages WHERE topic_id IN (" +
                            ids + ") ORDER BY timestamp, id",
                        "table messages");
      return true;
    }
    return false;
  }

  std::string bytes_;  ///< the database image of an in-memory bag (never moved once opened)
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

std::unique_ptr<RecordingReader> open_ros2_bag_bytes(std::string bytes, const std::string& name,
                                                     const ReaderOptions& options) {
  return std::make_unique<Ros2BagReader>(std::move(bytes), name, options);
}

bool is_ros2_bag_folder(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec) || !fs::exists(fs::path(dir) / "metadata.yaml", ec)) return false;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() == ".db3" || e.path().extension() == ".mcap") return true;
  return false;
}

}  // namespace fdv
