#include "fdv/io/hdf5/hdf5_reader.h"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/hdf5/hdf5_plugin_api.h"
#include "fdv/io/hdf5/hdf5_support.h"

namespace fdv {
namespace {
using hdf5::Id;

/// Rows of the index read at a time.
constexpr hsize_t kIndexBlock = 4096;
/// Raw-data chunk cache per dataset: a few of Metavision's 16384-row chunks (256 KiB each), so a
/// read that spans two chunks decompresses each once.
constexpr std::size_t kChunkCacheBytes = 8 << 20;

/// One event as read from either layout, before it becomes an fdv::Event.
struct Row {
  std::int64_t t;  ///< µs, on the file's own clock (DSEC: before t_offset)
  std::int32_t x, y, p;
};

using hdf5::CdEvent;

/// "first event at or after time t": Metavision's CD/indexes (t = ts + the table's time base) and
/// DSEC's ms_to_idx (t = k ms).
struct IndexEntry {
  std::int64_t id;
  std::int64_t t_us;
};

struct Source {
  std::string path;      ///< for errors
  Id file;
};

bool exists(hid_t loc, const std::string& path) {
  std::size_t pos = 0;
  while (true) {
    const std::size_t slash = path.find('/', pos);
    const std::string prefix = path.substr(0, slash);
    if (H5Lexists(loc, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (slash == std::string::npos) return true;
    pos = slash + 1;
  }
}

Id open_dataset(const Source& s, const std::string& name) {
  Id dapl(H5Pcreate(H5P_DATASET_ACCESS));
  H5Pset_chunk_cache(dapl.get(), H5D_CHUNK_CACHE_NSLOTS_DEFAULT, kChunkCacheBytes, H5D_CHUNK_CACHE_W0_DEFAULT);
  Id d(H5Dopen2(s.file.get(), name.c_str(), dapl.get()));
  if (!d.valid()) throw InputError(s.path, "dataset " + name, "cannot open: " + hdf5::last_error());
  return d;
}

/// Rows of a one-dimensional dataset; InputError for another rank.
hsize_t length_1d(const Source& s, const std::string& name, hid_t dset) {
  const Id space(H5Dget_space(dset));
  if (H5Sget_simple_extent_ndims(space.get()) != 1)
    throw InputError(s.path, "dataset " + name, "expected a one-dimensional table");
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space.get(), &n, nullptr);
  return n;
}

void require_integer(const Source& s, const std::string& dataset, hid_t type, const std::string& what) {
  if (H5Tget_class(type) != H5T_INTEGER)
    throw InputError(s.path, "dataset " + dataset, what + " is not an integer type");
}

/// Checks that `name`'s type is a compound with integer `members`.
void require_compound(const Source& s, const std::string& name, hid_t dset,
                      std::initializer_list<const char*> members) {
  const Id type(H5Dget_type(dset));
  std::string expected;
  for (const char* m : members) expected += std::string(expected.empty() ? "" : ", ") + m;
  if (H5Tget_class(type.get()) != H5T_COMPOUND)
    throw InputError(s.path, "dataset " + name,
                     "not a compound table (expected integer fields " + expected + ")");
  for (const char* m : members) {
    const int i = H5Tget_member_index(type.get(), m);
    if (i < 0)
      throw InputError(s.path, "dataset " + name,
                       std::string("has no field '") + m + "' (expected integer fields " + expected + ")");
    const Id member(H5Tget_member_type(type.get(), static_cast<unsigned>(i)));
    require_integer(s, name, member.get(), std::string("field '") + m + "'");
  }
}

/// Reads rows [first, first + n) of a one-dimensional dataset into `out` as `mem_type`.
template <typename T>
void read_rows(const Source& s, const std::string& name, hid_t dset, hid_t mem_type, hsize_t first,
               hsize_t n, std::vector<T>& out) {
  out.resize(n);
  if (n == 0) return;
  const Id file_space(H5Dget_space(dset));
  const Id mem_space(H5Screate_simple(1, &n, nullptr));
  if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &first, nullptr, &n, nullptr) < 0 ||
      H5Dread(dset, mem_type, mem_space.get(), file_space.get(), H5P_DEFAULT, out.data()) < 0)
    throw InputError(s.path, "dataset " + name + " rows " + std::to_string(first) + ".." +
                                 std::to_string(first + n),
                     "cannot read: " + hdf5::last_error());
}

/// A string or integer attribute of `loc`, as text; nullopt when absent.
std::optional<std::string> attribute_text(hid_t loc, const char* name) {
  if (H5Aexists(loc, name) <= 0) return std::nullopt;
  const Id attr(H5Aopen(loc, name, H5P_DEFAULT));
  const Id type(H5Aget_type(attr.get()));
  if (H5Tget_class(type.get()) == H5T_INTEGER) {
    std::int64_t v = 0;
    if (H5Aread(attr.get(), H5T_NATIVE_INT64, &v) < 0) return std::nullopt;
    return std::to_string(v);
  }
  if (H5Tget_class(type.get()) != H5T_STRING) return std::nullopt;
  const Id space(H5Aget_space(attr.get()));
  if (H5Sget_simple_extent_npoints(space.get()) != 1) return std::nullopt;
  if (H5Tis_variable_str(type.get()) > 0) {
    const Id mem(H5Tcopy(H5T_C_S1));
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));  // HDF5 does not convert ASCII <-> UTF-8 (h5py's str)
    char* text = nullptr;
    if (H5Aread(attr.get(), mem.get(), &text) < 0 || !text) return std::nullopt;
    std::string out(text);
    H5free_memory(text);
    return out;
  }
  std::string out(H5Tget_size(type.get()), '\0');
  if (out.empty() || H5Aread(attr.get(), type.get(), out.data()) < 0) return std::nullopt;
  out.resize(std::min(out.size(), out.find('\0')));
  return out;
}

bool parse_int(std::string_view s, std::int64_t& out) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && !s.empty();
}

/// The two layouts differ in how rows and index entries are read; the rest is shared.
class Layout {
 public:
  virtual ~Layout() = default;
  virtual hsize_t rows() const = 0;
  virtual void read(hsize_t first, hsize_t n, std::vector<Row>& out) = 0;
  /// Entries [first, first + n) of the index, normalised; `n` is clipped to what is left.
  virtual void read_index(hsize_t first, hsize_t n, std::vector<IndexEntry>& out) = 0;
  virtual hsize_t index_rows() const = 0;
  virtual std::string index_name() const = 0;
  /// Added to every row's t [µs] to give the recording's clock.
  virtual std::int64_t t_offset_us() const = 0;
};

class MetavisionLayout final : public Layout {
 public:
  static constexpr const char* kEvents = "CD/events";
  static constexpr const char* kIndexes = "CD/indexes";

  explicit MetavisionLayout(const Source& s) : s_(s), events_(open_dataset(s, kEvents)) {
    require_compound(s, kEvents, events_.get(), {"x", "y", "p", "t"});
    rows_ = length_1d(s, kEvents, events_.get());
    row_type_ = Id(H5Tcreate(H5T_COMPOUND, sizeof(Row)));
    H5Tinsert(row_type_.get(), "t", HOFFSET(Row, t), H5T_NATIVE_INT64);
    H5Tinsert(row_type_.get(), "x", HOFFSET(Row, x), H5T_NATIVE_INT32);
    H5Tinsert(row_type_.get(), "y", HOFFSET(Row, y), H5T_NATIVE_INT32);
    H5Tinsert(row_type_.get(), "p", HOFFSET(Row, p), H5T_NATIVE_INT32);
    cd_type_ = Id(H5Tcreate(H5T_COMPOUND, sizeof(CdEvent)));
    H5Tinsert(cd_type_.get(), "x", HOFFSET(CdEvent, x), H5T_NATIVE_UINT16);
    H5Tinsert(cd_type_.get(), "y", HOFFSET(CdEvent, y), H5T_NATIVE_UINT16);
    H5Tinsert(cd_type_.get(), "p", HOFFSET(CdEvent, p), H5T_NATIVE_INT16);
    H5Tinsert(cd_type_.get(), "t", HOFFSET(CdEvent, t), H5T_NATIVE_INT64);
    const Id file_type(H5Dget_type(events_.get()));
    exact_ = H5Tequal(file_type.get(), cd_type_.get()) > 0;
    filters_ = hdf5::check_filters(s.path, kEvents, events_.get());
    if (!exists(s.file.get(), kIndexes)) return;
    indexes_ = open_dataset(s, kIndexes);
    require_compound(s, kIndexes, indexes_.get(), {"id", "ts"});
    hdf5::check_filters(s.path, kIndexes, indexes_.get());
    index_rows_ = length_1d(s, kIndexes, indexes_.get());
    index_type_ = Id(H5Tcreate(H5T_COMPOUND, sizeof(IndexEntry)));
    H5Tinsert(index_type_.get(), "id", HOFFSET(IndexEntry, id), H5T_NATIVE_INT64);
    H5Tinsert(index_type_.get(), "ts", HOFFSET(IndexEntry, t_us), H5T_NATIVE_INT64);
    // ts is relative to the table's first time, which the `offset` attribute holds negated;
    // without it, the first event's time.
    if (const auto offset = attribute_text(indexes_.get(), "offset")) {
      std::int64_t v = 0;
      if (!parse_int(*offset, v) || v == std::numeric_limits<std::int64_t>::min())
        throw InputError(s.path, std::string("dataset ") + kIndexes,
                         "attribute 'offset' is not an integer: '" + *offset + "'");
      index_base_us_ = -v;
    } else if (rows_ > 0) {
      std::vector<Row> first;
      read(0, 1, first);
      index_base_us_ = first[0].t;
    }
  }

  hsize_t rows() const override { return rows_; }
  void read(hsize_t first, hsize_t n, std::vector<Row>& out) override {
    if (!exact_) return read_rows(s_, kEvents, events_.get(), row_type_.get(), first, n, out);
    read_rows(s_, kEvents, events_.get(), cd_type_.get(), first, n, cd_);
    out.resize(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = {cd_[i].t, cd_[i].x, cd_[i].y, cd_[i].p};
  }
  hsize_t index_rows() const override { return index_rows_; }
  std::string index_name() const override { return kIndexes; }
  void read_index(hsize_t first, hsize_t n, std::vector<IndexEntry>& out) override {
    read_rows(s_, kIndexes, indexes_.get(), index_type_.get(), first, n, out);
    // Entries with ts < 0 precede the table (Metavision's first entry is {0, -1}): no claim.
    std::erase_if(out, [](const IndexEntry& e) { return e.t_us < 0; });
    for (auto& e : out) e.t_us += index_base_us_;
  }
  std::int64_t t_offset_us() const override { return 0; }
  const std::string& filters() const { return filters_; }

 private:
  const Source& s_;
  Id events_, indexes_, row_type_, cd_type_, index_type_;
  bool exact_ = false;  ///< the file's type is CdEvent's
  std::vector<CdEvent> cd_;
  hsize_t rows_ = 0, index_rows_ = 0;
  std::int64_t index_base_us_ = 0;
  std::string filters_;
};

class DsecLayout final : public Layout {
 public:
  static constexpr const char* kIndex = "ms_to_idx";

  explicit DsecLayout(const Source& s) : s_(s) {
    const char* names[4] = {"events/x", "events/y", "events/t", "events/p"};
    for (int k = 0; k < 4; ++k) {
      if (!exists(s.file.get(), names[k]))
        throw InputError(s.path, std::string("dataset ") + names[k],
                         "missing (the DSEC layout has events/x, events/y, events/t and events/p)");
      columns_[k] = open_dataset(s, names[k]);
      const Id type(H5Dget_type(columns_[k].get()));
      require_integer(s, names[k], type.get(), "the column");
      const hsize_t n = length_1d(s, names[k], columns_[k].get());
      if (k == 0) rows_ = n;
      if (n != rows_)
        throw InputError(s.path, std::string("dataset ") + names[k],
                         std::to_string(n) + " rows, but events/x has " + std::to_string(rows_));
      filters_ += std::string(k ? "; " : "") + names[k] + ": " +
                  hdf5::check_filters(s.path, names[k], columns_[k].get());
    }
    if (exists(s.file.get(), "t_offset")) {
      const Id d = open_dataset(s, "t_offset");
      const Id type(H5Dget_type(d.get()));
      require_integer(s, "t_offset", type.get(), "the value");
      const Id space(H5Dget_space(d.get()));
      if (H5Sget_simple_extent_npoints(space.get()) != 1 ||
          H5Dread(d.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, &t_offset_us_) < 0)
        throw InputError(s.path, "dataset t_offset", "expected one integer [µs]");
    }
    if (exists(s.file.get(), kIndex)) {
      index_ = open_dataset(s, kIndex);
      const Id type(H5Dget_type(index_.get()));
      require_integer(s, kIndex, type.get(), "the index");
      hdf5::check_filters(s.path, kIndex, index_.get());
      index_rows_ = length_1d(s, kIndex, index_.get());
    }
  }

  hsize_t rows() const override { return rows_; }
  void read(hsize_t first, hsize_t n, std::vector<Row>& out) override {
    read_rows(s_, "events/t", columns_[2].get(), H5T_NATIVE_INT64, first, n, t_);
    read_rows(s_, "events/x", columns_[0].get(), H5T_NATIVE_INT32, first, n, x_);
    read_rows(s_, "events/y", columns_[1].get(), H5T_NATIVE_INT32, first, n, y_);
    read_rows(s_, "events/p", columns_[3].get(), H5T_NATIVE_INT32, first, n, p_);
    out.resize(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = {t_[i], x_[i], y_[i], p_[i]};
  }
  hsize_t index_rows() const override { return index_rows_; }
  std::string index_name() const override { return kIndex; }
  void read_index(hsize_t first, hsize_t n, std::vector<IndexEntry>& out) override {
    read_rows(s_, kIndex, index_.get(), H5T_NATIVE_INT64, first, n, ids_);
    out.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      out[i] = {ids_[i], static_cast<std::int64_t>(first + i) * 1000};  // entry k: k ms
  }
  std::int64_t t_offset_us() const override { return t_offset_us_; }
  const std::string& filters() const { return filters_; }

 private:
  const Source& s_;
  Id columns_[4], index_;
  hsize_t rows_ = 0, index_rows_ = 0;
  std::int64_t t_offset_us_ = 0;
  std::vector<std::int64_t> t_, ids_;
  std::vector<std::int32_t> x_, y_, p_;
  std::string filters_;
};

/// Checks the index against the table as it streams past: an entry {id, t} claims that event
/// `id` is the first at or after t (id = rows: no event is).
class IndexCheck {
 public:
  IndexCheck(Layout& layout, std::string path) : layout_(layout), path_(std::move(path)) {}

  /// `rows` are the table's rows [first, first + rows.size()).
  void check(hsize_t first, const std::vector<Row>& rows) {
    const auto end = static_cast<std::int64_t>(first + rows.size());
    while (const IndexEntry* e = peek()) {
      if (e->id >= end) break;
      if (e->id < last_id_ || e->id < static_cast<std::int64_t>(first))
        fail("event index " + std::to_string(e->id) + " goes back (the previous entry said " +
             std::to_string(last_id_) + ")");
      const std::int64_t t = rows[e->id - static_cast<std::int64_t>(first)].t;
      const bool has_prev = e->id > 0;
      const std::int64_t prev = e->id > static_cast<std::int64_t>(first)
                                    ? rows[e->id - static_cast<std::int64_t>(first) - 1].t
                                    : prev_t_;
      if (t < e->t_us || (has_prev && prev >= e->t_us))
        fail("says event " + std::to_string(e->id) + " is the first at or after " +
             std::to_string(e->t_us) + " µs, but it is at " + std::to_string(t) + " µs" +
             (has_prev ? " and the one before at " + std::to_string(prev) + " µs" : std::string()));
      advance();
    }
    if (!rows.empty()) prev_t_ = rows.back().t;
  }

  /// After the last row: entries left must point past the table's end.
  void finish(hsize_t table_rows) {
    while (const IndexEntry* e = peek()) {
      if (e->id != static_cast<std::int64_t>(table_rows))
        fail("event index " + std::to_string(e->id) + " is beyond the table's " +
             std::to_string(table_rows) + " rows");
      if (table_rows > 0 && prev_t_ >= e->t_us)
        fail("says no event is at or after " + std::to_string(e->t_us) + " µs, but the last is at " +
             std::to_string(prev_t_) + " µs");
      advance();
    }
  }

 private:
  const IndexEntry* peek() {
    while (pos_ == block_.size()) {
      if (next_row_ >= layout_.index_rows()) return nullptr;
      const hsize_t n = std::min<hsize_t>(kIndexBlock, layout_.index_rows() - next_row_);
      block_row_ = next_row_;
      layout_.read_index(next_row_, n, block_);
      next_row_ += n;
      pos_ = 0;
    }
    return &block_[pos_];
  }
  void advance() { last_id_ = block_[pos_++].id; }
  [[noreturn]] void fail(const std::string& why) {
    throw InputError(path_, "dataset " + layout_.index_name() + " near entry " + std::to_string(block_row_ + pos_),
                     "the index disagrees with the table: it " + why);
  }

  Layout& layout_;
  std::string path_;
  std::vector<IndexEntry> block_;
  std::size_t pos_ = 0;
  hsize_t next_row_ = 0, block_row_ = 0;
  std::int64_t last_id_ = 0, prev_t_ = std::numeric_limits<std::int64_t>::min();
};

/// "WxH" -> sides; false unless both are in 1..65535.
bool parse_geometry(const std::string& g, int& w, int& h) {
  const std::size_t x = g.find('x');
  std::int64_t a = 0, b = 0;
  if (x == std::string::npos || !parse_int(std::string_view(g).substr(0, x), a) ||
      !parse_int(std::string_view(g).substr(x + 1), b) || a < 1 || b < 1 || a > 65535 || b > 65535)
    return false;
  w = static_cast<int>(a);
  h = static_cast<int>(b);
  return true;
}

class Hdf5Reader final : public RecordingReader {
 public:
  Hdf5Reader(Id file, const std::string& path, const ReaderOptions& options)
      : chunk_events_(std::max<std::size_t>(1, options.chunk_events)) {
    source_.path = path;
    source_.file = std::move(file);
    info_.path = path;
    info_.streams = {StreamKind::kEvents};
    const hid_t f = source_.file.get();
    std::string filters;
    if (exists(f, MetavisionLayout::kEvents)) {
      auto m = std::make_unique<MetavisionLayout>(source_);
      info_.format = "hdf5_metavision";
      filters = m->filters();
      info_.notes.push_back("Metavision layout: CD/events, " +
                            std::string(m->index_rows() ? "index CD/indexes checked while reading"
                                                        : "no CD/indexes (nothing to check)"));
      layout_ = std::move(m);
    } else if (exists(f, "events")) {
      auto d = std::make_unique<DsecLayout>(source_);
      info_.format = "hdf5_dsec";
      filters = d->filters();
      info_.notes.push_back("DSEC layout: events/{x,y,t,p}, t_offset " + std::to_string(d->t_offset_us()) +
                            " µs, " + (d->index_rows() ? "ms_to_idx checked while reading" : "no ms_to_idx"));
      layout_ = std::move(d);
    } else {
      throw InputError(path, "dataset CD/events",
                       "missing: the file has neither Metavision's CD/events table nor DSEC's "
                       "events/{x,y,t,p} datasets");
    }
    info_.notes.push_back("compression: " + filters + " (HDF5 plugin path '" +
                          hdf5::use_default_plugin_path() + "')");
    info_.notes.push_back(std::to_string(layout_->rows()) + " events in the table");
    decide_geometry(options);
    sanitizer_.emplace(info_.width, info_.height);
    check_.emplace(*layout_, path);
  }

  const RecordingInfo& info() const override { return info_; }
  const ReadReport& report() const override { return report_; }

  bool read(SensorChunk& chunk) override {
    chunk.clear();
    while (chunk.events.empty() && next_row_ < layout_->rows()) {
      const hsize_t n = std::min<hsize_t>(chunk_events_, layout_->rows() - next_row_);
      layout_->read(next_row_, n, rows_);
      check_->check(next_row_, rows_);
      convert(next_row_, chunk.events);
      next_row_ += n;
      if (next_row_ == layout_->rows()) check_->finish(layout_->rows());
    }
    return !chunk.events.empty();
  }

 private:
  void decide_geometry(const ReaderOptions& options) {
    const hid_t f = source_.file.get();
    int w = 0, h = 0;
    std::string from;
    if (const auto g = attribute_text(f, "geometry")) {
      if (!parse_geometry(*g, w, h))
        throw InputError(source_.path, "attribute geometry", "expected WIDTHxHEIGHT, got '" + *g + "'");
      from = "the file's `geometry` attribute";
    } else if (const auto aw = attribute_text(f, "width"), ah = attribute_text(f, "height"); aw && ah) {
      if (!parse_geometry(*aw + "x" + *ah, w, h))
        throw InputError(source_.path, "attribute width", "width/height not integers in 1..65535");
      from = "the file's `width` and `height` attributes";
    } else if (options.width > 0 && options.height > 0) {
      w = options.width;
      h = options.height;
      from = "--resolution (the file does not say)";
    } else {
      throw InputError(source_.path, "attribute geometry",
                       "the file does not give the sensor size (no `geometry` or `width`/`height` "
                       "attribute): pass it with --resolution WxH (fdv.open(..., resolution=(W, H)))");
    }
    if ((options.width > 0 || options.height > 0) && (options.width != w || options.height != h))
      info_.notes.push_back("--resolution " + std::to_string(options.width) + "x" +
                            std::to_string(options.height) + " ignored: the file says " +
                            std::to_string(w) + "x" + std::to_string(h));
    info_.width = w;
    info_.height = h;
    info_.notes.push_back("sensor size " + std::to_string(w) + "x" + std::to_string(h) + ", from " + from);
  }

  void convert(hsize_t first, std::vector<Event>& out) {
    constexpr std::int64_t kMaxUs = std::numeric_limits<TimeNs>::max() / 1000;
    const std::int64_t offset = layout_->t_offset_us();
    events_.clear();
    event_rows_.clear();
    // Each kind of drop is reported at its first row, with the count of the chunk.
    struct Dropped {
      std::uint64_t count = 0;
      hsize_t first_row = 0;
      void add(hsize_t row) {
        if (count++ == 0) first_row = row;
      }
    } bad_polarity, outside, overflow;
    hsize_t row = first;
    for (const Row& r : rows_) {
      if (r.p != 0 && r.p != 1) {
        bad_polarity.add(row);
      } else if (r.x < 0 || r.y < 0 || r.x > 65535 || r.y > 65535) {
        outside.add(row);
      } else if (std::int64_t t = 0; __builtin_add_overflow(r.t, offset, &t) || t > kMaxUs || t < -kMaxUs) {
        overflow.add(row);
      } else {
        events_.push_back({t * 1000, static_cast<std::uint16_t>(r.x), static_cast<std::uint16_t>(r.y), r.p == 1});
        event_rows_.push_back(row);
      }
      ++row;
    }
    auto at = [](hsize_t r) { return "row " + std::to_string(r); };
    if (bad_polarity.count) report_.drop("event polarity not 0 or 1", at(bad_polarity.first_row), bad_polarity.count);
    if (outside.count) report_.drop("event pixel outside the sensor", at(outside.first_row), outside.count);
    if (overflow.count)
      report_.drop("event time beyond the int64 nanosecond range", at(overflow.first_row), overflow.count);
    sanitizer_->append(events_.data(), events_.data() + events_.size(), out, report_,
                       [&](std::size_t i) { return at(event_rows_[i]); });
  }

  Source source_;
  std::vector<hsize_t> event_rows_;  ///< the table row of each of events_
  std::size_t chunk_events_;
  RecordingInfo info_;
  ReadReport report_;
  std::unique_ptr<Layout> layout_;
  std::optional<EventSanitizer> sanitizer_;
  std::optional<IndexCheck> check_;
  hsize_t next_row_ = 0;
  std::vector<Row> rows_;
  std::vector<Event> events_;
};

Id open_file(const std::string& name, hid_t fapl) {
  hdf5::quiet_errors();
  hdf5::use_default_plugin_path();
  Id file(H5Fopen(name.c_str(), H5F_ACC_RDONLY, fapl));
  if (!file.valid()) throw InputError(name, "", "not a readable HDF5 file: " + hdf5::last_error());
  return file;
}

}  // namespace

namespace hdf5 {

std::unique_ptr<RecordingReader> open_reader(const std::string& path, const ReaderOptions& options) {
  return std::make_unique<Hdf5Reader>(open_file(path, H5P_DEFAULT), path, options);
}

std::unique_ptr<RecordingReader> open_reader_image(std::string image, const std::string& name,
                                                   const ReaderOptions& options) {
  hdf5::quiet_errors();
  Id fapl(H5Pcreate(H5P_FILE_ACCESS));
  // The core driver reads from memory; the image is copied into HDF5's own buffer.
  if (H5Pset_fapl_core(fapl.get(), 1 << 16, false) < 0 ||
      H5Pset_file_image(fapl.get(), image.data(), image.size()) < 0)
    throw InputError(name, "", "cannot hand the image to HDF5: " + hdf5::last_error());
  return std::make_unique<Hdf5Reader>(open_file(name, fapl.get()), name, options);
}

}  // namespace hdf5
}  // namespace fdv
