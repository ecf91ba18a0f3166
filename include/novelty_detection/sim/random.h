// Deterministic random numbers for the simulator. ROS-free.
//
// std::uniform_real_distribution and std::normal_distribution are implementation-defined,
// so scenes would differ between standard libraries. These helpers define the mapping from
// the std::mt19937_64 stream (whose output the standard does fix) to numbers exactly.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace novelty_detection {
namespace sim {

using Rng = std::mt19937_64;

/// Uniform in [0, 1) with 53 random bits.
inline double uniform01(Rng& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// Uniform in [lo, hi).
inline double uniform(Rng& rng, double lo, double hi) { return lo + (hi - lo) * uniform01(rng); }

/// Uniform integer in [lo, hi] (hi >= lo); the tiny modulo bias is irrelevant here.
inline int uniformInt(Rng& rng, int lo, int hi) {
  return lo + static_cast<int>(rng() % static_cast<std::uint64_t>(hi - lo + 1));
}

/// Standard normal by the Box-Muller transform (one draw per call, two uniforms consumed).
inline double standardNormal(Rng& rng) {
  const double u1 = 1.0 - uniform01(rng);  // (0, 1], keeps log() finite
  const double u2 = uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

/// SplitMix64 finaliser: derives independent seeds from (seed, stream) pairs.
inline std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace sim
}  // namespace novelty_detection
