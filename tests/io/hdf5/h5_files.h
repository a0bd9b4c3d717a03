#pragma once
// Test inputs written with the HDF5 C API directly, independent of fdv's HDF5 writer: the
// Metavision layout as its format page describes it, the DSEC layout as the dataset ships it,
// and damaged variants of both.
#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace fdv::test::h5 {

struct CdEvent {  // Metavision EventCD: x u16 @0, y u16 @2, p i16 @4, t i64 @8
  std::uint16_t x, y;
  std::int16_t p;
  std::int64_t t;
};
struct IndexRow {
  std::uint64_t id;
  std::int64_t ts;
};

inline hid_t cd_type() {
  const hid_t t = H5Tcreate(H5T_COMPOUND, sizeof(CdEvent));
  H5Tinsert(t, "x", HOFFSET(CdEvent, x), H5T_STD_U16LE);
  H5Tinsert(t, "y", HOFFSET(CdEvent, y), H5T_STD_U16LE);
  H5Tinsert(t, "p", HOFFSET(CdEvent, p), H5T_STD_I16LE);
  H5Tinsert(t, "t", HOFFSET(CdEvent, t), H5T_STD_I64LE);
  return t;
}

inline void string_attribute(hid_t loc, const char* name, const std::string& value) {
  const hid_t str = H5Tcopy(H5T_C_S1);
  H5Tset_size(str, value.size());
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(loc, name, str, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(a, str, value.data());
  H5Aclose(a);
  H5Sclose(space);
  H5Tclose(str);
}

/// A one-dimensional dataset of `n` rows of `type`, chunked by `chunk` rows (0: contiguous),
/// with `filter` (0: none; H5Z_FILTER_DEFLATE: gzip 4; another id: that filter, optional).
inline void write_table(hid_t loc, const char* name, hid_t file_type, hid_t mem_type, const void* rows,
                        hsize_t n, hsize_t chunk = 0, H5Z_filter_t filter = 0) {
  const hid_t space = H5Screate_simple(1, &n, nullptr);
  const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
  chunk = std::min(chunk, n);  // a fixed-size dataset cannot have a larger chunk
  if (chunk > 0) H5Pset_chunk(dcpl, 1, &chunk);
  if (filter == H5Z_FILTER_DEFLATE) H5Pset_deflate(dcpl, 4);
  else if (filter != 0) H5Pset_filter(dcpl, filter, H5Z_FLAG_OPTIONAL, 0, nullptr);
  const hid_t d = H5Dcreate2(loc, name, file_type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
  if (n > 0) H5Dwrite(d, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, rows);
  H5Dclose(d);
  H5Pclose(dcpl);
  H5Sclose(space);
}

/// Metavision's index of `events` (times in µs): {0, -1}, then per 2 ms period from the first
/// time the first event at or after it and that event's time relative to the first.
inline std::vector<IndexRow> metavision_index(const std::vector<CdEvent>& events) {
  std::vector<IndexRow> index{{0, -1}};
  if (events.empty()) return index;
  const std::int64_t first = events.front().t;
  std::int64_t next = first;
  for (std::size_t i = 0; i < events.size(); ++i)
    for (; events[i].t >= next; next += 2000) index.push_back({i, events[i].t - first});
  return index;
}

struct MetavisionFile {
  std::vector<CdEvent> events = {};
  std::vector<IndexRow> index = {};  ///< empty: metavision_index(events)
  std::string geometry = "640x480";  ///< empty: no attribute
  hsize_t chunk = 16384;
  H5Z_filter_t filter = 0;
  bool with_index = true;
};

inline void write_metavision(const std::string& path, MetavisionFile f) {
  if (f.index.empty()) f.index = metavision_index(f.events);
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t cd = H5Gcreate2(file, "CD", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t type = cd_type();
  write_table(cd, "events", type, type, f.events.data(), f.events.size(), f.chunk, f.filter);
  if (f.with_index) {
    const hid_t it = H5Tcreate(H5T_COMPOUND, sizeof(IndexRow));
    H5Tinsert(it, "id", HOFFSET(IndexRow, id), H5T_STD_U64LE);
    H5Tinsert(it, "ts", HOFFSET(IndexRow, ts), H5T_STD_I64LE);
    write_table(cd, "indexes", it, it, f.index.data(), f.index.size(), 1024);
    const hid_t d = H5Dopen2(cd, "indexes", H5P_DEFAULT);
    if (!f.events.empty()) string_attribute(d, "offset", std::to_string(-f.events.front().t));
    H5Dclose(d);
    H5Tclose(it);
  }
  if (!f.geometry.empty()) string_attribute(file, "geometry", f.geometry);
  H5Tclose(type);
  H5Gclose(cd);
  H5Fclose(file);
}

struct DsecFile {
  std::vector<std::uint16_t> x, y;
  std::vector<std::uint32_t> t;  ///< µs, before t_offset
  std::vector<std::uint8_t> p;
  std::int64_t t_offset = 0;
  hsize_t chunk = 0;
  H5Z_filter_t filter = 0;
};

inline void write_dsec(const std::string& path, const DsecFile& f) {
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t g = H5Gcreate2(file, "events", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  write_table(g, "x", H5T_STD_U16LE, H5T_NATIVE_UINT16, f.x.data(), f.x.size(), f.chunk, f.filter);
  write_table(g, "y", H5T_STD_U16LE, H5T_NATIVE_UINT16, f.y.data(), f.y.size(), f.chunk, f.filter);
  write_table(g, "t", H5T_STD_U32LE, H5T_NATIVE_UINT32, f.t.data(), f.t.size(), f.chunk, f.filter);
  write_table(g, "p", H5T_STD_U8LE, H5T_NATIVE_UINT8, f.p.data(), f.p.size(), f.chunk, f.filter);
  // ms_to_idx[k]: the first event at or after k ms; one entry past the last event's millisecond.
  std::vector<std::uint64_t> ms_to_idx;
  const std::uint32_t last = f.t.empty() ? 0 : f.t.back();
  for (std::uint64_t k = 0, i = 0; k <= last / 1000 + 1; ++k) {
    while (i < f.t.size() && f.t[i] < k * 1000) ++i;
    ms_to_idx.push_back(i);
  }
  write_table(file, "ms_to_idx", H5T_STD_U64LE, H5T_NATIVE_UINT64, ms_to_idx.data(), ms_to_idx.size());
  const hid_t scalar = H5Screate(H5S_SCALAR);
  const hid_t d = H5Dcreate2(file, "t_offset", H5T_STD_I64LE, scalar, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Dwrite(d, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, &f.t_offset);
  H5Dclose(d);
  H5Sclose(scalar);
  H5Gclose(g);
  H5Fclose(file);
}

}  // namespace fdv::test::h5
