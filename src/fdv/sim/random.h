#pragma once
/// Deterministic random numbers for the simulator.
///
///   Rng rng = Rng::stream(seed, kStreamNoise, tile_index);   // independent stream per (seed,
///   kind, index) double u = rng.uniform();      // [0, 1) double g = rng.normal();       // N(0,
///   1)
///
/// xoshiro256** (Blackman & Vigna) seeded through splitmix64 from a hash of (seed, kind, index),
/// so that every tile, sensor and frame draws from its own stream: the output does not depend on
/// which thread ran which tile, or in which order. Normals by the Box-Muller transform (no cached
/// second value, so a stream's draws depend only on how many were drawn before). Not thread-safe:
/// one Rng per thread of work.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>

namespace fdv::sim {

/// Stream kinds: each draws from its own sequence.
enum class RngStream : std::uint64_t {
  kPixelSetup = 1,  ///< per-pixel thresholds, hot pixels, noise rates (one stream per tile)
  kPixelNoise = 2,  ///< background-activity times and polarities (one stream per tile)
  kJitter = 3,      ///< event timestamp jitter (one stream per tile)
  kDepth = 4,       ///< depth noise and holes (one stream per frame row)
  kImu = 5,         ///< IMU noise and bias walk
  kOdometry = 6,    ///< odometry noise and drift
  kScenario = 7,    ///< preset randomisation (scene layout, throw)
};

class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0) {
    std::uint64_t z = seed;
    for (auto& s : s_) s = splitmix64(z);
  }
  /// An independent stream for (seed, kind, index).
  static Rng stream(std::uint64_t seed, RngStream kind, std::uint64_t index = 0) {
    std::uint64_t h = mix(seed) ^ (static_cast<std::uint64_t>(kind) * 0x9E3779B97F4A7C15ull);
    h = mix(h) ^ (index * 0xD1B54A32D192ED03ull);
    return Rng(mix(h));
  }

  std::uint64_t next() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  /// Uniform in [a, b).
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// Uniform in (0, 1]: safe for log().
  double uniform_open0() { return (static_cast<double>(next() >> 11) + 1.0) * 0x1.0p-53; }
  /// Standard normal.
  double normal() {
    const double u1 = uniform_open0(), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  /// Three standard normals (x, y, z), drawn z first: the order every simulated dataset and
  /// published figure (docs/RESULTS.md) was made with. Draws must be sequenced by hand: as
  /// function arguments their order is the compiler's (GCC and clang differ).
  Eigen::Vector3d normal3() {
    const double z = normal(), y = normal(), x = normal();
    return {x, y, z};
  }
  /// Exponential with the given mean.
  double exponential(double mean) { return -mean * std::log(uniform_open0()); }
  bool bernoulli(double p) { return uniform() < p; }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static std::uint64_t mix(std::uint64_t x) { return splitmix64(x); }
  static std::uint64_t splitmix64(std::uint64_t& x) {
    std::uint64_t z = (x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::uint64_t s_[4];
};

}  // namespace fdv::sim
