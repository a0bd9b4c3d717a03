#include "fdv/io/hdf5/hdf5_writer.h"

#include <cstdint>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/hdf5/hdf5_support.h"

namespace fdv {
namespace {
using hdf5::Id;

/// Index period of Metavision's CD/indexes [µs].
constexpr std::int64_t kIndexPeriodUs = 2000;

struct CdEvent {  // Metavision's EventCD record: 16 bytes, t at byte 8
  std::uint16_t x, y;
  std::int16_t p;
  std::int64_t t;
};
struct IndexRow {
  std::uint64_t id;
  std::int64_t ts;
};

std::int64_t floor_us(TimeNs t) { return t >= 0 ? t / 1000 : -((-t + 999) / 1000); }

}  // namespace

struct Hdf5EventWriter::State {
  std::string path;
  Hdf5WriterOptions options;
  Id file, events, indexes, event_type, index_type;
  std::vector<CdEvent> pending;
  std::vector<IndexRow> pending_index;
  std::uint64_t written = 0, index_written = 0, count = 0, floored = 0;
  std::int64_t first_us = 0, next_bucket_us = 0, last_us = 0;
  bool started = false, closed = false;

  Id make_table(const char* name, hid_t type) {
    const hsize_t zero = 0, unlimited = H5S_UNLIMITED, chunk = options.chunk_rows;
    const Id space(H5Screate_simple(1, &zero, &unlimited));
    const Id dcpl(H5Pcreate(H5P_DATASET_CREATE));
    H5Pset_chunk(dcpl.get(), 1, &chunk);
    if (options.gzip_level > 0) H5Pset_deflate(dcpl.get(), static_cast<unsigned>(options.gzip_level));
    Id d(H5Dcreate2(file.get(), name, type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
    if (!d.valid()) fail(std::string("cannot create dataset ") + name);
    return d;
  }

  template <typename T>
  void append(hid_t dset, hid_t type, std::vector<T>& rows, std::uint64_t& done, const char* name) {
    if (rows.empty()) return;
    const hsize_t first = done, n = rows.size(), total = done + rows.size();
    if (H5Dset_extent(dset, &total) < 0) fail(std::string("cannot extend ") + name);
    const Id file_space(H5Dget_space(dset));
    const Id mem_space(H5Screate_simple(1, &n, nullptr));
    if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &first, nullptr, &n, nullptr) < 0 ||
        H5Dwrite(dset, type, mem_space.get(), file_space.get(), H5P_DEFAULT, rows.data()) < 0)
      fail(std::string("cannot write ") + name);
    done = total;
    rows.clear();
  }

  void flush() {
    append(events.get(), event_type.get(), pending, written, "CD/events");
    append(indexes.get(), index_type.get(), pending_index, index_written, "CD/indexes");
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(path, "", what + ": " + hdf5::last_error());
  }
};

std::string Hdf5WriterOptions::validate() const {
  if (gzip_level < 0 || gzip_level > 9) return "gzip_level must be 0..9, got " + std::to_string(gzip_level);
  if (chunk_rows == 0) return "chunk_rows must be > 0";
  return {};
}

Hdf5EventWriter::Hdf5EventWriter(const std::string& path, int width, int height,
                                 const Hdf5WriterOptions& options)
    : state_(std::make_unique<State>()) {
  if (const std::string why = options.validate(); !why.empty()) throw ConfigError("Hdf5WriterOptions: " + why);
  if (width < 1 || height < 1 || width > 65536 || height > 65536)
    throw ConfigError(path + ": HDF5 (Metavision layout) holds pixels as uint16: sensor size " +
                      std::to_string(width) + "x" + std::to_string(height) + " is outside 1..65536");
  State& s = *state_;
  s.path = path;
  s.options = options;
  hdf5::quiet_errors();
  s.file = Id(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!s.file.valid()) s.fail("cannot create the file");
  const Id group(H5Gcreate2(s.file.get(), "CD", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!group.valid()) s.fail("cannot create group CD");

  s.event_type = Id(H5Tcreate(H5T_COMPOUND, sizeof(CdEvent)));
  H5Tinsert(s.event_type.get(), "x", HOFFSET(CdEvent, x), H5T_STD_U16LE);
  H5Tinsert(s.event_type.get(), "y", HOFFSET(CdEvent, y), H5T_STD_U16LE);
  H5Tinsert(s.event_type.get(), "p", HOFFSET(CdEvent, p), H5T_STD_I16LE);
  H5Tinsert(s.event_type.get(), "t", HOFFSET(CdEvent, t), H5T_STD_I64LE);
  s.index_type = Id(H5Tcreate(H5T_COMPOUND, sizeof(IndexRow)));
  H5Tinsert(s.index_type.get(), "id", HOFFSET(IndexRow, id), H5T_STD_U64LE);
  H5Tinsert(s.index_type.get(), "ts", HOFFSET(IndexRow, ts), H5T_STD_I64LE);
  s.events = s.make_table("CD/events", s.event_type.get());
  s.indexes = s.make_table("CD/indexes", s.index_type.get());

  const std::string geometry = std::to_string(width) + "x" + std::to_string(height);
  const Id str(H5Tcopy(H5T_C_S1));
  H5Tset_size(str.get(), geometry.size());
  const Id scalar(H5Screate(H5S_SCALAR));
  const Id attr(H5Acreate2(s.file.get(), "geometry", str.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attr.valid() || H5Awrite(attr.get(), str.get(), geometry.data()) < 0)
    s.fail("cannot write attribute geometry");
}

Hdf5EventWriter::~Hdf5EventWriter() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; close() explicitly to see the error
  }
}

void Hdf5EventWriter::add(std::span<const Event> events) {
  State& s = *state_;
  if (s.closed) throw ConfigError(s.path + ": add() after close()");
  for (const Event& e : events) {
    const std::int64_t t = floor_us(e.t);
    if (!s.started) {
      s.started = true;
      s.first_us = s.next_bucket_us = s.last_us = t;
      s.pending_index.push_back({0, -1});  // Metavision's leading entry: no claim
    }
    if (t < s.last_us)
      throw InputError(s.path, "event " + std::to_string(s.count),
                       "time goes backwards (" + std::to_string(t) + " µs after " + std::to_string(s.last_us) + " µs)");
    if (t * 1000 != e.t) ++s.floored;
    // One entry per period started, naming this event (the first at or after it).
    while (t >= s.next_bucket_us) {
      s.pending_index.push_back({s.count, t - s.first_us});
      s.next_bucket_us += kIndexPeriodUs;
    }
    s.last_us = t;
    s.pending.push_back({e.x, e.y, static_cast<std::int16_t>(e.polarity ? 1 : 0), t});
    ++s.count;
    if (s.pending.size() >= s.options.chunk_rows) s.flush();
  }
  if (s.pending_index.size() >= s.options.chunk_rows) s.flush();
}

void Hdf5EventWriter::close() {
  State& s = *state_;
  if (s.closed) return;
  s.closed = true;
  s.flush();
  const std::string offset = std::to_string(-s.first_us);
  const Id str(H5Tcopy(H5T_C_S1));
  H5Tset_size(str.get(), offset.size());
  const Id scalar(H5Screate(H5S_SCALAR));
  const Id attr(H5Acreate2(s.indexes.get(), "offset", str.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attr.valid() || H5Awrite(attr.get(), str.get(), offset.data()) < 0) s.fail("cannot write CD/indexes offset");
  s.events.reset();
  s.indexes.reset();
  if (H5Fflush(s.file.get(), H5F_SCOPE_GLOBAL) < 0) s.fail("cannot flush");
  s.file.reset();
}

std::uint64_t Hdf5EventWriter::events() const { return state_->count; }
std::uint64_t Hdf5EventWriter::floored_events() const { return state_->floored; }

}  // namespace fdv
