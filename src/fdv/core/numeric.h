#pragma once
/// Small numeric checks shared by the options' validate() functions.
///
///   if (!positive_finite(sigma_px)) return "sigma_px must be > 0";
#include <cmath>

namespace fdv {

/// x > 0 and finite (false for NaN).
inline bool positive_finite(double x) { return std::isfinite(x) && x > 0; }

}  // namespace fdv
