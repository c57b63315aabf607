// Deterministic random numbers for the simulator. The engine is std::mt19937_64; the
// distributions are written out here because libstdc++'s are implementation-defined: the same
// seed must give the same scene and the same noise with any standard library.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace rsrio::sim::detail {

/// SplitMix64 finaliser: decorrelates seeds that differ in a few bits.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// A seed for one independent stream: (seed, stream id, index...) hashed together.
inline std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t stream, std::uint64_t a = 0, std::uint64_t b = 0) {
  return mix64(mix64(mix64(mix64(seed) ^ stream) ^ a) ^ b);
}

class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(mix64(seed)) {}

  std::uint64_t bits() { return engine_(); }
  /// Uniform in [0, 1), 53 bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Exponential with mean 1.
  double exponential() { return -std::log1p(-uniform()); }
  /// Standard normal (Box-Muller, one value per call; the second is discarded for simplicity).
  double normal() {
    const double u1 = 1.0 - uniform();  // (0, 1]
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace rsrio::sim::detail
