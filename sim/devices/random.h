// Small, fast, seedable random numbers for the simulated devices. Every random choice a device
// makes (noise, jitter, fault draws) comes from a stream derived from a seed and an index
// (frame number, image row), so a simulated run repeats exactly whatever order work is done in.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

namespace relume::sim {

// Sebastiano Vigna's SplitMix64 finaliser: a bijective mix of 64 bits.
constexpr std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A seed for stream `index` of `seed` (e.g. the fault draw of frame 17).
constexpr std::uint64_t StreamSeed(std::uint64_t seed, std::uint64_t index) {
  return SplitMix64(SplitMix64(seed) ^ (index * 0xd1b54a32d192ed03ULL));
}

// A SplitMix64 sequence with uniform and standard normal draws.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t Next() {
    state_ += 0x9e3779b97f4a7c15ULL;
    return SplitMix64(state_);
  }
  // Uniform in [0, 1).
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  // Standard normal (Box-Muller; the second value of each pair is kept for the next call).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - Uniform();  // (0, 1]: log stays finite
    const double u2 = Uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    spare_ = radius * std::sin(2.0 * std::numbers::pi * u2);
    has_spare_ = true;
    return radius * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace relume::sim
