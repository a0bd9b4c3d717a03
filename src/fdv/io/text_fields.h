#pragma once
/// Line-by-line reading of numeric text tables (CSV, space-separated), streaming, with exact
/// integer timestamps: a time never passes through a double, so nanoseconds since 1970 stay exact.
/// Thread safety: a LineReader is used by one thread; the functions are pure.
#include <cstdint>
#include <fstream>
#include <istream>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "fdv/core/time.h"

namespace fdv {

/// Longest line a text table may have. The longest real row (odometry.csv, 14 numbers) is a few
/// hundred bytes; the bound keeps a file without newlines from being read into memory whole.
inline constexpr std::size_t kMaxLineBytes = 64 * 1024;

/// Reads the lines of a text table from a file or any stream (e.g. an in-memory buffer).
class LineReader {
 public:
  /// Throws InputError if the file cannot be opened.
  explicit LineReader(const std::string& path);
  /// Reads `in`; `name` stands for the file in positions and errors.
  LineReader(std::unique_ptr<std::istream> in, std::string name);
  /// Next non-empty line that is not a comment ('#' first); false at end of file.
  /// Throws InputError (file, line) for a line longer than kMaxLineBytes or a read error.
  bool next(std::string_view& line);
  std::size_t line_number() const { return line_number_; }
  const std::string& path() const { return path_; }
  std::string where() const { return "line " + std::to_string(line_number_); }

 private:
  std::string path_;
  std::unique_ptr<std::istream> in_;
  std::string buffer_;
  std::size_t line_number_ = 0;
};

/// Splits on `separator` (or on runs of blanks when separator is ' '); trims blanks.
void split_fields(std::string_view line, char separator, std::vector<std::string_view>& fields);

bool parse_int64(std::string_view s, std::int64_t& out);
bool parse_double(std::string_view s, double& out);  ///< finite values only
/// Decimal seconds ("1468941032.229165635", "0.5", "12") to integer nanoseconds, exactly
/// (digits beyond the ninth decimal are rounded).
bool parse_seconds_to_ns(std::string_view s, TimeNs& out);

/// `text` as valid UTF-8: each byte that is not part of a well-formed UTF-8 sequence becomes the
/// four characters \xNN. For text a file declares (header values, encoding names) that is
/// printed or put into JSON, which requires UTF-8.
std::string escape_non_utf8(std::string_view text);

}  // namespace fdv
