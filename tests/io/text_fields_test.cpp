#include "fdv/io/text_fields.h"

#include <gtest/gtest.h>

namespace fdv {
namespace {

TEST(ParseSecondsToNs, IsExactWhereADoubleWouldNotBe) {
  TimeNs t;
  ASSERT_TRUE(parse_seconds_to_ns("1468941032.229165635", t));
  EXPECT_EQ(t, 1468941032229165635);  // a double keeps only ~16 significant digits
  ASSERT_TRUE(parse_seconds_to_ns("0.5", t));
  EXPECT_EQ(t, 500'000'000);
  ASSERT_TRUE(parse_seconds_to_ns("12", t));
  EXPECT_EQ(t, 12'000'000'000);
  ASSERT_TRUE(parse_seconds_to_ns(".000001", t));
  EXPECT_EQ(t, 1000);
  ASSERT_TRUE(parse_seconds_to_ns("-0.25", t));
  EXPECT_EQ(t, -250'000'000);
  ASSERT_TRUE(parse_seconds_to_ns("1.0000000006", t));  // rounded at the tenth decimal
  EXPECT_EQ(t, 1'000'000'001);
  EXPECT_FALSE(parse_seconds_to_ns("", t));
  EXPECT_FALSE(parse_seconds_to_ns("1.2.3", t));
  EXPECT_FALSE(parse_seconds_to_ns("abc", t));
  EXPECT_FALSE(parse_seconds_to_ns(".", t));
}

TEST(ParseDouble, RejectsNonFiniteAndGarbage) {
  double v;
  EXPECT_TRUE(parse_double("-1.5e-3", v));
  EXPECT_DOUBLE_EQ(v, -1.5e-3);
  EXPECT_FALSE(parse_double("nan", v));
  EXPECT_FALSE(parse_double("inf", v));
  EXPECT_FALSE(parse_double("1.0x", v));
  EXPECT_FALSE(parse_double("", v));
}

TEST(SplitFields, CommaAndBlankSeparated) {
  std::vector<std::string_view> f;
  split_fields("1, 2 ,3", ',', f);
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f[1], "2");
  split_fields("  0.1   5\t7 1 ", ' ', f);
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[2], "7");
}

}  // namespace
}  // namespace fdv
