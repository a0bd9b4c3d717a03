#include "fdv/eval/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <vector>

namespace fdv {
namespace {
double quantile(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}
}  // namespace

Summary summarize(std::span<const double> values) {
  Summary s;
  if (values.empty()) return s;
  std::vector<double> v(values.begin(), values.end());
  std::sort(v.begin(), v.end());
  s.count = v.size();
  s.min = v.front();
  s.max = v.back();
  s.mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  s.median = quantile(v, 0.5);
  s.p99 = quantile(v, 0.99);
  double sq = 0;
  for (double x : v) sq += x * x;
  s.rmse = std::sqrt(sq / static_cast<double>(v.size()));
  return s;
}

double sample_standard_deviation(std::span<const double> values) {
  if (values.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  const double n = static_cast<double>(values.size());
  const double mean = std::accumulate(values.begin(), values.end(), 0.0) / n;
  double sq = 0;
  for (double x : values) sq += (x - mean) * (x - mean);
  return std::sqrt(sq / (n - 1));
}

nlohmann::json Summary::to_json() const {
  return {{"count", count}, {"min", min}, {"mean", mean}, {"median", median},
          {"p99", p99},     {"max", max}, {"rmse", rmse}};
}

}  // namespace fdv
