#pragma once
/// Summary statistics for timings and errors, as the tables report them.
/// Thread safety: value types and pure functions; may be used from any thread.
#include <nlohmann/json_fwd.hpp>
#include <span>

namespace fdv {

struct Summary {
  std::size_t count = 0;
  double min = 0, mean = 0, median = 0, p99 = 0, max = 0, rmse = 0;
  nlohmann::json to_json() const;
};

/// Percentiles by linear interpolation between order statistics (p99 of 100 values lies between
/// the 99th and 100th). An empty input gives count 0 and zeros.
Summary summarize(std::span<const double> values);

/// The sample standard deviation (divisor n − 1); NaN (undefined) for fewer than two values.
double sample_standard_deviation(std::span<const double> values);

}  // namespace fdv
