#pragma once
/// Results documents made of blocks that different commands own: each command rewrites only the
/// text between its own markers and leaves the rest of the file as it is.
///
///   <!-- table1:begin -->
///   ... written by `fdv table1 --write docs/RESULTS.md` ...
///   <!-- table1:end -->
///
///   write_marked_block("docs/RESULTS.md", "table1", markdown);
#include <string>

namespace fdv {

/// `document` with the text between `<!-- NAME:begin -->` and `<!-- NAME:end -->` replaced by
/// `content` (markers kept, each on its own line). Without the markers, the block is appended at
/// the end after a blank line. Throws ConfigError when the markers are unbalanced (one alone,
/// end before begin, or more than one pair), naming `source` (e.g. the file) and the block.
std::string replace_marked_block(const std::string& document, const std::string& name,
                                 const std::string& content,
                                 const std::string& source = "document");

/// replace_marked_block on a file, created (with `title` as its first line) when absent; the file
/// is replaced atomically (written beside it, then renamed). Throws InputError / ConfigError.
void write_marked_block(const std::string& path, const std::string& name,
                        const std::string& content, const std::string& title = "# Results");

}  // namespace fdv
