// Janssen's wall-stress saturation in a silo (docs/accuracy.md, "Janssen"): beads settle in a cylinder whose side wall
// is cut into bands and each band into four quadrants, every quadrant a surface of its own, so the per-surface wall
// loads give the wall's normal stress (the quadrant's radial resultant over sqrt(2) R h) and shear (its vertical
// load over (pi/2) R h) band by band. Janssen: sigma_w(z) = sigma_inf (1 - exp(-z / lambda)), sigma_inf = rho_b g D /
// (4 mu), lambda = D / (4 mu K), with mu the wall friction the bed mobilises (tau / sigma, measured). Used by
// pflow-janssen (bench/janssen.cc) and janssen_test (label gpu).
#pragma once
#include <string>
#include <vector>

#include "compute/core/ExecutorKind.h"

namespace pflow::bench {

struct JanssenOptions {
  double radius = 0.02;       // silo radius R [m] (D = 2R)
  double fillHeight = 0.5;    // height of the lattice the beads start on [m]: a settled bed about 4 lambda deep
  double rMin = 0.0009, rMax = 0.0011, spacing = 0.0023;
  double youngs = 5e7, friction = 0.5, wallFriction = 0.3, rolling = 0.02, restitution = 0.3;
  double bandHeight = 0.01;   // [m]
  double settle = 0.6, average = 0.1;  // [s]: settling, then (after the floor drop) the loads averaged over this
  double floorDrop = 0.0005;  // how far the floor sinks after the settling [m], mobilising the wall friction
  std::string precision = "double";
  std::uint64_t seed = 1;
};

struct JanssenBand {
  double depth = 0;    // below the bed's surface, at the band's middle [m]
  double normal = 0;   // sigma_w [Pa]
  double shear = 0;    // tau_w [Pa]
};

struct JanssenResult {
  std::vector<JanssenBand> bands;  // those fully below the surface, shallowest first
  double bulkDensity = 0, surface = 0, floorLoad = 0, weight = 0, wallShearLoad = 0;
  double mobilised = 0;         // tau / sigma averaged over the bands deeper than lambda
  double sigmaInf = 0, lambda = 0;  // the fit
  double janssenInf = 0;        // rho_b g D / (4 mobilised)
  double K = 0;                 // D / (4 mobilised lambda)
  double fitResidual = 0;       // rms of the fit over sigma_inf
  std::size_t particles = 0;
  double wall = 0;
  std::string error;
};

JanssenResult runJanssen(const JanssenOptions& o, compute::ExecutorKind kind);

}  // namespace pflow::bench
