// Every input of ../shared/fuzz-findings (each once crashed, hung, blew up memory or stopped
// `fdv` with a foreign message), run through the built `fdv` as its README says, must now end as
// that README expects: a clear error on stderr naming the file, exit code 1, or for the inputs
// that are readable, a summary. A run that does not end within kHangSeconds is killed and fails
// (a hang, not a timing measurement); peak memory is read from the kernel's rusage.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "test_support.h"

namespace fdv {
namespace {
namespace fs = std::filesystem;

constexpr int kHangSeconds = 60;
constexpr long kMaxResidentKiB = 1024L * 1024L;  // 1 GiB, the README's bound

struct GuardedRun {
  int exit_code = -1;       ///< -1 when killed by a signal
  int signal = 0;
  bool hung = false;
  long max_resident_kib = 0;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

/// Runs `fdv args...` with stdout and stderr captured to files.
GuardedRun run_fdv(const std::vector<std::string>& args) {
  const fs::path dir = fs::path(FDV_TEST_TMP_DIR) / "fuzz_findings_output";
  fs::create_directories(dir);
  const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const pid_t pid = fork();
  if (pid == 0) {
    if (!std::freopen(out.c_str(), "w", stdout) || !std::freopen(err.c_str(), "w", stderr)) _exit(127);
    std::vector<char*> argv{const_cast<char*>(FDV_BINARY)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(FDV_BINARY, argv.data());
    _exit(127);
  }
  GuardedRun r;
  int status = 0;
  rusage usage{};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(kHangSeconds);
  while (wait4(pid, &status, WNOHANG, &usage) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      r.hung = true;
      kill(pid, SIGKILL);
      wait4(pid, &status, 0, &usage);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  r.max_resident_kib = usage.ru_maxrss;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

void expect_ended_cleanly(const GuardedRun& r, const std::string& file) {
  EXPECT_FALSE(r.hung) << file << ": still running after " << kHangSeconds << " s";
  EXPECT_EQ(r.signal, 0) << file << ": killed by signal " << r.signal << "\n" << r.err;
  EXPECT_LT(r.max_resident_kib, kMaxResidentKiB) << file << ": peak resident memory";
}

/// Exit code 1 and an error line on stderr that names the file (and `also`, when given).
void expect_clear_error(const GuardedRun& r, const std::string& file, const std::string& also = "") {
  expect_ended_cleanly(r, file);
  EXPECT_EQ(r.exit_code, 1) << file << "\n" << r.err;
  EXPECT_NE(r.err.find(file), std::string::npos) << "the error does not name the file:\n" << r.err;
  if (!also.empty()) {
    EXPECT_NE(r.err.find(also), std::string::npos) << "the error does not name " << also << ":\n" << r.err;
  }
  for (const char* foreign : {"terminate called", "basic_string", "OpenCV(", "bad conversion", "BadSubscript",
                              "type_error", "yaml-cpp"})
    EXPECT_EQ(r.err.find(foreign), std::string::npos) << "a foreign message:\n" << r.err;
}

/// `fdv info` printed its JSON summary (exit 0); returns it.
nlohmann::json expect_summary(const GuardedRun& r, const std::string& file) {
  expect_ended_cleanly(r, file);
  EXPECT_EQ(r.exit_code, 0) << file << "\n" << r.err;
  try {
    return nlohmann::json::parse(r.out);
  } catch (const nlohmann::json::exception& e) {
    ADD_FAILURE() << file << ": stdout is not the JSON summary: " << e.what();
    return {};
  }
}

/// A clear error, or a summary whose reader report counts the bad records as dropped.
void expect_error_or_reported_drop(const GuardedRun& r, const std::string& file) {
  if (r.exit_code == 0) {
    const auto summary = expect_summary(r, file);
    EXPECT_FALSE(summary["report"]["dropped"].empty()) << file << ": nothing reported dropped\n" << r.out;
  } else {
    expect_clear_error(r, file);
  }
}

std::string finding(const std::string& name) { return test::fuzz_finding(name); }
std::string any_recording() { return test::real_data("davis346_ball_throw_person.aedat4"); }

TEST(FuzzFindings, Aedat4HeaderWithoutXmlRootIsAnError) {
  for (const auto* name : {"aedat4/f1-header-xml-no-root.aedat4", "aedat4/f1-header-xml-comment-only.aedat4"}) {
    const auto file = finding(name);
    FDV_REQUIRE_REAL_FILE(file);
    expect_clear_error(run_fdv({"info", file}), file);
  }
}

TEST(FuzzFindings, Aedat4ZstdBombIsAnErrorNamingThePacket) {
  const auto file = finding("aedat4/f7-zstd-bomb.aedat4");
  FDV_REQUIRE_REAL_FILE(file);
  expect_clear_error(run_fdv({"info", file}), file, "packet");
}

TEST(FuzzFindings, HostileCalibrationsAreClearErrors) {
  FDV_REQUIRE_REAL_FILE(any_recording());
  const fs::path out = test::scratch_dir("fuzz_findings_run");
  const fs::path dir = finding("calibration");
  FDV_REQUIRE_REAL_FILE(dir);
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string file = entry.path().string();
    const std::string name = entry.path().filename().string();
    // The oversized matrix must be named by its key (the other files fail on a YAML syntax
    // error first, which is named by its line).
    const std::string key = name == "f9-opencv-huge-matrix.yaml" ? "key camera_matrix" : "";
    expect_clear_error(run_fdv({"run", any_recording(), "--calib", file, "--out", out.string()}), file, key);
    ++files;
  }
  EXPECT_EQ(files, 12);
}

TEST(FuzzFindings, OptionsWithANonScalarKeyAreAClearError) {
  FDV_REQUIRE_REAL_FILE(any_recording());
  const auto file = finding("options/f9-non-scalar-key.yaml");
  FDV_REQUIRE_REAL_FILE(file);
  const fs::path out = test::scratch_dir("fuzz_findings_run");
  expect_clear_error(run_fdv({"run", any_recording(), "--config", file, "--out", out.string()}), file);
}

TEST(FuzzFindings, Ros2TimeOverflowsAreDroppedOrErrors) {
  for (const auto* name : {"ros2/f4-libcaer-time-base.db3", "ros2/f4-libcaer-time-overflow-1.db3",
                           "ros2/f4-libcaer-time-overflow-2.db3", "ros2/f4-mono-offset.db3",
                           "ros2/f4-mono-time-base.db3"}) {
    const auto file = finding(name);
    FDV_REQUIRE_REAL_FILE(file);
    expect_error_or_reported_drop(run_fdv({"info", file}), file);
  }
}

TEST(FuzzFindings, Ros2TopicSpanOverflowGivesASummaryOrAnError) {
  const auto file = finding("ros2/f5-topic-span-overflow.db3");
  FDV_REQUIRE_REAL_FILE(file);
  const GuardedRun r = run_fdv({"info", file});
  if (r.exit_code == 0) {
    const auto summary = expect_summary(r, file);
    for (const auto& topic : summary["topics"]) EXPECT_GE(topic["rate_hz"].get<double>(), 0.0) << topic;
  } else {
    expect_clear_error(r, file);
  }
}

TEST(FuzzFindings, Ros2FolderWithScalarMetadataIsAnErrorNamingIt) {
  const auto dir = finding("ros2/f9-scalar-metadata-folder");
  FDV_REQUIRE_REAL_FILE(dir);
  expect_clear_error(run_fdv({"info", dir}), dir, "metadata.yaml");
}

TEST(FuzzFindings, Evt2EpochOverflowIsDroppedOrAnError) {
  const auto gz = finding("evt2/f6-epoch-overflow.raw.gz");
  FDV_REQUIRE_REAL_FILE(gz);
  const fs::path file = fs::path(test::scratch_dir("fuzz_findings_evt2")) / "f6-epoch-overflow.raw";
  ASSERT_EQ(std::system(("gzip -dc '" + gz + "' > '" + file.string() + "'").c_str()), 0);
  expect_error_or_reported_drop(run_fdv({"info", file.string()}), file.string());
}

TEST(FuzzFindings, NonUtf8RawHeadersGiveTheSummaryWithTheBytesEscaped) {
  for (const auto* name : {"evt2/f8-non-utf8-header-1.raw", "evt2/f8-non-utf8-header-2.raw"}) {
    const auto file = finding(name);
    FDV_REQUIRE_REAL_FILE(file);
    const auto summary = expect_summary(run_fdv({"info", file}), file);
    EXPECT_NE(summary.dump().find("\\\\x"), std::string::npos) << "no escaped byte in " << summary.dump();
  }
}

}  // namespace
}  // namespace fdv
