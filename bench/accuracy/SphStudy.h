// The SPH part of the accuracy-speed study (pflow-accuracy --solver sph; docs/sph.md, "Convergence"): the 2D
// dam break of seed 002 against Martin & Moyce (1952), swept over resolution (20 x 40 ... 200 x 400 at the CFL
// step, every other parameter fixed) and over a fixed dt (seed 002's sweeps), each run's surge-front times
// and its cost. Writes docs/sph/dam_break_2d.csv (resolution,T,Z) and docs/sph/convergence.csv.
#pragma once
#include <string>
#include <vector>

#include "compute/core/ExecutorKind.h"
#include "compute/sim/RunConfig.h"

namespace pflow::bench::accuracy {

struct SphStudyOptions {
  compute::ExecutorKind executor = compute::ExecutorKind::kCpu;
  compute::Precision precision = compute::Precision::kDouble;
  std::string out = "docs/sph";
  bool quick = false;  // 20 x 40 and 40 x 80 only, no dt sweep
  // The sweeps to run ("" every one): resolution (boundary particles), mirror (the resolution ladder with mirror
  // walls), dt, particles_at_1e-5. Rows of the sweeps not run are kept in convergence.csv.
  std::string only;
  int threads = 0;
};

int runSphStudy(const SphStudyOptions& options);

}  // namespace pflow::bench::accuracy
