#pragma once
/// One numeric text table (CSV or space-separated) read row by row with a single-row lookahead,
/// so that a reader can hand out a stream's rows up to a time horizon (usually the last event time
/// of the chunk it is filling). Used by the fdv dataset folder and the RPG text layout.
///
///   TableStream<ImuSample> imu(dir / "imu.txt", "imu", parse_imu_row, ' ');
///   imu.take_until(chunk.events.back().t, SIZE_MAX, chunk.imu, report);
///
/// `parse` turns the fields of one row into an item or returns a short reason for dropping the
/// row. Rows that fail to parse, whose time is corrupt (not valid_time) or goes backwards, are
/// dropped and counted in the report as "<name>: <reason>" with "<path>:line N". A missing file is an absent stream
/// (present() == false), not an error. Not thread-safe.
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fdv/core/time.h"
#include "fdv/io/read_report.h"
#include "fdv/io/text_fields.h"

namespace fdv {

/// Rows one stream hands out per chunk at most: a chunk stays bounded whatever its time horizon
/// (one corrupt event time far ahead would otherwise pull a whole file into one chunk). About a
/// minute of 1 kHz IMU; later rows follow in the next chunks.
inline constexpr std::size_t kMaxTableRowsPerChunk = 1 << 16;

template <typename T>
class TableStream {
 public:
  using Parser = std::function<std::string(const std::vector<std::string_view>&, T&)>;
  /// `separator` as in split_fields(): ',' for CSV, ' ' for runs of blanks.
  TableStream(const std::filesystem::path& path, std::string name, Parser parse,
              char separator = ',')
      : name_(std::move(name)), parse_(std::move(parse)), separator_(separator) {
    std::error_code ec;
    // An existing file that cannot be inspected is opened anyway, so its error names it.
    if (std::filesystem::exists(path, ec) || ec) lines_.emplace(path.string());
  }
  /// Reads the rows of `lines` (a file or an in-memory stream).
  TableStream(LineReader lines, std::string name, Parser parse, char separator = ',')
      : name_(std::move(name)), parse_(std::move(parse)), separator_(separator) {
    lines_.emplace(std::move(lines));
  }
  bool present() const { return lines_.has_value(); }

  /// Moves rows with t <= horizon (at most max_items) into out; drops bad rows into report.
  void take_until(TimeNs horizon, std::size_t max_items, std::vector<T>& out, ReadReport& report) {
    while (out.size() < max_items && fill(report) && pending_->t <= horizon) {
      out.push_back(std::move(*pending_));
      pending_.reset();
    }
  }
  bool exhausted(ReadReport& report) { return !fill(report); }

 private:
  bool fill(ReadReport& report) {
    if (pending_) return true;
    if (!lines_) return false;
    std::string_view line;
    while (lines_->next(line)) {
      split_fields(line, separator_, fields_);
      T item;
      std::string why = parse_(fields_, item);
      const std::string where = lines_->path() + ":" + lines_->where();
      if (!why.empty()) {
        report.drop(name_ + ": " + why, where);
      } else if (!valid_time(item.t)) {
        report.drop(name_ + ": time out of range (corrupt)", where);
      } else if (item.t < last_t_) {
        report.drop(name_ + ": timestamp went backwards", where);
      } else {
        last_t_ = item.t;
        pending_ = std::move(item);
        return true;
      }
    }
    lines_.reset();
    return false;
  }

  std::string name_;
  Parser parse_;
  char separator_;
  std::optional<LineReader> lines_;
  std::vector<std::string_view> fields_;
  std::optional<T> pending_;
  TimeNs last_t_ = std::numeric_limits<TimeNs>::min();
};

}  // namespace fdv
