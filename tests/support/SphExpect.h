// Shared expectations of the SPH validation tests (GoogleTest): the 2D dam break's surge front against Martin &
// Moyce (1952) with the gate's time shift.
#pragma once
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "tests/support/SphScenes.h"

namespace pflow::test {

// Runs the dam break and expects, against the experiment: the front times within 8 % once the experiment's time
// origin moves by the gate's opening (0.175 in T, Lethe's comparison; sph-reference §0.4), and the front's speed
// dZ/dT from Z = 2 to 3.5 within 5 %. Prints each time with its raw and shifted error, prefixed by `label`.
inline void expectFrontFollowsMartinMoyce(compute::sph::SphSimulation& sim, double dp, const std::string& label, double gate = 0.175) {
  const std::vector<double>& zs = kFrontZ;
  const std::vector<double>& experiment = kMartinMoyceT;
  const std::vector<double> t = frontTimes(sim, dp, zs);
  for (std::size_t k = 0; k < zs.size(); ++k) {
    ASSERT_TRUE(std::isfinite(t[k])) << "the front never reached Z = " << zs[k];
    EXPECT_NEAR(t[k] + gate, experiment[k], 0.08 * experiment[k]) << "Z = " << zs[k];
    std::printf("%sZ %.1f: T %.3f (experiment %.3f, %+.1f%%; with the gate's %.3f, %+.1f%%)\n", label.c_str(), zs[k], t[k], experiment[k],
                100 * (t[k] / experiment[k] - 1), gate, 100 * ((t[k] + gate) / experiment[k] - 1));
  }
  const double speed = (zs[4] - zs[1]) / (t[4] - t[1]), measured = (zs[4] - zs[1]) / (experiment[4] - experiment[1]);
  EXPECT_NEAR(speed, measured, 0.05 * measured);
  std::printf("%sfront speed dZ/dT from Z = 2 to 3.5: %.3f (experiment %.3f)\n", label.c_str(), speed, measured);
}

// Fluid particles (kind 0) in horizontal layers one spacing thick, from the floor (z = 0) to the kernel's reach
// (2h) under the free surface: each layer's mean pressure within `tolerance` of rho g (surface - its mean z).
// Returns the layers checked.
inline int expectHydrostaticLayers(const compute::ParticleSnapshot& s, double surface, double dp, double h, double rho, double g,
                                   double tolerance) {
  const auto* x = s.find("position")->as<Vec3d>();
  const auto* p = s.find("pressure")->as<double>();
  const auto* kind = s.find("kind")->as<std::int32_t>();
  int layers = 0;
  for (double z = 0; z < surface - 2 * h; z += dp) {
    double sum = 0, zsum = 0;
    int count = 0;
    for (std::size_t i = 0; i < s.n; ++i)
      if (kind[i] == 0 && x[i].z >= z && x[i].z < z + dp) {
        sum += p[i];
        zsum += x[i].z;
        ++count;
      }
    if (!count) continue;
    ++layers;
    EXPECT_NEAR(sum / count, rho * g * (surface - zsum / count), tolerance) << "layer at z = " << zsum / count;
  }
  return layers;
}

}  // namespace pflow::test
