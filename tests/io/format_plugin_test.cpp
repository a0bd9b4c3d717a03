// Loading the format plugins (fdv/io/format_plugin.h): where they are looked for, what a missing
// or foreign plugin gives, and that the program itself links none of their libraries.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>
#include <string>

#include "fdv/core/error.h"
#include "fdv/io/format_plugin.h"
#include "fdv/io/hdf5/hdf5_writer.h"
#include "fdv/io/recording.h"
#include "test_support.h"

namespace fdv {
namespace {

/// Sets FDV_PLUGIN_PATH for one test.
class PluginPath {
 public:
  explicit PluginPath(const std::string& value) { ::setenv("FDV_PLUGIN_PATH", value.c_str(), 1); }
  ~PluginPath() { ::unsetenv("FDV_PLUGIN_PATH"); }
};

std::string load_error(const std::string& name, const char* entry) {
  try {
    load_plugin_api(name, entry, "input.xyz");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(FormatPlugin, SearchPathIsTheEnvironmentThenBesideThenTheBuildAndInstallFolders) {
  const PluginPath env("/first/a:/first/b");
  const std::vector<std::string> path = plugin_search_path();
  ASSERT_GE(path.size(), 4u);
  EXPECT_EQ(path[0], "/first/a");
  EXPECT_EQ(path[1], "/first/b");
  EXPECT_NE(std::find(path.begin(), path.end(), FDV_TEST_PLUGIN_BUILD_DIR), path.end());
  // The test program's own folder: fdv_plugins beside it.
  EXPECT_NE(std::find(path.begin(), path.end(), std::string(FDV_TEST_BINARY_DIR) + "/fdv_plugins"), path.end());
}

TEST(FormatPlugin, AMissingPluginIsAnErrorNamingTheInputThePluginAndTheFolders) {
  const PluginPath env("/no/such/folder");
  const std::string what = load_error("no_such_format", "fdv_no_such_format_plugin_api");
  EXPECT_NE(what.find("input.xyz"), std::string::npos) << what;
  EXPECT_NE(what.find("libfdv_no_such_format.so"), std::string::npos) << what;
  EXPECT_NE(what.find("/no/such/folder"), std::string::npos) << what;
}

TEST(FormatPlugin, APluginBuiltForAnotherVersionIsRefused) {
  const PluginPath env(FDV_TEST_STALE_PLUGIN_DIR);
  const std::string what = load_error("stale", "fdv_stale_plugin_api");
  EXPECT_NE(what.find("built for fdv 0.0.0/0, not " + std::string(plugin_abi())), std::string::npos) << what;
}

// Through the public functions: the HDF5 writer and reader load libfdv_hdf5.so.
TEST(FormatPlugin, Hdf5GoesThroughItsPlugin) {
  const std::string file = test::scratch_dir("format_plugin") + "/events.h5";
  {
    Hdf5EventWriter out(file, 8, 4);
    out.add(std::vector<Event>{{1000, 1, 2, true}, {2000, 7, 3, false}});
    out.close();
  }
  auto reader = open_recording(file);
  SensorChunk chunk;
  std::size_t events = 0;
  while (reader->read(chunk)) events += chunk.events.size();
  EXPECT_EQ(events, 2u);
  EXPECT_EQ(reader->info().width, 8);
}

// The point of the plugins: the command line links neither HDF5 nor ROS, and only the plugins do.
TEST(FormatPlugin, TheProgramLinksNoneOfThePluginsLibraries) {
  const auto linked_libraries = [](const std::string& file) {
    const auto listed = test::run_command(FDV_TEST_LIST_SHARED_LIBRARIES " " + file, "format_plugin_ldd");
    EXPECT_NE(listed.out.find("libc.so"), std::string::npos) << "no libraries listed for " << file;
    return listed.out;
  };
  const std::string program = linked_libraries(FDV_TEST_CLI);
  for (const char* library : {"libhdf5", "librosbag_storage", "libroslib", "libpython", "libcurl", "libgdal"})
    EXPECT_EQ(program.find(library), std::string::npos) << library << " in\n" << program;
  EXPECT_NE(linked_libraries(std::string(FDV_TEST_PLUGIN_BUILD_DIR) + "/libfdv_hdf5.so").find("libhdf5"), std::string::npos);
  EXPECT_NE(linked_libraries(std::string(FDV_TEST_PLUGIN_BUILD_DIR) + "/libfdv_ros1.so").find("librosbag_storage"),
            std::string::npos);
}

// The program links its third-party libraries from Debian's static archives where the build found
// them (cmake/fdv_static_third_party.cmake): none of those libraries is loaded as a shared one.
TEST(FormatPlugin, TheProgramLoadsNoSharedCopyOfWhatItLinksStatically) {
  const std::string archives = FDV_TEST_STATIC_ARCHIVES;
  if (archives.empty()) GTEST_SKIP() << "no static archives found at configure time";
  const auto listed = test::run_command(FDV_TEST_LIST_SHARED_LIBRARIES " " FDV_TEST_CLI, "format_plugin_ldd");
  ASSERT_NE(listed.out.find("libc.so"), std::string::npos) << listed.out;
  std::size_t begin = 0;
  while (begin <= archives.size()) {
    const std::size_t end = std::min(archives.find(',', begin), archives.size());
    const std::string shared = "lib" + archives.substr(begin, end - begin) + ".so";
    EXPECT_EQ(listed.out.find(shared), std::string::npos) << shared << " in\n" << listed.out;
    begin = end + 1;
  }
}

}  // namespace
}  // namespace fdv
