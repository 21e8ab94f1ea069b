// The reference problems of the accuracy-speed study (docs/accuracy.md): each builds its RunConfig in code,
// runs it with one setting (time step as a fraction of the Rayleigh time, precision, stiffness softening,
// neighbour skin, rebuild interval) and returns its measured quantities against their references, the cost
// (wall seconds per simulated second of the stepping alone) and how the run failed, if it did.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "compute/sim/RunConfig.h"
#include "compute/dem/Simulation.h"

namespace pflow::bench::accuracy {

struct Setting {
  compute::ExecutorKind executor = compute::ExecutorKind::kCpu;
  compute::Precision precision = compute::Precision::kDouble;
  double dtFraction = 0.2;    // of the Rayleigh time of the (softened) material
  double softening = 1;       // Young's moduli divided by this
  double skinFraction = 0.1;  // neighbour skin, in largest particle diameters
  int rebuildInterval = 0;    // 0 = automatic (skin criterion); N = every N steps
  int threads = 0;
  std::uint64_t seed = 0;     // bulk problems: which random packing (set by the study's averaging)
};

struct Quantity {
  std::string name;
  double reference = 0;
  double value = 0;  // NaN when the run could not measure it
};

struct Outcome {
  std::vector<Quantity> quantities;
  double wallPerSimSecond = 0;  // wall seconds of the step calls / simulated seconds
  std::int64_t steps = 0;
  std::string status = "ok";  // ok | energy gain | lost contacts | tunnelling | damping instability |
                              // non-finite | excessive overlap | error
  std::string detail;         // the run's error message, if any
  // Bulk problems: each value is the mean over a few random packings; these are the packings' own values
  // (per quantity, in packing order), whose scatter is the noise floor of the comparison.
  std::vector<std::vector<double>> packings;
};

// A reference problem: a named case (`family/variant`) and how to run it. `reference` is filled for
// problems whose reference is the finest setting (no closed form): `run` fills the values, the study fills
// the references from the finest run.
struct Problem {
  std::string name;    // e.g. "chung_ooi_1/glass"
  std::string family;  // e.g. "chung_ooi_1" (one chart per family)
  bool bulk = false;   // no closed form: reference = the finest setting in double (and costly: fewer settings)
  std::function<Outcome(const Setting&)> run;
};

std::vector<Problem> allProblems();
// The adhesion problems (AdhesionProblems.cc), part of allProblems().
std::vector<Problem> adhesionProblems();

// The failure mode named by a run's error (the run-time detectors' messages start with a cause keyword:
// "energy growth:", "tunnelling:", "excessive overlap:", "non-finite:"; older messages are matched by content).
std::string classifyError(const std::string& message);

const char* precisionName(compute::Precision p);
const char* executorName(compute::ExecutorKind k);

}  // namespace pflow::bench::accuracy
