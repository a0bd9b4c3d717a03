// HDF5 reader: files written here with the HDF5 C API (h5_files.h), read through open_recording
// and compared event by event with what was written.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "fdv/core/error.h"
#include "fdv/io/hdf5/hdf5_reader.h"
#include "fdv/io/recording.h"
#include "h5_files.h"
#include "test_support.h"

namespace fdv {
namespace {
namespace h5 = test::h5;

/// Events with gaps of 0..3 ms (so some 2 ms periods are empty and some times repeat).
std::vector<h5::CdEvent> some_events(std::size_t n, std::int64_t t0 = 1'000'000) {
  std::mt19937 rng(7);
  std::vector<h5::CdEvent> out;
  std::int64_t t = t0;
  for (std::size_t i = 0; i < n; ++i) {
    t += std::uniform_int_distribution<int>(0, 9)(rng) == 0 ? 3000 : std::uniform_int_distribution<int>(0, 40)(rng);
    out.push_back({static_cast<std::uint16_t>(rng() % 640), static_cast<std::uint16_t>(rng() % 480),
                   static_cast<std::int16_t>(rng() % 2), t});
  }
  return out;
}

std::vector<Event> read_all(RecordingReader& r) {
  std::vector<Event> out;
  SensorChunk c;
  while (r.read(c)) out.insert(out.end(), c.events.begin(), c.events.end());
  return out;
}

void expect_same(const std::vector<h5::CdEvent>& written, const std::vector<Event>& read,
                 std::int64_t offset_us = 0) {
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    const Event want{(written[i].t + offset_us) * 1000, written[i].x, written[i].y, written[i].p == 1};
    ASSERT_EQ(read[i], want) << "event " << i;
  }
}

ReaderOptions chunked(std::size_t n) {
  ReaderOptions o;
  o.chunk_events = n;
  return o;
}

TEST(Hdf5Reader, MetavisionLayoutReadsEveryEventInChunks) {
  const std::string path = test::scratch_dir("hdf5_metavision") + "/cd.h5";
  const auto events = some_events(5000);
  h5::write_metavision(path, {.events = events, .chunk = 1000});
  for (std::size_t chunk : {7u, 1000u, 65536u}) {
    auto r = open_recording(path, chunked(chunk));
    EXPECT_EQ(r->info().format, "hdf5_metavision");
    EXPECT_EQ(r->info().width, 640);
    EXPECT_EQ(r->info().height, 480);
    expect_same(events, read_all(*r));
    EXPECT_EQ(r->report().total_dropped(), 0u);
  }
}

TEST(Hdf5Reader, GzipCompressedTableReadsTheSame) {
  const std::string path = test::scratch_dir("hdf5_gzip") + "/cd.h5";
  const auto events = some_events(3000);
  h5::write_metavision(path, {.events = events, .chunk = 512, .filter = H5Z_FILTER_DEFLATE});
  auto r = open_recording(path, chunked(100));
  expect_same(events, read_all(*r));
}

TEST(Hdf5Reader, DsecLayoutAddsTOffsetAndNeedsTheResolution) {
  const std::string path = test::scratch_dir("hdf5_dsec") + "/events.h5";
  const auto events = some_events(4000, 0);
  h5::DsecFile f;
  for (const auto& e : events) {
    f.x.push_back(e.x);
    f.y.push_back(e.y);
    f.t.push_back(static_cast<std::uint32_t>(e.t));
    f.p.push_back(static_cast<std::uint8_t>(e.p));
  }
  f.t_offset = 1'600'000'000'000'000;  // an epoch time in µs, as DSEC's
  f.chunk = 512;
  h5::write_dsec(path, f);
  EXPECT_EQ(test::input_error_of(path, [&] { open_recording(path); }),
            "attribute geometry | the file does not give the sensor size (no `geometry` or `width`/`height` "
            "attribute): pass it with --resolution WxH (fdv.open(..., resolution=(W, H)))");
  ReaderOptions o = chunked(333);
  o.width = 640;
  o.height = 480;
  auto r = open_recording(path, o);
  EXPECT_EQ(r->info().format, "hdf5_dsec");
  expect_same(events, read_all(*r), f.t_offset);
}

TEST(Hdf5Reader, InMemoryImageReadsLikeTheFile) {
  const std::string path = test::scratch_dir("hdf5_image") + "/cd.h5";
  const auto events = some_events(100);
  h5::write_metavision(path, {.events = events});
  std::ifstream in(path, std::ios::binary);
  std::string image((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto r = open_hdf5_image(image, "memory.h5");
  expect_same(events, read_all(*r));
}

TEST(Hdf5Reader, PolarityOutsideZeroOneIsACountedDrop) {
  const std::string path = test::scratch_dir("hdf5_polarity") + "/cd.h5";
  auto events = some_events(10);
  events[4].p = -1;
  h5::write_metavision(path, {.events = events});
  auto r = open_recording(path);
  EXPECT_EQ(read_all(*r).size(), 9u);
  EXPECT_EQ(r->report().dropped().at("event polarity not 0 or 1").count, 1u);
}

// ------------------------------------------------------------------------------ bad input

TEST(Hdf5BadInput, MissingEventsTable) {
  const std::string path = test::scratch_dir("hdf5_missing") + "/x.h5";
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  H5Gclose(H5Gcreate2(file, "CD", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  H5Fclose(file);
  EXPECT_EQ(test::input_error_of(path, [&] { open_recording(path); }),
            "dataset CD/events | missing: the file has neither Metavision's CD/events table nor DSEC's "
            "events/{x,y,t,p} datasets");
}

TEST(Hdf5BadInput, MistypedEventsTable) {
  const std::string dir = test::scratch_dir("hdf5_mistyped");
  {  // a compound without t
    const hid_t file = H5Fcreate((dir + "/no_t.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t cd = H5Gcreate2(file, "CD", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t t = H5Tcreate(H5T_COMPOUND, 8);
    H5Tinsert(t, "x", 0, H5T_STD_U16LE);
    H5Tinsert(t, "y", 2, H5T_STD_U16LE);
    H5Tinsert(t, "p", 4, H5T_STD_I16LE);
    const char row[8] = {};
    h5::write_table(cd, "events", t, t, row, 1);
    H5Fclose(file);
  }
  EXPECT_EQ(test::input_error_of(dir + "/no_t.h5", [&] { open_recording(dir + "/no_t.h5"); }),
            "dataset CD/events | has no field 't' (expected integer fields x, y, p, t)");
  {  // floats instead of a compound
    const hid_t file = H5Fcreate((dir + "/float.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t cd = H5Gcreate2(file, "CD", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const double rows[3] = {1, 2, 3};
    h5::write_table(cd, "events", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, rows, 3);
    H5Fclose(file);
  }
  EXPECT_EQ(test::input_error_of(dir + "/float.h5", [&] { open_recording(dir + "/float.h5"); }),
            "dataset CD/events | not a compound table (expected integer fields x, y, p, t)");
}

TEST(Hdf5BadInput, IndexThatDisagreesWithTheTable) {
  const std::string dir = test::scratch_dir("hdf5_bad_index");
  const auto events = some_events(2000);
  auto index = h5::metavision_index(events);
  ASSERT_GT(index.size(), 20u);
  index[10].id += 1;  // now names an event after the first of its period
  h5::write_metavision(dir + "/off.h5", {.events = events, .index = index});
  const std::string off = test::input_error_of(dir + "/off.h5", [&] {
    auto r = open_recording(dir + "/off.h5", chunked(64));
    read_all(*r);
  });
  EXPECT_TRUE(off.starts_with("dataset CD/indexes near entry")) << off;
  EXPECT_NE(off.find("the index disagrees with the table: it says event " + std::to_string(index[10].id) +
                     " is the first at or after"),
            std::string::npos)
      << off;

  index = h5::metavision_index(events);
  index.back().id = events.size() + 5;  // beyond the table
  h5::write_metavision(dir + "/beyond.h5", {.events = events, .index = index});
  const std::string beyond = test::input_error_of(dir + "/beyond.h5", [&] { read_all(*open_recording(dir + "/beyond.h5")); });
  EXPECT_NE(beyond.find("event index 2005 is beyond the table's 2000 rows"), std::string::npos) << beyond;
}

/// A pass-through filter registered only while the test writes, so that the file names a filter
/// that the reader then does not have.
herr_t register_dummy_filter(H5Z_filter_t id) {
  static H5Z_class2_t cls;
  cls = {H5Z_CLASS_T_VERS, id, 1, 1, "test dummy", nullptr, nullptr,
         [](unsigned, size_t, const unsigned[], size_t n, size_t*, void**) -> size_t { return n; }};
  return H5Zregister(&cls);
}

TEST(Hdf5BadInput, UnavailableFilterAndEcfNameTheFilter) {
  const std::string dir = test::scratch_dir("hdf5_filter");
  const auto events = some_events(100);
  for (H5Z_filter_t id : {H5Z_filter_t{32999}, H5Z_filter_t{36559}}) {
    ASSERT_GE(register_dummy_filter(id), 0);
    h5::write_metavision(dir + "/" + std::to_string(id) + ".h5", {.events = events, .chunk = 64, .filter = id});
    ASSERT_GE(H5Zunregister(id), 0);
  }
  const std::string unknown = test::input_error_of(dir + "/32999.h5", [&] { open_recording(dir + "/32999.h5"); });
  EXPECT_TRUE(unknown.starts_with("dataset CD/events | filter 32999 (test dummy) is not available: install its plugin"))
      << unknown;
  EXPECT_EQ(test::input_error_of(dir + "/36559.h5", [&] { open_recording(dir + "/36559.h5"); }),
            "dataset CD/events | compressed with Prophesee's ECF codec (HDF5 filter 36559), which Debian "
            "does not ship: convert the RAW recording instead (`fdv convert REC.raw --to hdf5 OUT.h5`), or "
            "put Prophesee's hdf5_ecf plugin in HDF5_PLUGIN_PATH");
}

TEST(Hdf5BadInput, TruncatedFileIsAnErrorNamingTheFile) {
  const std::string dir = test::scratch_dir("hdf5_truncated");
  h5::write_metavision(dir + "/whole.h5", {.events = some_events(20000), .chunk = 1024});
  const auto size = std::filesystem::file_size(dir + "/whole.h5");
  for (double keep : {0.9, 0.5, 0.01}) {
    const std::string cut = dir + "/cut.h5";
    std::filesystem::copy_file(dir + "/whole.h5", cut, std::filesystem::copy_options::overwrite_existing);
    std::filesystem::resize_file(cut, static_cast<std::uintmax_t>(static_cast<double>(size) * keep));
    const std::string why = test::input_error_of(cut, [&] { read_all(*open_recording(cut)); });
    EXPECT_NE(why.find("truncated"), std::string::npos) << keep << ": " << why;
  }
}

}  // namespace
}  // namespace fdv
