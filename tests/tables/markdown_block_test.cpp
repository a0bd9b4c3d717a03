// Replacing one command's marked block of a results document and nothing else.
#include "fdv/tables/markdown_block.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "fdv/core/error.h"
#include "test_support.h"

namespace fdv {
namespace {

TEST(MarkdownBlock, ReplacesOnlyBetweenItsMarkers) {
  const std::string doc =
      "# Results\n\nintro\n<!-- table1:begin -->\nold 1\n<!-- table1:end -->\nmiddle\n"
      "<!-- table2:begin -->\nold 2\n<!-- table2:end -->\ntail\n";
  EXPECT_EQ(
      replace_marked_block(doc, "table1", "new 1\nline 2"),
      "# Results\n\nintro\n<!-- table1:begin -->\nnew 1\nline 2\n<!-- table1:end -->\nmiddle\n"
      "<!-- table2:begin -->\nold 2\n<!-- table2:end -->\ntail\n");
  EXPECT_EQ(replace_marked_block(doc, "table2", "new 2\n"),
            "# Results\n\nintro\n<!-- table1:begin -->\nold 1\n<!-- table1:end -->\nmiddle\n"
            "<!-- table2:begin -->\nnew 2\n<!-- table2:end -->\ntail\n");
}

TEST(MarkdownBlock, AppendsAMissingBlock) {
  EXPECT_EQ(replace_marked_block("# Results\n", "table2", "x"),
            "# Results\n\n<!-- table2:begin -->\nx\n<!-- table2:end -->\n");
  EXPECT_EQ(replace_marked_block("", "t", "x"), "<!-- t:begin -->\nx\n<!-- t:end -->\n");
}

TEST(MarkdownBlock, UnbalancedMarkersAreErrors) {
  const std::string b = "<!-- t:begin -->\n", e = "<!-- t:end -->\n";
  for (const std::string& doc : {b, e, e + b, b + e + b + e}) {
    try {
      replace_marked_block(doc, "t", "x", "RESULTS.md");
      FAIL() << "accepted: " << doc;
    } catch (const ConfigError& err) {
      EXPECT_NE(std::string(err.what()).find("RESULTS.md: block 't'"), std::string::npos)
          << err.what();
    }
  }
  // Another block's markers are not this block's.
  EXPECT_NO_THROW(replace_marked_block("<!-- table1:begin -->\n", "table2", "x"));
}

TEST(MarkdownBlock, WritesAFileAndRewritesItsBlockOnly) {
  const std::string path = test::scratch_dir("markdown_block") + "/docs/RESULTS.md";
  write_marked_block(path, "table1", "first");
  write_marked_block(path, "table2", "second");
  write_marked_block(path, "table1", "again");
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_EQ(s.str(),
            "# Results\n\n<!-- table1:begin -->\nagain\n<!-- table1:end -->\n\n<!-- table2:begin "
            "-->\nsecond\n"
            "<!-- table2:end -->\n");
}

}  // namespace
}  // namespace fdv
