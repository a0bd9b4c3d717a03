// ROS 1 bags through Debian's rosbag storage library (rosbag::Bag / rosbag::View): the library
// reads the index, decompresses chunks and merges connections in time order; the message bytes
// are decoded here (ros_messages.h). The library trusts the file's lengths and offsets, so
// Ros1BagStructure checks what it will read first: the index before it opens the bag, each chunk's
// records before the first message the view takes from it.
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <unordered_map>

#include "fdv/core/error.h"
#include "fdv/io/rosbag/bag_reader.h"
#include "fdv/io/rosbag/ros1_bag_structure.h"
#include "fdv/io/rosbag/ros1_plugin_api.h"
#include "fdv/io/rosbag/rosbag_reader.h"
#include "fdv/io/text_fields.h"

namespace fdv {
namespace {

using rosbag_impl_reader = fdv::bag::BagReader;

TimeNs to_ns(const ros::Time& t) { return static_cast<TimeNs>(t.toNSec()); }

/// rosbag::Bag objects, reused. Constructing one costs about 20 ms (its pluginlib loader of
/// encryptor plugins searches the ament index), opening, reading and closing a small bag on one
/// 0.1 ms: reading many small bags (a folder of recordings, a fuzzer) was bound by the
/// construction. Closed bags go back to a small free list (thread-safe); it is never destroyed,
/// so no plugin loader is torn down during static destruction.
class BagPool {
 public:
  struct Return {
    void operator()(::rosbag::Bag* bag) const { pool().give_back(bag); }
  };
  using Handle = std::unique_ptr<::rosbag::Bag, Return>;

  static BagPool& pool() {
    static BagPool* const instance = new BagPool;
    return *instance;
  }

  Handle take() {
    std::unique_ptr<::rosbag::Bag> bag;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!idle_.empty()) {
        bag = std::move(idle_.back());
        idle_.pop_back();
      }
    }
    return Handle(bag ? bag.release() : new ::rosbag::Bag);
  }

 private:
  /// Closed bags kept: each keeps its buffers (up to the largest chunk it read).
  static constexpr std::size_t kMaxIdle = 2;

  void give_back(::rosbag::Bag* raw) {
    std::unique_ptr<::rosbag::Bag> bag(raw);
    try {
      bag->close();  // clears every connection, chunk and index of the bag it read
      bag->setEncryptorPlugin("rosbag/NoEncryptor");  // a bag's header may have named another
    } catch (const std::exception&) {
      return;  // not reusable: destroyed here
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (idle_.size() < kMaxIdle) idle_.push_back(std::move(bag));
  }

  std::mutex mutex_;
  std::vector<std::unique_ptr<::rosbag::Bag>> idle_;
};

class Ros1BagReader final : public rosbag_impl_reader {
 public:
  /// Reads the bag at `file`; messages name it `name` (the path when empty).
  Ros1BagReader(const std::string& file, const std::string& name, const ReaderOptions& options)
      : rosbag_impl_reader(name.empty() ? file : name, options, bag::Dialect::kRos1, "ros1_bag") {
    const std::string& path = this->path();
    check_magic(file, path);
    structure_.emplace(file, path);  // InputError naming the byte when the index does not hold
    try {
      bag_->open(file, ::rosbag::bagmode::Read);
    } catch (const ::rosbag::BagUnindexedException&) {
      throw InputError(path, "byte 13",
                       "the bag is unindexed (its recording was not closed): run `rosbag reindex " +
                           path + "` and try again");
    } catch (const std::exception& e) {
      throw InputError(path, "",
                       std::string("cannot read the bag's index (") + e.what() +
                           "): the bag is truncated or damaged; `rosbag reindex` may recover it");
    }
    try {
      setup(list_topics());
      std::vector<std::string> names;
      for (std::size_t i = 0; i < selected().size(); ++i) {
        const std::string& raw = raw_topic_.at(selected()[i].topic);
        names.push_back(raw);
        selected_index_[raw] = i;
      }
      ordinal_.assign(selected().size(), 0);
      view_ = std::make_unique<::rosbag::View>();
      if (!names.empty()) view_->addQuery(*bag_, ::rosbag::TopicQuery(names));
      it_ = view_->begin();
      end_ = view_->end();
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {  // rosbag's, ros::Time's range errors, std::bad_alloc
      throw InputError(path, "", std::string("cannot read the bag: ") + e.what());
    }
  }

 protected:
  const char* position_label() const override { return "message "; }

  void check_selected() override {
    const auto& stats = structure_->connection_stats();
    for (const auto& [id, c] : structure_->connections()) {
      const auto s_it = stats.find(id);
      if (s_it == stats.end() || s_it->second.count == 0) continue;  // no messages to decode
      for (const auto& s : selected()) {
        if (escape_non_utf8(c.topic) != s.topic) continue;
        const std::string datatype = escape_non_utf8(c.type);
        if (datatype != s.type_name)
          throw InputError(path(), "topic " + s.topic,
                           "has messages of two types, " + s.type_name + " and " + datatype);
        const std::string expected = bag::type_info(s.type).ros1_md5;
        if (c.md5sum != expected)
          throw InputError(path(), "topic " + s.topic,
                           "MD5 sum of " + datatype + " in the bag is " +
                               escape_non_utf8(c.md5sum) +
                               ", but this reader decodes the definition whose MD5 sum is " +
                               expected + ": the message layout differs");
      }
    }
  }

  bool peek_event_message(std::vector<std::uint8_t>& bytes) override {
    for (const auto& s : selected()) {
      if (s.stream != StreamKind::kEvents) continue;
      try {
        ::rosbag::View v(*bag_, ::rosbag::TopicQuery(raw_topic_.at(s.topic)));
        auto it = v.begin();
        if (it == v.end() || damage_up_to(to_ns(it->getTime()))) return false;  // read() reports it
        copy_bytes(*it, bytes);
        return true;
      } catch (const std::exception&) {
        return false;  // read() meets the damage again and reports it
      }
    }
    return false;
  }

  bool next_message(bag::RawMessage& m) override {
    if (done_) return false;
    try {
      if (advance_) ++it_;
      advance_ = true;
      if (it_ == end_) {
        done_ = true;
        return false;
      }
      const ::rosbag::MessageInstance& mi = *it_;
      const auto sel = selected_index_.find(mi.getTopic());
      if (sel == selected_index_.end()) return next_message(m);  // not possible with TopicQuery
      if (const auto damage = damage_up_to(to_ns(mi.getTime()))) {
        report_.drop("bag damaged, the rest is unreadable: " + damage->reason(),
                     damage->where() + ", after message " + std::to_string(total()));
        done_ = true;
        return false;
      }
      copy_bytes(mi, buffer_);
      m.selected = sel->second;
      m.data = buffer_.data();
      m.size = buffer_.size();
      m.bag_time = to_ns(mi.getTime());
      m.position = ++ordinal_[sel->second];
      return true;
    } catch (const std::exception& e) {
      report_.drop(std::string("bag damaged, the rest is unreadable: ") + e.what(),
                   "after message " + std::to_string(total()));
      done_ = true;
      return false;
    }
  }

 private:
  static void check_magic(const std::string& file, const std::string& path) {
    std::ifstream in(file, std::ios::binary);
    std::string head(kRos1BagMagic.size(), '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    if (head.rfind("#ROSBAG V", 0) == 0 && head != kRos1BagMagic)
      throw InputError(path, "byte 0",
                       "ROS bag format " + head.substr(9, 3) +
                           " is not supported (only 2.0; `rosbag fix` converts older bags)");
    if (head != kRos1BagMagic)
      throw InputError(path, "byte 0", "not a ROS 1 bag (no #ROSBAG V2.0)");
  }

  /// Checks the records of every chunk that starts at or before t (a message at t comes from one
  /// of them: the structure check keeps index times within their chunk's span), once each, in
  /// order of start time. The first damage found, again at every call.
  std::optional<InputError> damage_up_to(TimeNs t) {
    const auto& chunks = structure_->chunks();
    for (; checked_ < chunks.size() && chunks[checked_].start <= t; ++checked_)
      if (auto damage = structure_->check_records(checked_)) return damage;
    return std::nullopt;
  }

  static void copy_bytes(const ::rosbag::MessageInstance& mi, std::vector<std::uint8_t>& out) {
    out.resize(mi.size());
    ros::serialization::OStream stream(out.data(), static_cast<std::uint32_t>(out.size()));
    mi.write(stream);
  }

  /// Every topic with its type, message count and rate over its span of bag time.
  std::vector<TopicInfo> list_topics() {
    struct Topic {
      std::string type;
      bag::Ros1BagStructure::ConnectionStats stats;
    };
    std::map<std::string, Topic> by_name;  // the library's (raw) topic names
    const auto& stats = structure_->connection_stats();
    for (const auto& [id, c] : structure_->connections()) {
      const auto s = stats.find(id);
      if (s == stats.end() || s->second.count == 0) continue;  // as rosbag::View lists them
      Topic& t = by_name.emplace(c.topic, Topic{c.type, {}}).first->second;
      t.stats.first =
          t.stats.count == 0 ? s->second.first : std::min(t.stats.first, s->second.first);
      t.stats.last = t.stats.count == 0 ? s->second.last : std::max(t.stats.last, s->second.last);
      t.stats.count += s->second.count;
    }
    std::vector<TopicInfo> topics;
    for (const auto& [topic, t] : by_name) {
      TopicInfo info;
      // Names and types as valid UTF-8 (printed and put into JSON); the library keeps its own.
      info.topic = escape_non_utf8(topic);
      info.type = escape_non_utf8(t.type);
      raw_topic_.emplace(info.topic, topic);
      info.count = t.stats.count;
      // ROS 1 times are uint32 seconds: the span fits in int64 nanoseconds.
      const double span_s = to_seconds(t.stats.last - t.stats.first);
      if (info.count > 1 && span_s > 0) info.rate_hz = static_cast<double>(info.count - 1) / span_s;
      topics.push_back(info);
    }
    return topics;
  }

  std::uint64_t total() const {
    std::uint64_t n = 0;
    for (auto k : ordinal_) n += k;
    return n;
  }

  std::optional<bag::Ros1BagStructure> structure_;
  std::size_t checked_ = 0;  ///< chunks (by start time) whose records were checked
  BagPool::Handle bag_ = BagPool::pool().take();  ///< before the view, which refers to it
  std::unique_ptr<::rosbag::View> view_;
  ::rosbag::View::iterator it_, end_;
  bool advance_ = false;
  bool done_ = false;
  std::unordered_map<std::string, std::size_t> selected_index_;  ///< by the library's topic name
  std::map<std::string, std::string> raw_topic_;  ///< listed (escaped) topic -> library's name
  std::vector<std::uint64_t> ordinal_;
  std::vector<std::uint8_t> buffer_;
};

}  // namespace

std::unique_ptr<RecordingReader> ros1::open_reader(const std::string& path, const ReaderOptions& options) {
  return std::make_unique<Ros1BagReader>(path, "", options);
}

namespace {

/// The bytes of an in-memory ROS 1 bag as an anonymous memory file: Debian's rosbag storage
/// opens bags by path only, and /proc/self/fd/N is one. Closed (and freed) with the reader.
class MemoryFile {
 public:
  MemoryFile(const std::string& bytes, const std::string& name)
      : fd_(memfd_create("fdv-ros1-bag", MFD_CLOEXEC)) {
    if (fd_ < 0) throw InputError(name, "", std::string("memfd_create: ") + std::strerror(errno));
    for (std::size_t done = 0; done < bytes.size();) {
      const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        const int err = errno;
        ::close(fd_);
        throw InputError(name, "", std::string("writing the memory file: ") + std::strerror(err));
      }
      done += static_cast<std::size_t>(n);
    }
  }
  ~MemoryFile() { ::close(fd_); }
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;
  std::string path() const { return "/proc/self/fd/" + std::to_string(fd_); }

 private:
  int fd_;
};

/// A Ros1BagReader over a MemoryFile it owns (declared first: it outlives the reader's bag).
class MemoryRos1BagReader final : public RecordingReader {
 public:
  MemoryRos1BagReader(const std::string& bytes, const std::string& name,
                      const ReaderOptions& options)
      : file_(bytes, name), reader_(file_.path(), name, options) {}
  const RecordingInfo& info() const override { return reader_.info(); }
  const ReadReport& report() const override { return reader_.report(); }
  bool read(SensorChunk& chunk) override { return reader_.read(chunk); }

 private:
  MemoryFile file_;
  Ros1BagReader reader_;
};

}  // namespace

std::unique_ptr<RecordingReader> ros1::open_reader_bytes(const std::string& bytes, const std::string& name,
                                                         const ReaderOptions& options) {
  return std::make_unique<MemoryRos1BagReader>(bytes, name, options);
}

}  // namespace fdv
