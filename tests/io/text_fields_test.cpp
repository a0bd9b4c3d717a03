#include "fdv/io/text_fields.h"

#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fdv/core/error.h"
#include "test_support.h"

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

TEST(ParseSecondsToNs, RejectsTimesBeyondInt64NanosecondsAndDoubleSigns) {
  TimeNs t;
  ASSERT_TRUE(parse_seconds_to_ns("9223372036.854775807", t));  // INT64_MAX ns
  EXPECT_EQ(t, std::numeric_limits<TimeNs>::max());
  ASSERT_TRUE(parse_seconds_to_ns("-9223372036.854775807", t));
  EXPECT_EQ(t, -std::numeric_limits<TimeNs>::max());
  ASSERT_TRUE(parse_seconds_to_ns("9200000000", t));  // fits: 9.2e18 ns
  EXPECT_EQ(t, 9'200'000'000'000'000'000);
  EXPECT_FALSE(parse_seconds_to_ns("9223372036.854775808", t));
  EXPECT_FALSE(parse_seconds_to_ns("9223372036.8547758075", t));  // rounds up past the limit
  EXPECT_FALSE(parse_seconds_to_ns("9223372037", t));
  EXPECT_FALSE(parse_seconds_to_ns("99999999999999999999", t));
  EXPECT_FALSE(parse_seconds_to_ns("--5", t));  // was read as +5 s
  EXPECT_FALSE(parse_seconds_to_ns("+-5", t));  // was read as -5 s
  EXPECT_FALSE(parse_seconds_to_ns("-", t));
}

std::string hex(std::string_view s) { return escape_non_utf8(s); }

TEST(EscapeNonUtf8, KeepsValidUtf8) {
  EXPECT_EQ(hex("plain ASCII, tabs\t and ~"), "plain ASCII, tabs\t and ~");
  EXPECT_EQ(hex("\xC3\xA9"), "\xC3\xA9");                  // é, 2 bytes
  EXPECT_EQ(hex("\xE2\x82\xAC"), "\xE2\x82\xAC");          // €, 3 bytes
  EXPECT_EQ(hex("\xF0\x9F\x98\x80"), "\xF0\x9F\x98\x80");  // 😀, 4 bytes
  EXPECT_EQ(hex("\xF4\x8F\xBF\xBF"), "\xF4\x8F\xBF\xBF");  // U+10FFFF, the last code point
  EXPECT_EQ(hex(std::string_view("a\0b", 3)), std::string("a\0b", 3));  // NUL is valid UTF-8
  EXPECT_EQ(hex(""), "");
}

TEST(EscapeNonUtf8, EscapesEachByteOfAnIllFormedSequence) {
  EXPECT_EQ(hex("a\xFFz"), "a\\xFFz");                     // never valid
  EXPECT_EQ(hex("\xC0\xAF"), "\\xC0\\xAF");                // overlong '/'
  EXPECT_EQ(hex("\xE0\x80\xAF"), "\\xE0\\x80\\xAF");      // overlong, 3 bytes
  EXPECT_EQ(hex("\xED\xA0\x80"), "\\xED\\xA0\\x80");      // UTF-16 surrogate D800
  EXPECT_EQ(hex("\xF4\x90\x80\x80"), "\\xF4\\x90\\x80\\x80");  // above U+10FFFF
  EXPECT_EQ(hex("ok\xE2\x82"), "ok\\xE2\\x82");            // truncated at the end
  EXPECT_EQ(hex("\x80"), "\\x80");                          // lone continuation byte
  // A bad byte does not swallow the valid character after it.
  EXPECT_EQ(hex("\xE2\xC3\xA9"), "\\xE2\xC3\xA9");
}

TEST(EscapeNonUtf8, OutputIsAcceptedByJson) {
  std::string all;
  for (int b = 0; b < 256; ++b) all += static_cast<char>(b);
  all += "\xED\xA0\x80\xF4\x90\x80\x80\xC0\xAF\xE2\x82";
  EXPECT_THROW(nlohmann::json(all).dump(), nlohmann::json::type_error);
  EXPECT_NO_THROW(nlohmann::json(escape_non_utf8(all)).dump());
}

using test::text;

TEST(LineReader, ReadsAStreamSkippingBlankAndCommentLines) {
  LineReader lines(text("# header\n\n  1 2 \r\n3 4\n\n# end"), "mem.txt");
  std::string_view line;
  ASSERT_TRUE(lines.next(line));
  EXPECT_EQ(line, "1 2");
  EXPECT_EQ(lines.where(), "line 3");
  ASSERT_TRUE(lines.next(line));
  EXPECT_EQ(line, "3 4");
  EXPECT_EQ(lines.line_number(), 4u);
  EXPECT_FALSE(lines.next(line));
  EXPECT_FALSE(lines.next(line));
  LineReader no_final_newline(text("5 6"), "mem.txt");
  ASSERT_TRUE(no_final_newline.next(line));
  EXPECT_EQ(line, "5 6");
  EXPECT_FALSE(no_final_newline.next(line));
}

TEST(LineReader, LongestLineIsReadAndALongerOneIsAnError) {
  const std::string longest(kMaxLineBytes, '7');
  LineReader ok(text("1\n" + longest + "\n" + longest), "mem.txt");
  std::string_view line;
  ASSERT_TRUE(ok.next(line));
  ASSERT_TRUE(ok.next(line));
  EXPECT_EQ(line.size(), kMaxLineBytes);
  ASSERT_TRUE(ok.next(line));
  EXPECT_EQ(line.size(), kMaxLineBytes);
  EXPECT_FALSE(ok.next(line));
  // A file without newlines is not read into memory whole.
  LineReader too_long(text("1\n" + longest + "7\n2\n"), "mem.txt");
  ASSERT_TRUE(too_long.next(line));
  try {
    too_long.next(line);
    FAIL() << "a line over kMaxLineBytes was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "mem.txt");
    EXPECT_EQ(e.where(), "line 2");
    EXPECT_NE(e.reason().find("longer than"), std::string::npos);
  }
}

}  // namespace
}  // namespace fdv
