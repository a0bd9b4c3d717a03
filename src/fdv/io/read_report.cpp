#include "fdv/io/read_report.h"

#include <nlohmann/json.hpp>

namespace fdv {
namespace {
void add(std::map<std::string, ReadReport::Entry>& m, const std::string& reason,
         const std::string& where, std::uint64_t n) {
  auto& e = m[reason];
  if (e.count == 0) e.first_where = where;
  e.count += n;
}
nlohmann::json entries_json(const std::map<std::string, ReadReport::Entry>& m) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [reason, e] : m) j[reason] = {{"count", e.count}, {"first", e.first_where}};
  return j;
}
}  // namespace

void ReadReport::drop(const std::string& reason, const std::string& where, std::uint64_t n) {
  add(dropped_, reason, where, n);
}
void ReadReport::repair(const std::string& reason, const std::string& where, std::uint64_t n) {
  add(repaired_, reason, where, n);
}
std::uint64_t ReadReport::total_dropped() const {
  std::uint64_t n = 0;
  for (const auto& [_, e] : dropped_) n += e.count;
  return n;
}
void ReadReport::merge(const ReadReport& other) {
  for (const auto& [r, e] : other.dropped_) add(dropped_, r, e.first_where, e.count);
  for (const auto& [r, e] : other.repaired_) add(repaired_, r, e.first_where, e.count);
}
nlohmann::json ReadReport::to_json() const {
  return {{"dropped", entries_json(dropped_)}, {"repaired", entries_json(repaired_)}};
}

}  // namespace fdv
