// What `pflow validate` (and the frontend service's ValidateScene) reports about a loaded scene: counts, sizes,
// solid fractions, triangles per surface, the time step and why, and a memory estimate.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/dem/ModelChoice.h"
#include "frontend/SceneLoader.h"

namespace pflow::frontend {

struct SceneSummary {
  std::string solver = "dem";  // "dem" or "sph" (SphSummary.cc: sets are the fluid and the wall particles)
  std::size_t particles = 0;
  double minRadius = 0, maxRadius = 0;  // [m]
  double solidVolume = 0;               // [m^3]
  struct Set {
    ParticleSetInfo info;
    double solidFraction = 0;  // of its region; 0 without a region
  };
  std::vector<Set> sets;
  std::size_t planes = 0, meshes = 0, triangles = 0;
  std::vector<SurfaceInfo> surfaces;
  compute::Aabb domain;          // [m], as given or derived
  double domainSolidFraction = 0;
  std::array<int, 3> cells{0, 0, 0};
  double cellSize = 0;           // [m]
  double skin = 0;               // [m]
  double rayleighTime = 0;       // [s]
  double dt = 0;                 // [s]
  std::string dtReason;
  std::vector<std::string> warnings;
  std::int64_t steps = 0;        // to simulation.duration
  double bytesPerParticle = 0;   // estimate of device memory per particle at the initial slot counts
  double memoryBytes = 0;        // estimate for the whole run on one device
  // The least model the scene needs (simulation.model), each decision with its reason; the executor is not
  // known here, so an accuracy target picks float only where the study proposes it on every executor.
  compute::ModelChoice model;
};

Result<SceneSummary> summarize(const LoadedScene& scene);
// The SPH scene's summary (summarize() calls it for solver: sph).
Result<SceneSummary> summarizeSph(const LoadedScene& scene);

// One JSON object (SI units in the key names: radius_min_m, dt_s, ...), as `pflow validate --json` prints it.
std::string toJson(const SceneSummary& summary);

}  // namespace pflow::frontend
