// `fdv run` and `fdv eval` as a user runs them: the built binary on a small simulated dataset (with
// exact ground truth) and on real recordings; the files they write are read back and checked
// against the names the README and the issues give, and against the simulator's truth.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.h"

namespace fdv {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

struct Ran {
  int exit_code = -1;
  std::string output;  // stdout, then stderr
};

/// Runs `fdv ARGS`, capturing its output.
Ran fdv(const std::string& args) {
  const test::CommandRun r = test::run_command(std::string(FDV_BINARY) + " " + args, "cli_test_last");
  return {r.exit_code, r.out + r.err};
}

json read_json(const fs::path& p) {
  std::ifstream f(p);
  EXPECT_TRUE(f.good()) << p;
  return json::parse(f);
}

std::vector<json> read_lines(const fs::path& p) {
  std::ifstream f(p);
  EXPECT_TRUE(f.good()) << p;
  std::vector<json> out;
  for (std::string line; std::getline(f, line);) out.push_back(json::parse(line));
  return out;
}

bool has_warning(const json& summary, const std::string& part) {
  for (const auto& w : summary.at("warnings"))
    if (w.get<std::string>().find(part) != std::string::npos) return true;
  return false;
}

/// A copy of the dataset without some of its files (a stream the user's recording lacks).
fs::path dataset_without(const fs::path& dataset, const std::vector<std::string>& files, const std::string& name) {
  const fs::path copy = test::scratch_dir("cli_" + name);
  fs::copy(dataset, copy, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  for (const auto& f : files) fs::remove_all(copy / f);
  return copy;
}

class Cli : public ::testing::Test {
 protected:
  // fast_forward seed 3 at 320x240: a ball thrown across a vehicle flying at 2 m/s, 1 s, ~1.3 s to simulate.
  static void SetUpTestSuite() {
    dataset_ = test::scratch_dir("cli_dataset");
    const Ran r = fdv("simulate --scenario fast_forward --seed 3 --resolution 320x240 --threads 2 --out " + dataset_.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static fs::path dataset_;
};
fs::path Cli::dataset_;

TEST_F(Cli, RunWritesEveryOutputWithItsDocumentedFieldsAndEvalScoresItAgainstTheTruth) {
  const fs::path out = test::scratch_dir("cli_run");
  const Ran r = fdv("run " + dataset_.string() + " --visualize --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;

  const json summary = read_json(out / "summary.json");
  EXPECT_EQ(summary.at("method_requested"), "rotation_translation");
  EXPECT_EQ(summary.at("method"), "rotation_translation");
  const json& counts = summary.at("counts");
  const auto windows = counts.at("windows").get<std::uint64_t>();
  EXPECT_EQ(windows, 40u);  // 1 s in 25 ms windows
  EXPECT_EQ(counts.at("events_read").get<std::uint64_t>(), counts.at("events").get<std::uint64_t>());  // no overload
  for (const char* stage : {"compensation", "time_images", "detection_total", "window_total"}) {
    const json& t = summary.at("timing_ms").at(stage);
    EXPECT_EQ(t.at("count").get<std::uint64_t>(), windows) << stage;
    EXPECT_LE(t.at("min").get<double>(), t.at("median").get<double>()) << stage;
    EXPECT_LE(t.at("median").get<double>(), t.at("p99").get<double>()) << stage;
    EXPECT_LE(t.at("p99").get<double>(), t.at("max").get<double>()) << stage;
  }
  EXPECT_TRUE(summary.at("warnings").empty()) << summary.at("warnings");

  // detections.jsonl: one object per window with its fields, in the input's time base.
  const std::vector<json> lines = read_lines(out / "detections.jsonl");
  ASSERT_EQ(lines.size(), windows);
  int detections = 0;
  for (const json& w : lines) {
    const double t0 = w.at("t_start"), t1 = w.at("t_end");
    EXPECT_NEAR(t1 - t0, 0.025, 1e-9);
    EXPECT_GE(w.at("events").get<int>(), 0);
    EXPECT_EQ(w.at("method"), "rotation_translation");
    for (const json& d : w.at("detections")) {
      ++detections;
      ASSERT_EQ(d.at("box").size(), 4u);
      ASSERT_EQ(d.at("center").size(), 2u);
      const double x = d.at("center")[0], y = d.at("center")[1];
      EXPECT_TRUE(x >= 0 && x < 320 && y >= 0 && y < 240) << d;
      EXPECT_TRUE(d.at("t").get<double>() >= t0 && d.at("t").get<double>() <= t1) << d;
      EXPECT_GT(d.at("events").get<int>(), 0);
      EXPECT_TRUE(d.at("score").get<double>() > 0 && d.at("score").get<double>() <= 1) << d;
    }
  }
  EXPECT_EQ(detections, counts.at("detections").get<int>());
  // --visualize: a PNG per window.
  int pngs = 0;
  for (const auto& f : fs::directory_iterator(out / "windows")) pngs += f.path().extension() == ".png";
  EXPECT_EQ(pngs, static_cast<int>(windows));

  // trajectories.jsonl: every row an estimate, fusion among them.
  int fusion = 0;
  for (const json& e : read_lines(out / "trajectories.jsonl")) {
    EXPECT_TRUE(e.at("method") == "fusion" || e.at("method") == "mono") << e;
    EXPECT_NE(e.at("fit"), "none") << e;
    EXPECT_EQ(e.at("p0").size(), 3u);
    EXPECT_EQ(e.at("v0").size(), 3u);
    EXPECT_GT(e.at("event_observations").get<int>(), 0);
    EXPECT_TRUE(e.contains("t") && e.contains("track") && e.contains("t0") && e.contains("depth_observations"));
    if (e.contains("covariance")) {
      EXPECT_EQ(e.at("covariance").size(), 36u);
    }
    fusion += e.at("method") == "fusion";
  }
  EXPECT_GT(fusion, 0);
  int with_sigma = 0;
  for (const json& p : read_lines(out / "predictions.jsonl")) {
    EXPECT_GE(p.at("miss_distance").get<double>(), 0);
    EXPECT_EQ(p.at("passage_B").size(), 3u);
    // Absent where a depth frame's estimate holds events newer than the frame (no risk then).
    if (!p.contains("miss_distance_sigma")) continue;
    EXPECT_GT(p.at("miss_distance_sigma").get<double>(), 0) << p;
    ++with_sigma;
  }
  EXPECT_GT(with_sigma, 0);
  EXPECT_FALSE(read_lines(out / "depth.jsonl").empty());
  // TUM: `t x y z qx qy qz qw`, time increasing.
  std::ifstream tum(out / "track_1_fusion.tum");
  ASSERT_TRUE(tum.good());
  double t_prev = -1;
  int rows = 0;
  for (std::string line; std::getline(tum, line); ++rows) {
    std::istringstream s(line);
    std::vector<double> v;
    for (double x; s >> x;) v.push_back(x);
    ASSERT_EQ(v.size(), 8u) << line;
    EXPECT_GT(v[0], t_prev);
    t_prev = v[0];
    EXPECT_EQ(v[7], 1.0);
  }
  EXPECT_GT(rows, 10);

  // fdv eval against the simulator's truth: the ball found, its trajectory within 0.3 m.
  const Ran e = fdv("eval " + out.string() + " --truth " + dataset_.string());
  ASSERT_EQ(e.exit_code, 0) << e.output;
  const json metrics = read_json(out / "metrics.json");
  EXPECT_GE(metrics.at("detection").at("recall").get<double>(), 0.8) << metrics.at("detection");
  bool fusion_ape = false;
  for (const json& a : metrics.at("ape"))
    if (a.at("method") == "fusion") {
      fusion_ape = true;
      EXPECT_LT(a.at("rmse").get<double>(), 0.3) << a;
    }
  EXPECT_TRUE(fusion_ape);
  EXPECT_FALSE(metrics.at("prediction_error").empty());
  // detection_pairs.csv lists the (window, ball) pairs the any-size recall counts.
  std::ifstream pairs(out / "detection_pairs.csv");
  std::string line;
  ASSERT_TRUE(std::getline(pairs, line));
  EXPECT_EQ(line,
            "t_start_s,t_end_s,ball,size_px,fraction_in_view_min,partial,fills_view,found,center_error_px,"
            "track,u_min,v_min,u_max,v_max");
  int eligible = 0, found = 0;
  while (std::getline(pairs, line)) {
    std::vector<std::string> cells;
    std::stringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 14u) << line;
    if (cells[6] == "1") continue;  // fills the view: listed, not scored
    ++eligible;
    found += cells[7] == "1";
  }
  const json& any_size = metrics.at("detection").at("any_size");
  EXPECT_EQ(eligible, any_size.at("eligible_windows").get<int>());
  EXPECT_EQ(found, any_size.at("detected").get<int>());
  EXPECT_GT(found, 0);
}

TEST_F(Cli, TheRequestedMethodIsReportedWhetherItComesFromTheConfigFileOrTheCommandLine) {
  const fs::path out = test::scratch_dir("cli_method");
  std::ofstream(out / "config.yaml") << "compensation: {method: none}\n";
  Ran r = fdv("run " + dataset_.string() + " --config " + (out / "config.yaml").string() + " --out " + (out / "a").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  json s = read_json(out / "a" / "summary.json");
  EXPECT_EQ(s.at("method_requested"), "none");
  EXPECT_EQ(s.at("method"), "none");
  r = fdv("run " + dataset_.string() + " --config " + (out / "config.yaml").string() + " --method rotation --out " +
          (out / "b").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  s = read_json(out / "b" / "summary.json");
  EXPECT_EQ(s.at("method_requested"), "rotation");
  EXPECT_EQ(s.at("method"), "rotation");
}

TEST_F(Cli, SummaryHoldsTheEffectiveOptionsAndPrintConfigReadsBackIdentically) {
  const fs::path out = test::scratch_dir("cli_options");
  std::ofstream(out / "config.yaml") << "threads: 2\ntracking: {max_tracks: 3, max_gap_ms: 80}\n";
  const std::string config = " --config " + (out / "config.yaml").string();
  Ran r = fdv("run " + dataset_.string() + config + " --method rotation --out " + (out / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json options = read_json(out / "run" / "summary.json").at("options");
  EXPECT_EQ(options.at("threads"), 2);
  EXPECT_EQ(options.at("tracking").at("max_tracks"), 3);
  EXPECT_EQ(options.at("tracking").at("max_gap_ms"), 80.0);
  EXPECT_EQ(options.at("compensation").at("method"), "rotation");
  for (const char* section : {"compensation", "detector", "depth_registration", "tracking", "depth_segmentation",
                              "estimation", "prediction"})
    EXPECT_TRUE(options.at(section).is_object()) << section;

  // --print-config: what --config reads back to the same options (flags included), and nothing else.
  r = fdv("run --print-config" + config + " --method rotation");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("threads: 2\n"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("  method: rotation\n"), std::string::npos) << r.output;
  std::ofstream(out / "printed.yaml") << r.output;
  const Ran again = fdv("run --print-config --config " + (out / "printed.yaml").string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(again.output, r.output);
}

TEST_F(Cli, MissingStreamsFallBackAndSaySo) {
  // No IMU: no compensation is possible ("none"), said.
  fs::path in = dataset_without(dataset_, {"imu.csv"}, "no_imu");
  fs::path out = test::scratch_dir("cli_no_imu_out");
  Ran r = fdv("run " + in.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  json s = read_json(out / "summary.json");
  EXPECT_EQ(s.at("method"), "none");
  EXPECT_TRUE(has_warning(s, "no IMU")) << s.at("warnings");
  EXPECT_NE(r.output.find("no IMU"), std::string::npos);

  // No odometry: detection goes on, no 3D estimate, and the user is told how to declare a static vehicle.
  in = dataset_without(dataset_, {"odometry.csv"}, "no_odometry");
  out = test::scratch_dir("cli_no_odometry_out");
  r = fdv("run " + in.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  s = read_json(out / "summary.json");
  EXPECT_EQ(s.at("method"), "rotation");
  EXPECT_GT(s.at("counts").at("detections").get<int>(), 0);
  EXPECT_EQ(s.at("counts").at("estimates").get<int>(), 0);
  EXPECT_TRUE(has_warning(s, "no odometry")) << s.at("warnings");
  EXPECT_TRUE(has_warning(s, "--assume-static")) << s.at("warnings");

  // No depth: event-only estimates, said.
  in = dataset_without(dataset_, {"depth.csv", "depth"}, "no_depth");
  out = test::scratch_dir("cli_no_depth_out");
  r = fdv("run " + in.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  s = read_json(out / "summary.json");
  EXPECT_TRUE(has_warning(s, "no depth frames: 3D estimates are event-only")) << s.at("warnings");
  for (const json& e : read_lines(out / "trajectories.jsonl")) EXPECT_EQ(e.at("fit"), "event-only") << e;
}

TEST_F(Cli, SamplesTheReaderDropsAreWarnedAbout) {
  // Two odometry rows swapped: the later one goes back in time and is dropped by the reader.
  const fs::path in = dataset_without(dataset_, {}, "odometry_swapped");
  std::vector<std::string> rows;
  {
    std::ifstream f(in / "odometry.csv");
    for (std::string line; std::getline(f, line);) rows.push_back(line);
  }
  ASSERT_GT(rows.size(), 20u);
  std::swap(rows[10], rows[11]);
  {
    std::ofstream f(in / "odometry.csv");
    for (const auto& row : rows) f << row << "\n";
  }
  const fs::path out = test::scratch_dir("cli_odometry_swapped_out");
  const Ran r = fdv("run " + in.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json s = read_json(out / "summary.json");
  EXPECT_TRUE(has_warning(s, "the reader dropped 1 record(s): odometry")) << s.at("warnings");
}

TEST(CliRealRecording, ABareRawFileIsDetectedInPixelCoordinatesAndSaysSo) {
  const std::string path = test::real_data("gen3_sparks_evt2.raw");
  FDV_REQUIRE_REAL_FILE(path);
  const fs::path out = test::scratch_dir("cli_raw");
  const Ran r = fdv("run " + path + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json s = read_json(out / "summary.json");
  EXPECT_EQ(s.at("method"), "none");
  EXPECT_EQ(s.at("calibration").get<std::string>().rfind("none", 0), 0u) << s.at("calibration");
  EXPECT_TRUE(has_warning(s, "no calibration")) << s.at("warnings");
  EXPECT_FALSE(has_warning(s, "no odometry")) << s.at("warnings");  // said once, by "no calibration"
  EXPECT_EQ(s.at("counts").at("events_read").get<std::uint64_t>(), 521'252u);  // shared/data/README.md
  // A static camera declared: still no 3D estimate, the focal length is made up.
  const Ran declared = fdv("run " + path + " --assume-static --out " + (out / "static").string());
  ASSERT_EQ(declared.exit_code, 0) << declared.output;
  const json d = read_json(out / "static" / "summary.json");
  EXPECT_EQ(d.at("counts").at("estimates").get<int>(), 0);
  EXPECT_TRUE(has_warning(d, "--assume-static ignored")) << d.at("warnings");
}

TEST(CliVersion, PrintsTheProjectVersionAndNeedsNoSubcommand) {
  const Ran r = fdv("--version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, "fdv " FDV_PROJECT_VERSION "\n");
}

TEST(CliBadInput, AMissingInputIsAClearErrorNamingThePath) {
  const fs::path out = test::scratch_dir("cli_missing");
  const Ran r = fdv("run " + (out / "no_such_recording.aedat4").string() + " --out " + (out / "o").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("no_such_recording.aedat4"), std::string::npos) << r.output;
}

TEST(CliDemo, AConfigThatDoesNotLoadIsAClearErrorBeforeAnySimulation) {
  const fs::path out = test::scratch_dir("cli_demo_config");
  const fs::path config = out / "bad.yaml";
  std::ofstream(config) << "dodge:\n  limits:\n    max_tilt_deg: 0\n";
  const Ran r = fdv("demo --config " + config.string() + " --out " + (out / "demo").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("bad.yaml"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("max_tilt_deg"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "demo" / "dataset"));
}

// `fdv dodge-eval` on one throw (random_throw seed 6: 346x260, a hovering vehicle, a threat
// passing 7 cm from the body; about 6 s): the file's keys, the simulated
// truth against the drawn throw, and --keep's folders.
TEST(CliDodgeEval, OneThrowGivesTheTotalsTheBaselinesAndItsRow) {
  const fs::path out = test::scratch_dir("cli_dodge_eval");
  const Ran r = fdv("dodge-eval --seeds 6 --jobs 1 --keep --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* method :
       {"| ours |", "| point_estimate |", "| mono |", "| rotation |", "| oracle |", "| oracle_visible |"})
    EXPECT_NE(r.output.find(method), std::string::npos) << method << "\n" << r.output;
  const json e = read_json(out / "dodge_eval.json");
  const char* keys[] = {"threats", "escaped", "non_threats", "false_alarms", "near_misses"};
  for (const char* key : keys) EXPECT_TRUE(e.contains(key)) << key;
  for (const char* baseline : {"point_estimate", "mono", "rotation", "oracle", "oracle_visible"})
    for (const char* key : keys) EXPECT_TRUE(e.at("baselines").at(baseline).contains(key)) << baseline << " " << key;
  ASSERT_EQ(e.at("throws").size(), 1u);
  const json& row = e.at("throws").at(0);
  EXPECT_EQ(row.at("seed"), 6);
  EXPECT_EQ(row.at("parameters").at("seed"), 6);
  // The simulated truth passes at the drawn miss distance, and the threat is the drawn one.
  EXPECT_NEAR(row.at("true_miss_m").get<double>(), row.at("parameters").at("miss_distance_m").get<double>(), 0.01);
  EXPECT_EQ(row.at("threat").get<bool>(), row.at("parameters").at("threat").get<bool>());
  EXPECT_EQ(e.at("threats").get<int>() + e.at("non_threats").get<int>() + e.at("near_misses").get<int>(), 1);
  // The oracles know a threat for certain, from the first detection or the first window the ball
  // is plainly in view, which comes no later: they manoeuvre, oracle_visible no later.
  if (row.at("threat").get<bool>()) {
    EXPECT_TRUE(row.at("outcomes").at("oracle").at("maneuvered").get<bool>());
    EXPECT_TRUE(row.at("outcomes").at("oracle_visible").at("maneuvered").get<bool>());
    EXPECT_LE(row.at("outcomes").at("oracle_visible").at("decision_t_s").get<double>(),
              row.at("outcomes").at("oracle").at("decision_t_s").get<double>());
  }
  EXPECT_LE(row.at("first_in_view_t_s").get<double>(), row.at("first_detection_t_s").get<double>());
  EXPECT_GE(row.at("first_usable_estimate_t_s").get<double>(), row.at("first_detection_t_s").get<double>());
  for (const char* key : {"oracle_visible_escaped", "escaped_where_oracle_visible_escaped", "late_against_oracle_visible"})
    EXPECT_TRUE(e.contains(key)) << key;
  EXPECT_TRUE(fs::exists(out / "throws" / "6" / "dataset" / "dataset.yaml"));
  for (const char* file : {"detections.jsonl", "dodge.jsonl", "summary.json"})
    EXPECT_TRUE(fs::exists(out / "throws" / "6" / "run" / file)) << file;
  // The row was also written as the throw ended, a line of throws.jsonl.
  std::ifstream lines(out / "throws.jsonl");
  std::string line;
  ASSERT_TRUE(std::getline(lines, line));
  EXPECT_EQ(json::parse(line), row);
  EXPECT_FALSE(std::getline(lines, line));
  // Bad arguments: a clear error, nothing written.
  const Ran bad = fdv("dodge-eval --seeds 9-3 --out " + (out / "bad").string());
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("runs backwards"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(out / "bad" / "dodge_eval.json"));
  const Ran typo = fdv("dodge-eval --seeds 6 --baselines rotation,rotaton --out " + (out / "typo").string());
  EXPECT_NE(typo.exit_code, 0);
  EXPECT_NE(typo.output.find("unknown baseline 'rotaton'"), std::string::npos) << typo.output;
  EXPECT_FALSE(fs::exists(out / "typo"));
}


/// The last row of a pose CSV (truth/body.csv layout) as t, x, y, z.
std::vector<double> last_pose(const fs::path& p) {
  std::ifstream f(p);
  EXPECT_TRUE(f.good()) << p;
  std::string line, last;
  while (std::getline(f, line))
    if (!line.empty() && line[0] != '#') last = line;
  std::vector<double> v;
  std::stringstream s(last);
  for (std::string cell; std::getline(s, cell, ',') && v.size() < 4;) v.push_back(std::stod(cell));
  return v;
}

// A decision written by hand: 4 m/s² to the left from 0.25 s for 0.3 s. The kinematic replay moves
// 4·(0.3²/2 + 0.3·0.25) = 0.48 m by 0.8 s. Flown, the tilt follows with a first-order lag of
// τ = 0.08 s, which for a small tilt acts on the position like a delay of τ once settled:
// 4·(0.3²/2 + 0.3·0.17) = 0.384 m.
TEST(CliSimulateFly, TheVehicleFliesTheDecisionsAndKeepsTheUnflownPath) {
  const fs::path dir = test::scratch_dir("cli_fly");
  {
    std::ofstream f(dir / "dodge.jsonl");
    f << R"({"t":0.2,"effective_t":0.25,"track":1,"action":"dodge","probability":0.9,"miss_distance":0.1,)"
      << R"("committed":false,"reason":"by hand","maneuver":{"acceleration_W":[0,4,0],"start_t":0.25,)"
      << R"("duration":0.3,"expected_clearance":1,"probability_after":0}})" << "\n";
  }
  const fs::path out = dir / "flown";
  const Ran r = fdv("simulate --scenario hover_headon --seed 2 --resolution 64x48 --duration 0.8 --threads 2 --fly " +
                    (dir / "dodge.jsonl").string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json j = json::parse(r.output.substr(r.output.find('{'), r.output.rfind('}') - r.output.find('{') + 1));
  EXPECT_EQ(j.at("flight").at("setpoint_changes"), 2);
  EXPECT_EQ(j.at("flight").at("late"), 0);
  EXPECT_EQ(j.at("flight").at("tilt_clipped"), 0);
  EXPECT_TRUE(j.at("balls")[0].contains("closest_approach_unflown"));
  const std::vector<double> flown = last_pose(out / "truth" / "body.csv");
  const std::vector<double> unflown = last_pose(out / "truth" / "body_unflown.csv");
  ASSERT_EQ(flown.size(), 4u);
  ASSERT_EQ(unflown.size(), 4u);
  EXPECT_EQ(flown[0], unflown[0]);
  EXPECT_NEAR(flown[2] - unflown[2], 0.384, 0.02);
  EXPECT_NEAR(flown[1], unflown[1], 0.02);  // x: a lateral command
  EXPECT_NEAR(flown[3], unflown[3], 0.02);  // z: height held

  // A missing decisions file is an error naming it.
  const Ran missing = fdv("simulate --scenario hover_headon --fly " + (dir / "nope.jsonl").string() +
                          " --out " + (dir / "x").string());
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("nope.jsonl"), std::string::npos) << missing.output;
}

}  // namespace
}  // namespace fdv
