#pragma once
/// What a reader dropped or repaired, counted per reason, with the first place it happened.
/// Readers never silently change data: anything skipped lands here and `fdv info` prints it.
/// Thread safety: not thread-safe; const methods may be called concurrently while no thread adds.
#include <cstdint>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>

namespace fdv {

class ReadReport {
 public:
  struct Entry {
    std::uint64_t count = 0;
    std::string first_where;  ///< e.g. "byte 4096" or "line 17"
  };
  /// Counts `n` records dropped for `reason` (a short fixed phrase, e.g. "timestamp went backwards").
  void drop(const std::string& reason, const std::string& where, std::uint64_t n = 1);
  /// Counts `n` records kept after a documented repair (e.g. "time counter wrapped").
  void repair(const std::string& reason, const std::string& where, std::uint64_t n = 1);

  const std::map<std::string, Entry>& dropped() const { return dropped_; }
  const std::map<std::string, Entry>& repaired() const { return repaired_; }
  std::uint64_t total_dropped() const;
  void merge(const ReadReport& other);
  /// {"dropped": {reason: {count, first}}, "repaired": {...}}
  nlohmann::json to_json() const;

 private:
  std::map<std::string, Entry> dropped_, repaired_;
};

}  // namespace fdv
