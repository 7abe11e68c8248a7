// Independent random streams from one scan seed: a new use of randomness (a grid's offsets, a partial
// view's band) draws from its own stream, so it leaves every other draw, and so older scans, unchanged.
#pragma once

#include <cstdint>
#include <random>

namespace cmm::sim {

// The streams beside the scan's main one (std::mt19937_64(seed)); never renumber one.
enum class SeedStream : std::uint32_t { coverage_bands = 1, grid_offsets = 2, poisson = 3 };

// std::seed_seq's mixing is fixed by the standard: the same seed and stream give the same engine anywhere.
inline std::mt19937_64 seed_stream(std::uint64_t seed, SeedStream stream) {
  std::seed_seq sequence{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                         static_cast<std::uint32_t>(stream)};
  return std::mt19937_64(sequence);
}

}  // namespace cmm::sim
