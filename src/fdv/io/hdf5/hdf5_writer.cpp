#include "fdv/io/hdf5/hdf5_writer.h"

#include <cstdint>
#include <vector>

#include "fdv/core/error.h"
#include "fdv/io/hdf5/hdf5_plugin_api.h"
#include "fdv/io/hdf5/hdf5_support.h"

namespace fdv {
namespace {
using hdf5::Id;

/// Index period of Metavision's CD/indexes [µs].
constexpr std::int64_t kIndexPeriodUs = 2000;

using hdf5::CdEvent;
struct IndexRow {
  std::uint64_t id;
  std::int64_t ts;
};

/// Hdf5EventWriter's work: the tables, their index and the file.
class TableWriter final : public hdf5::EventWriterBackend {
 public:
  TableWriter(const std::string& path, int width, int height, const Hdf5WriterOptions& options);
  ~TableWriter() override = default;
  void add(std::span<const Event> batch) override;
  void close() override;
  std::uint64_t events() const override { return count; }
  std::uint64_t floored_events() const override { return floored; }

 private:
  std::string path;
  Hdf5WriterOptions options;
  Id file, event_table, index_table, event_type, index_type;
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
    append(event_table.get(), event_type.get(), pending, written, "CD/events");
    append(index_table.get(), index_type.get(), pending_index, index_written, "CD/indexes");
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(path, "", what + ": " + hdf5::last_error());
  }
};

}  // namespace

TableWriter::TableWriter(const std::string& file_path, int width, int height,
                         const Hdf5WriterOptions& writer_options)
    : path(file_path), options(writer_options) {
  hdf5::quiet_errors();
  file = Id(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  if (!file.valid()) fail("cannot create the file");
  const Id group(H5Gcreate2(file.get(), "CD", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!group.valid()) fail("cannot create group CD");

  event_type = Id(H5Tcreate(H5T_COMPOUND, sizeof(CdEvent)));
  H5Tinsert(event_type.get(), "x", HOFFSET(CdEvent, x), H5T_STD_U16LE);
  H5Tinsert(event_type.get(), "y", HOFFSET(CdEvent, y), H5T_STD_U16LE);
  H5Tinsert(event_type.get(), "p", HOFFSET(CdEvent, p), H5T_STD_I16LE);
  H5Tinsert(event_type.get(), "t", HOFFSET(CdEvent, t), H5T_STD_I64LE);
  index_type = Id(H5Tcreate(H5T_COMPOUND, sizeof(IndexRow)));
  H5Tinsert(index_type.get(), "id", HOFFSET(IndexRow, id), H5T_STD_U64LE);
  H5Tinsert(index_type.get(), "ts", HOFFSET(IndexRow, ts), H5T_STD_I64LE);
  event_table = make_table("CD/events", event_type.get());
  index_table = make_table("CD/indexes", index_type.get());

  const std::string geometry = std::to_string(width) + "x" + std::to_string(height);
  const Id str(H5Tcopy(H5T_C_S1));
  H5Tset_size(str.get(), geometry.size());
  const Id scalar(H5Screate(H5S_SCALAR));
  const Id attr(H5Acreate2(file.get(), "geometry", str.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attr.valid() || H5Awrite(attr.get(), str.get(), geometry.data()) < 0)
    fail("cannot write attribute geometry");
}

void TableWriter::add(std::span<const Event> batch) {
  if (closed) throw ConfigError(path + ": add() after close()");
  for (const Event& e : batch) {
    const std::int64_t t = floor_us(e.t);
    if (!started) {
      started = true;
      first_us = next_bucket_us = last_us = t;
      pending_index.push_back({0, -1});  // Metavision's leading entry: no claim
    }
    if (t < last_us)
      throw InputError(path, "event " + std::to_string(count),
                       "time goes backwards (" + std::to_string(t) + " µs after " + std::to_string(last_us) + " µs)");
    if (t * 1000 != e.t) ++floored;
    // One entry per period started, naming this event (the first at or after it).
    while (t >= next_bucket_us) {
      pending_index.push_back({count, t - first_us});
      next_bucket_us += kIndexPeriodUs;
    }
    last_us = t;
    pending.push_back({e.x, e.y, static_cast<std::int16_t>(e.polarity ? 1 : 0), t});
    ++count;
    if (pending.size() >= options.chunk_rows) flush();
  }
  if (pending_index.size() >= options.chunk_rows) flush();
}

void TableWriter::close() {
  if (closed) return;
  closed = true;
  flush();
  const std::string offset = std::to_string(-first_us);
  const Id str(H5Tcopy(H5T_C_S1));
  H5Tset_size(str.get(), offset.size());
  const Id scalar(H5Screate(H5S_SCALAR));
  const Id attr(H5Acreate2(index_table.get(), "offset", str.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attr.valid() || H5Awrite(attr.get(), str.get(), offset.data()) < 0) fail("cannot write CD/indexes offset");
  event_table.reset();
  index_table.reset();
  if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) fail("cannot flush");
  file.reset();
}

std::unique_ptr<hdf5::EventWriterBackend> hdf5::create_writer(const std::string& path, int width, int height,
                                                            const Hdf5WriterOptions& options) {
  return std::make_unique<TableWriter>(path, width, height, options);
}

}  // namespace fdv
