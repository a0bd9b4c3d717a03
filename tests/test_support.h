#pragma once
// Shared helpers for tests: where the real recordings are, and scratch folders.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "fdv/core/error.h"

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

}  // namespace fdv::test
