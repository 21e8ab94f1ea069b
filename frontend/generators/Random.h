// A deterministic random number source for the particle generators: the same seed gives the same
// numbers on every platform and standard library. std::mt19937_64 is fully specified by the C++
// standard; the distributions of <random> are not, so every conversion to doubles is written here.
//
// uniform() and everything built only from it (jitter, positions, uniform radii, discrete mixes) is
// bit-identical everywhere. normal() uses std::log, std::sqrt and std::cos: IEEE 754 makes sqrt exact,
// log and cos are accurate to about an ulp but not required to be correctly rounded, so normal and
// log-normal radii can in principle differ in the last bit between C libraries.
#pragma once
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace pflow::frontend {

// SplitMix64's finaliser: spreads nearby seeds (0, 1, 2, ...) over unrelated engine states.
constexpr std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// The seed of stream `stream` (a particle set's index) of a run seeded with `seed`. The scene loader's
// lattice uses exactly this, so a generator given streamSeed(simulation.seed, setIndex) reproduces it.
constexpr std::uint64_t streamSeed(std::uint64_t seed, std::uint64_t stream) { return splitMix64(seed ^ splitMix64(stream)); }

class Random {
 public:
  explicit Random(std::uint64_t seed) : m_engine(seed) {}

  std::uint64_t bits() { return m_engine(); }

  // Uniform in [0, 1) from the top 53 bits: every value k * 2^-53, k = 0 .. 2^53 - 1, equally likely.
  double uniform() { return static_cast<double>(m_engine() >> 11) * 0x1.0p-53; }
  // Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  // Uniform in [-1, 1); the same expression as the scene loader's lattice jitter.
  double symmetric() { return 2.0 * uniform() - 1.0; }

  // Uniform integer in [0, n), n > 0, without modulo bias (rejection of the top partial block).
  std::uint64_t below(std::uint64_t n) {
    const std::uint64_t limit = ~std::uint64_t{0} - (~std::uint64_t{0} % n);  // a multiple of n
    std::uint64_t x = m_engine();
    while (x >= limit) x = m_engine();
    return x % n;
  }

  // Standard normal by Box-Muller; the second value of each pair is kept for the next call.
  double normal() {
    if (m_haveSpare) {
      m_haveSpare = false;
      return m_spare;
    }
    const double u1 = 1.0 - uniform();  // (0, 1]: log stays finite
    const double u2 = uniform();
    const double rho = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * std::numbers::pi * u2;
    m_spare = rho * std::sin(angle);
    m_haveSpare = true;
    return rho * std::cos(angle);
  }

 private:
  std::mt19937_64 m_engine;
  double m_spare = 0;
  bool m_haveSpare = false;
};

}  // namespace pflow::frontend
