// Shared expectations of the SPH validation tests (GoogleTest): the 2D dam break's surge front against Martin &
// Moyce (1952) with the gate's time shift, and a tank at rest.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
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

// A tank of water `depth` deep at rest (the hydrostatic tests): its fluid's settled surface (the highest particle plus
// half a spacing), lowest and leftmost particle, after expecting the fluid still (max speed under 1 % of sqrt(g H))
// and its pressure in at least `minLayers` layers within 2 % of rho g H of rho g (surface - z).
struct TankAtRest {
  double surface, lowest, leftmost, maxSpeed;
};
inline TankAtRest expectTankAtRest(const compute::ParticleSnapshot& s, double dp, double h, double depth, int minLayers) {
  const auto* x = s.find("position")->as<Vec3d>();
  const auto* v = s.find("velocity")->as<Vec3d>();
  const auto* kind = s.find("kind")->as<std::int32_t>();
  double top = -1e300;
  TankAtRest r{0, 1e300, 1e300, 0};
  for (std::size_t i = 0; i < s.n; ++i)
    if (kind[i] == 0) {
      top = std::max(top, x[i].z);
      r.lowest = std::min(r.lowest, x[i].z);
      r.leftmost = std::min(r.leftmost, x[i].x);
      r.maxSpeed = std::max(r.maxSpeed, norm(v[i]));
    }
  const double g = 9.81, rho = 1000;
  r.surface = top + 0.5 * dp;
  EXPECT_LT(r.maxSpeed, 0.01 * std::sqrt(g * depth)) << "max speed " << r.maxSpeed;
  EXPECT_GE(expectHydrostaticLayers(s, r.surface, dp, h, rho, g, 0.02 * rho * g * depth), minLayers);
  return r;
}

// Test names of the integrators (INSTANTIATE_TEST_SUITE_P's last argument).
inline std::string integratorTestName(const ::testing::TestParamInfo<compute::sph::Integrator>& info) {
  using compute::sph::Integrator;
  return info.param == Integrator::kVerlet ? "Verlet" : info.param == Integrator::kVelocityVerlet ? "VelocityVerlet" : "Symplectic";
}

}  // namespace pflow::test
