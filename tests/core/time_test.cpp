#include "fdv/core/time.h"

#include <gtest/gtest.h>

#include <limits>

namespace fdv {
namespace {

constexpr TimeNs kMax = std::numeric_limits<TimeNs>::max();
constexpr TimeNs kMin = std::numeric_limits<TimeNs>::min();

TEST(CheckedTime, AddAtTheLimits) {
  EXPECT_EQ(checked_add(kMax - 1, 1), kMax);
  EXPECT_EQ(checked_add(kMin + 1, -1), kMin);
  EXPECT_EQ(checked_add(kMax, kMin), -1);
  EXPECT_FALSE(checked_add(kMax, 1).has_value());
  EXPECT_FALSE(checked_add(kMin, -1).has_value());
  EXPECT_FALSE(checked_add(kMax, kMax).has_value());
}

TEST(CheckedTime, SubAtTheLimits) {
  EXPECT_EQ(checked_sub(kMin + 1, 1), kMin);
  EXPECT_EQ(checked_sub(kMax, kMax), 0);
  EXPECT_EQ(checked_sub(-1, kMax), kMin);
  EXPECT_FALSE(checked_sub(kMin, 1).has_value());
  EXPECT_FALSE(checked_sub(0, kMin).has_value());  // -INT64_MIN does not exist
  EXPECT_FALSE(checked_sub(kMax, -1).has_value());
}

TEST(CheckedTime, MulAtTheLimits) {
  EXPECT_EQ(checked_mul(9'223'372'036, kNsPerS), 9'223'372'036'000'000'000);
  EXPECT_FALSE(checked_mul(9'223'372'037, kNsPerS).has_value());
  EXPECT_EQ(checked_mul(kMin, 1), kMin);
  EXPECT_FALSE(checked_mul(kMin, -1).has_value());
  EXPECT_FALSE(checked_mul(-1, kMin).has_value());
  EXPECT_EQ(checked_mul(kMax, -1), -kMax);
  EXPECT_FALSE(checked_mul(kMax, 2).has_value());
  EXPECT_EQ(checked_mul(0, kMin), 0);
}

}  // namespace
}  // namespace fdv
