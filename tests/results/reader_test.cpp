// Reading a `fdv run` results folder back: the fields evaluation uses, and errors with file and
// line.
#include "fdv/results/reader.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fdv/core/error.h"
#include "test_support.h"

namespace fdv {
namespace {

TEST(RunResults, ReadsDetectionsWithTheirTracks) {
  const std::string dir = test::scratch_dir("run_results_detections");
  test::write_text(dir + "/detections.jsonl",
        R"({"t_start":0.1,"t_end":0.125,"detections":[{"t":0.11,"center":[12.5,30.25],"track":4}]})"
        "\n"
        R"({"t_start":0.125,"t_end":0.15,"detections":[]})"
        "\n");
  const auto w = read_detections(dir);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0].t_start, 100 * kNsPerMs);
  EXPECT_EQ(w[0].t_end, 125 * kNsPerMs);
  ASSERT_EQ(w[0].detections.size(), 1u);
  EXPECT_EQ(w[0].detections[0].t, 110 * kNsPerMs);
  EXPECT_EQ(w[0].detections[0].center_raw, Eigen::Vector2d(12.5, 30.25));
  EXPECT_EQ(w[0].detections[0].track, 4);
  EXPECT_TRUE(w[1].detections.empty());
}

TEST(RunResults, MalformedLineNamesFileAndLine) {
  const std::string dir = test::scratch_dir("run_results_bad");
  test::write_text(dir + "/detections.jsonl",
        "{\"t_start\":0,\"t_end\":1,\"detections\":[]}\n{\"t_start\":0}\n");
  try {
    read_detections(dir);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("detections.jsonl:line 2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_detections(dir + "/missing"), InputError);
}

TEST(RunResults, ReadsConvergedEstimatesWithTheirUsableFlag) {
  const std::string dir = test::scratch_dir("run_results_estimates");
  const std::string fields =
      R"("t0":0.05,"p0":[1,2,3],"v0":[4,5,6],"gravity":[0,0,-9.81],"t_first":0.05,"t_last":0.2)";
  test::write_text(dir + "/trajectories.jsonl",
        R"({"t":0.1,"track":2,"method":"fusion","usable":false,"converged":false,)" + fields + "}\n" +
            R"({"t":0.15,"track":2,"method":"fusion","usable":false,"converged":true,)" + fields + "}\n" +
            // Written before "converged" existed: usable implied it, a not usable line is skipped.
            R"({"t":0.18,"track":2,"method":"fusion","usable":false,)" + fields + "}\n" +
            R"({"t":0.2,"track":2,"method":"mono","usable":true,)" + fields + "}\n");
  const auto e = read_estimates(dir);
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e[0].t, 150 * kNsPerMs);
  EXPECT_EQ(e[0].mode, EstimatorMode::kFusion);
  EXPECT_FALSE(e[0].usable);
  EXPECT_TRUE(e[1].usable);
  EXPECT_EQ(e[1].mode, EstimatorMode::kMonocular);
  EXPECT_EQ(e[1].track, 2);
  EXPECT_EQ(e[1].t, 200 * kNsPerMs);
  EXPECT_EQ(e[1].trajectory.p0_W, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(e[1].trajectory.v0_W, Eigen::Vector3d(4, 5, 6));
  EXPECT_TRUE(read_estimates(dir + "/missing").empty());  // a run without 3D estimation
  test::write_text(dir + "/trajectories.jsonl",
        R"({"t":0.1,"track":2,"method":"stereo","usable":true,)" + fields + "}\n");
  EXPECT_THROW(read_estimates(dir), InputError);
}

}  // namespace
}  // namespace fdv
