#include "fdv/eval/statistics.h"

#include <gtest/gtest.h>

#include "fdv/eval/trajectory_error.h"

namespace fdv {
namespace {

TEST(Summarize, HandComputedValues) {
  const std::vector<double> v{4, 1, 3, 2};
  const Summary s = summarize(v);
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 4);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.p99, 3.97);             // 3 + 0.97 * (4 - 3)
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));  // (1+4+9+16)/4
  EXPECT_EQ(summarize(std::vector<double>{}).count, 0u);
}

TEST(SampleStandardDeviation, HandComputedValuesAndTooFewValues) {
  // Mean 5, squared deviations 9 + 1 + 1 + 9 = 20, over n − 1 = 3.
  EXPECT_DOUBLE_EQ(sample_standard_deviation(std::vector<double>{2, 4, 6, 8}), std::sqrt(20.0 / 3.0));
  EXPECT_DOUBLE_EQ(sample_standard_deviation(std::vector<double>{3, 3, 3}), 0.0);
  EXPECT_TRUE(std::isnan(sample_standard_deviation(std::vector<double>{1})));
  EXPECT_TRUE(std::isnan(sample_standard_deviation(std::vector<double>{})));
}

TEST(AbsolutePositionError, ConstantOffsetGivesThatError) {
  std::vector<ObjectState> truth;
  for (int i = 0; i <= 10; ++i) truth.push_back({i * kNsPerMs, 1, {0.1 * i, 0, 5}, {100, 0, 0}});
  truth.push_back({5 * kNsPerMs, 2, {9, 9, 9}, Eigen::Vector3d::Zero()});  // another object: ignored
  // Estimate off by (0, 0.3, 0.4): error 0.5 at every sample.
  const auto est = [](TimeNs t) { return Eigen::Vector3d(100.0 * to_seconds(t), 0.3, 5.4); };
  const Summary s = absolute_position_error(est, truth, 1, 2 * kNsPerMs, 8 * kNsPerMs);
  EXPECT_EQ(s.count, 7u);
  EXPECT_NEAR(s.mean, 0.5, 1e-12);
  EXPECT_NEAR(s.rmse, 0.5, 1e-12);
  EXPECT_NEAR(s.max, 0.5, 1e-12);
}

}  // namespace
}  // namespace fdv
