// Beverloo's law from a flat-bottomed silo (docs/accuracy.md, "Beverloo"): the silo scene for one orifice, its
// discharge rate and the settled bed's bulk density, and the fit of C and k over several orifices. Used by
// pflow-beverloo (bench/beverloo.cc) and beverloo_test (label gpu).
#pragma once
#include <string>
#include <vector>

#include "compute/core/ExecutorKind.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::bench {

struct BeverlooOptions {
  double siloRadius = 0.04, fillHeight = 0.09, rMin = 0.0009, rMax = 0.0011, spacing = 0.0023;
  double youngs = 5e7, friction = 0.5, rolling = 0.02, restitution = 0.5;
  double settle = 0.35, transient = 0.15, window = 0.5;  // [s]
  std::string precision = "double";
};

struct BeverlooRow {
  double D = 0, W = 0, bulkDensity = 0, meanDiameter = 0, wall = 0;  // [m], [kg/s], [kg/m^3], [m], [s]
  std::size_t particles = 0;
  std::string error;
};

struct BeverlooFit {
  double C = 0, k = 0, bulkDensity = 0, meanDiameter = 0, worstResidual = 0;
  bool ok = false;
};

// The bulk density of a settled bed's core, shared by the silo problems (Beverloo, Janssen): the particle volume
// (density rho) with centres in a cylinder of radius coreRadius about the z axis between a quarter and three quarters
// of `top`, over that cylinder's volume (the volumes of the spheres it cuts average out).
double coreBulkDensity(const compute::ParticleSnapshot& s, double coreRadius, double top, double rho);

std::string beverlooScene(const BeverlooOptions& o, double D);
BeverlooRow runBeverloo(const BeverlooOptions& o, double D, compute::ExecutorKind kind);
// W^{2/5} = a D + b by least squares: a = (C rho_b sqrt(g))^{2/5}, b = -a k d (rho_b, d: the rows' means).
BeverlooFit fitBeverloo(const std::vector<BeverlooRow>& rows);

}  // namespace pflow::bench
