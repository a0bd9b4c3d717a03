// HDF5 writer: read back with the HDF5 C API directly (the layout as Metavision's readers expect
// it) and through fdv's reader. python/tests/test_hdf5.py reads the same kind of file with h5py.
#include <gtest/gtest.h>

#include "fdv/core/error.h"
#include "fdv/io/hdf5/hdf5_writer.h"
#include "fdv/io/recording.h"
#include "h5_files.h"
#include "test_support.h"

namespace fdv {
namespace {
namespace h5 = test::h5;

std::vector<Event> sample_events(std::size_t n) {
  std::vector<Event> out;
  TimeNs t = 5'000'000'000;
  for (std::size_t i = 0; i < n; ++i) {
    t += (i % 97 == 0) ? 4'500'000 : static_cast<TimeNs>(i % 13) * 1000;
    out.push_back({t, static_cast<std::uint16_t>(i * 7 % 346), static_cast<std::uint16_t>(i * 11 % 260), i % 3 == 0});
  }
  return out;
}

std::vector<h5::CdEvent> read_table(const std::string& path) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t d = H5Dopen2(f, "CD/events", H5P_DEFAULT);
  const hid_t space = H5Dget_space(d);
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space, &n, nullptr);
  std::vector<h5::CdEvent> rows(n);
  const hid_t type = h5::cd_type();
  H5Dread(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, rows.data());
  H5Tclose(type);
  H5Sclose(space);
  H5Dclose(d);
  H5Fclose(f);
  return rows;
}

TEST(Hdf5Writer, TableHoldsTheEventsInMicrosecondsAndOurReaderReadsThemBack) {
  for (int gzip : {0, 4}) {
    const std::string path = test::scratch_dir("hdf5_writer_" + std::to_string(gzip)) + "/out.h5";
    const auto events = sample_events(40000);
    {
      Hdf5EventWriter w(path, 346, 260, {.gzip_level = gzip, .chunk_rows = 4096});
      w.add(std::span(events).first(12345));
      w.add(std::span(events).subspan(12345));
      w.close();
      EXPECT_EQ(w.events(), events.size());
      EXPECT_EQ(w.floored_events(), 0u);  // every time above is a whole µs
    }
    const auto rows = read_table(path);
    ASSERT_EQ(rows.size(), events.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      ASSERT_EQ(rows[i].t * 1000, events[i].t) << i;
      ASSERT_EQ(rows[i].x, events[i].x) << i;
      ASSERT_EQ(rows[i].y, events[i].y) << i;
      ASSERT_EQ(rows[i].p, events[i].polarity ? 1 : 0) << i;
    }
    ReaderOptions o;
    o.chunk_events = 1000;
    auto r = open_recording(path, o);  // checks CD/indexes as it reads
    EXPECT_EQ(r->info().width, 346);
    EXPECT_EQ(r->info().height, 260);
    std::vector<Event> back;
    SensorChunk c;
    while (r->read(c)) back.insert(back.end(), c.events.begin(), c.events.end());
    EXPECT_EQ(back, events);
  }
}

TEST(Hdf5Writer, SubMicrosecondTimesAreFlooredAndCounted) {
  const std::string path = test::scratch_dir("hdf5_writer_floor") + "/out.h5";
  const std::vector<Event> events{{1'000'500, 1, 1, true}, {1'001'000, 2, 2, false}, {-1'500, 3, 3, true}};
  Hdf5EventWriter w(path, 10, 10);
  w.add(std::span(events).first(2));
  EXPECT_EQ(test::input_error_of(path, [&] { w.add(std::span(events).subspan(2)); }),
            "event 2 | time goes backwards (-2 µs after 1001 µs)");
  w.close();
  EXPECT_EQ(w.floored_events(), 1u);
  const auto rows = read_table(path);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].t, 1000);
  EXPECT_EQ(rows[1].t, 1001);
}

TEST(Hdf5Writer, SensorLargerThanUint16IsAConfigError) {
  const std::string path = test::scratch_dir("hdf5_writer_big") + "/out.h5";
  EXPECT_THROW(Hdf5EventWriter(path, 70000, 10), ConfigError);
}

}  // namespace
}  // namespace fdv
