// Particle radius distributions for the generators. All radii in metres; validate() before sampling.
//
//   single      every particle has `radius`
//   uniform     radius uniform in [min, max]
//   normal      radius ~ N(mean, std), truncated to [min, max] (rejection sampling)
//   logNormal   ln(radius) ~ N(ln(median), ln(geometricStd)), truncated to [min, max]: `median` is the median
//               radius of the untruncated law and `geometricStd` (>= 1) its geometric standard deviation, the
//               way sieve analyses report d50 and sigma_g
//   discrete    a mix of radii with fractions by number (basis kNumber) or by solid volume (basis kVolume)
//
// Mean particle volume and the bounds are those of the distribution as sampled (truncation included).
#pragma once
#include <string>
#include <vector>

#include "common/Status.h"
#include "frontend/generators/Random.h"

namespace pflow::frontend {

class SizeDistribution {
 public:
  enum class Kind { kSingle, kUniform, kNormal, kLogNormal, kDiscrete };
  enum class Basis { kNumber, kVolume };  // what a discrete mix's fractions count

  static SizeDistribution single(double radius);
  static SizeDistribution uniform(double min, double max);
  static SizeDistribution normal(double mean, double std, double min, double max);
  static SizeDistribution logNormal(double median, double geometricStd, double min, double max);
  static SizeDistribution discrete(std::vector<double> radii, std::vector<double> fractions, Basis basis = Basis::kNumber);

  // Every problem at once, each under `path` + ".key" and naming the bound it breaks.
  ErrorList validate(const std::string& path = "size") const;

  // One radius. Requires validate() to be empty. Single radii consume no random numbers.
  double sample(Random& rng) const;

  double minRadius() const;
  double maxRadius() const;
  double meanRadius() const;  // number-weighted, of the (truncated) distribution as sampled
  double meanVolume() const;  // number-weighted mean of 4/3 pi r^3 [m^3]

  Kind kind() const { return m_kind; }
  const std::vector<double>& radii() const { return m_radii; }
  // Discrete mix: fraction by number of each radius (converted from volume fractions when basis is kVolume).
  const std::vector<double>& numberFractions() const { return m_numberFractions; }

 private:
  double moment(int power) const;  // E[r^power] of the distribution as sampled

  Kind m_kind = Kind::kSingle;
  double m_a = 0, m_b = 0;      // single: (radius, -); normal: (mean, std); logNormal: (median, geometricStd)
  double m_min = 0, m_max = 0;  // bounds (single: radius; discrete: smallest and largest radius)
  std::vector<double> m_radii, m_fractions, m_numberFractions, m_cumulative;
  Basis m_basis = Basis::kNumber;
};

}  // namespace pflow::frontend
