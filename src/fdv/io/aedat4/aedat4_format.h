#pragma once
/// Facts of the AEDAT 4.0 format that its reader and writer share (docs/FORMATS.md, "AEDAT 4.0").
#include <numbers>
#include <string_view>

namespace fdv {

/// The first 14 bytes of every AEDAT 4.0 file.
inline constexpr std::string_view kAedat4Magic{"#!AER-DAT4.0\r\n", 14};

/// The IOHeader's packet compression (its `compression` field).
enum class Aedat4Compression { kNone = 0, kLz4 = 1, kLz4High = 2, kZstd = 3, kZstdHigh = 4 };

/// Standard gravity [m/s^2]: the unit "g" of the IMUS accelerometer fields (3rd CGPM, 1901).
inline constexpr double kAedat4Gravity_m_s2 = 9.80665;
/// The IMUS gyroscope fields are in degrees per second.
inline constexpr double kAedat4RadPerDeg = std::numbers::pi / 180.0;

}  // namespace fdv
