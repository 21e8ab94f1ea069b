// The least model a scene needs (simulation.model: auto), derived from the run configuration alone: which
// parts of the step the engine may skip because they cannot change the answer, and why. `pflow validate`
// prints the decisions, the job record keeps them, and prepareEngineSetup / Simulation::create apply them
// (EngineSetup::model, the run's precision), so the work is really skipped. Pure host code.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "compute/dem/AccuracyTable.h"
#include "compute/dem/ModelFlags.h"
#include "compute/sim/RunConfig.h"

namespace pflow::compute {

struct ModelDecision {
  std::string name;    // "dimensions", "tangential history", ...
  std::string choice;  // "2D (discs in the x-y plane)", "off", ...
  std::string reason;  // why, in a sentence
};

struct ModelOptions {
  // The executor the run will use ("cpu" or "cuda"); empty where it is not known yet (validate, the job record):
  // the accuracy target then picks float only if the study proposes float on every executor it measured.
  std::string executor;
  // Particles that keep one GPU busy: the manager's --particles-per-gpu default (manager/Placement.h).
  std::uint64_t particlesPerGpu = 1000000;
  const AccuracyTable* table = nullptr;  // null: AccuracyTable::builtIn()
};

struct ModelChoice {
  bool full = false;  // simulation.model: full
  ModelFlags flags;
  Precision precision = Precision::kDouble;
  double cellSize = 0;  // [m], before any coarsening of a huge grid (the setup's grid has the final one)
  int gpus = 1;         // the manager's placement rule, on an unlimited pool
  std::vector<AccuracyProposal> proposals;  // for simulation.accuracy (empty: none, or no target)
  std::vector<ModelDecision> decisions;

  // One decision per line: "  tangential history: off — every material and pair has friction 0".
  std::string text() const;
};

// Planar-scene tolerance: centres may differ along the axis by this fraction of the smallest radius.
inline constexpr double kPlanarTolerance = 1e-9;

ModelChoice deriveModel(const RunConfig& config, const ModelOptions& options = {});

}  // namespace pflow::compute
