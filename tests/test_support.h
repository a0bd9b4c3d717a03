#pragma once
// Shared helpers for tests: where the real recordings are, scratch folders, running a command.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "fdv/core/error.h"
#include "fdv/io/read_report.h"

namespace fdv::test {

/// "where | reason" of the InputError that `parse()` throws, which must name `file`; "no error"
/// when it throws none.
template <class Parse>
std::string input_error_of(const std::string& file, Parse&& parse) {
  try {
    parse();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file);
    return e.where() + " | " + e.reason();
  }
  return "no error";
}

/// Path of a real recording in ../shared/data/real. If the folder is absent (a clone without
/// shared/), the test is skipped, unless FDV_REQUIRE_REAL_DATA=1 (CI) makes that a failure.
inline std::string real_data(const std::string& name) {
  return std::string(FDV_REAL_DATA_DIR) + "/" + name;
}

#define FDV_REQUIRE_REAL_FILE(path)                                                    \
  do {                                                                                 \
    if (!std::filesystem::exists(path)) {                                              \
      const char* req = std::getenv("FDV_REQUIRE_REAL_DATA");                          \
      if (req && std::string(req) == "1") FAIL() << "missing real recording " << path; \
      GTEST_SKIP() << "real recording not found: " << path;                            \
    }                                                                                  \
  } while (0)

/// Path of an input in ../shared/fuzz-findings (a reader's past crash, hang or foreign error);
/// guard it with FDV_REQUIRE_REAL_FILE like a real recording.
inline std::string fuzz_finding(const std::string& name) {
  return std::string(FDV_FUZZ_FINDINGS_DIR) + "/" + name;
}

/// A fresh, empty scratch folder for one test.
inline std::string scratch_dir(const std::string& name) {
  const auto dir = std::filesystem::path(FDV_TEST_TMP_DIR) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

/// What a command run through the shell left: its exit code (-1 when killed by a signal) and what
/// it wrote to stdout and stderr.
struct CommandRun {
  int exit_code = -1;
  std::string out, err;
};

/// Runs `command` with stdout and stderr captured to `log_stem`.out / .err in the tests' scratch
/// folder (kept for a failing test's reader).
inline CommandRun run_command(const std::string& command, const std::string& log_stem) {
  const auto dir = std::filesystem::path(FDV_TEST_TMP_DIR) / "command_logs";
  std::filesystem::create_directories(dir);
  const auto out = dir / (log_stem + ".out"), err = dir / (log_stem + ".err");
  const int status = std::system((command + " > '" + out.string() + "' 2> '" + err.string() + "'").c_str());
  auto slurp = [](const std::filesystem::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  };
  CommandRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

/// An in-memory stream holding `s`, for the readers that take one.
inline std::unique_ptr<std::istream> text(const std::string& s) {
  return std::make_unique<std::istringstream>(s);
}

/// Writes `text` to the file at `path`, replacing it.
inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

/// How many records `report` says were dropped, or repaired, for `reason` (0 when none were).
inline std::uint64_t dropped(const ReadReport& report, const std::string& reason) {
  const auto it = report.dropped().find(reason);
  return it == report.dropped().end() ? 0 : it->second.count;
}
inline std::uint64_t repaired(const ReadReport& report, const std::string& reason) {
  const auto it = report.repaired().find(reason);
  return it == report.repaired().end() ? 0 : it->second.count;
}
/// Where the first record dropped for `reason` was ("" when none was).
inline std::string first_where(const ReadReport& report, const std::string& reason) {
  const auto it = report.dropped().find(reason);
  return it == report.dropped().end() ? "" : it->second.first_where;
}

}  // namespace fdv::test
