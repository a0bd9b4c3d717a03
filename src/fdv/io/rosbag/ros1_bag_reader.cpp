// ROS 1 bags through Debian's rosbag storage library (rosbag::Bag / rosbag::View): the library
// reads the index, decompresses chunks and merges connections in time order; the message bytes
// are decoded here (ros_messages.h). The library trusts the file's lengths and offsets, so
// Ros1BagStructure checks what it will read first: the index before it opens the bag, each chunk's
// records before the first message the view takes from it.
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <fstream>
#include <map>
#include <optional>
#include <unordered_map>

#include "fdv/core/error.h"
#include "fdv/io/rosbag/bag_reader.h"
#include "fdv/io/rosbag/ros1_bag_structure.h"
#include "fdv/io/rosbag/rosbag_reader.h"

namespace fdv {
namespace {

using rosbag_impl_reader = fdv::bag::BagReader;

TimeNs to_ns(const ros::Time& t) { return static_cast<TimeNs>(t.toNSec()); }

class Ros1BagReader final : public rosbag_impl_reader {
 public:
  Ros1BagReader(const std::string& path, const ReaderOptions& options)
      : rosbag_impl_reader(path, options, bag::Dialect::kRos1, "ros1_bag") {
    check_magic(path);
    structure_.emplace(path);  // InputError naming the byte when the index does not hold together
    try {
      bag_.open(path, ::rosbag::bagmode::Read);
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
        names.push_back(selected()[i].topic);
        selected_index_[selected()[i].topic] = i;
      }
      ordinal_.assign(selected().size(), 0);
      view_ = std::make_unique<::rosbag::View>();
      if (!names.empty()) view_->addQuery(bag_, ::rosbag::TopicQuery(names));
      it_ = view_->begin();
      end_ = view_->end();
    } catch (const ::rosbag::BagException& e) {
      throw InputError(path, "", std::string("cannot read the bag: ") + e.what());
    }
  }

 protected:
  const char* position_label() const override { return "message "; }

  void check_selected() override {
    ::rosbag::View all(bag_);
    for (const auto* c : all.getConnections()) {
      for (const auto& s : selected()) {
        if (c->topic != s.topic) continue;
        if (c->datatype != s.type_name)
          throw InputError(path(), "topic " + s.topic,
                           "has messages of two types, " + s.type_name + " and " + c->datatype);
        const std::string expected = bag::type_info(s.type).ros1_md5;
        if (c->md5sum != expected)
          throw InputError(path(), "topic " + s.topic,
                           "MD5 sum of " + c->datatype + " in the bag is " + c->md5sum +
                               ", but this reader decodes the definition whose MD5 sum is " +
                               expected + ": the message layout differs");
      }
    }
  }

  bool peek_event_message(std::vector<std::uint8_t>& bytes) override {
    for (const auto& s : selected()) {
      if (s.stream != StreamKind::kEvents) continue;
      try {
        ::rosbag::View v(bag_, ::rosbag::TopicQuery(s.topic));
        auto it = v.begin();
        if (it == v.end() || damage_up_to(to_ns(it->getTime()))) return false;  // read() reports it
        copy_bytes(*it, bytes);
        return true;
      } catch (const ::rosbag::BagException&) {
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
  static void check_magic(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
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
    ::rosbag::View all(bag_);
    std::map<std::string, std::string> types;
    for (const auto* c : all.getConnections()) types.emplace(c->topic, c->datatype);
    std::vector<TopicInfo> topics;
    for (const auto& [topic, type] : types) {
      ::rosbag::View v(bag_, ::rosbag::TopicQuery(topic));
      TopicInfo t;
      t.topic = topic;
      t.type = type;
      t.count = v.size();
      const double span_s = to_seconds(to_ns(v.getEndTime()) - to_ns(v.getBeginTime()));
      if (t.count > 1 && span_s > 0) t.rate_hz = static_cast<double>(t.count - 1) / span_s;
      topics.push_back(t);
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
  ::rosbag::Bag bag_;
  std::unique_ptr<::rosbag::View> view_;
  ::rosbag::View::iterator it_, end_;
  bool advance_ = false;
  bool done_ = false;
  std::unordered_map<std::string, std::size_t> selected_index_;
  std::vector<std::uint64_t> ordinal_;
  std::vector<std::uint8_t> buffer_;
};

}  // namespace

std::unique_ptr<RecordingReader> open_ros1_bag(const std::string& path,
                                               const ReaderOptions& options) {
  return std::make_unique<Ros1BagReader>(path, options);
}

}  // namespace fdv
