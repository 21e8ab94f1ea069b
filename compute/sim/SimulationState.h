// What a run of either solver needs to go on from a step bit for bit (DEM's Simulation::state and resume, SPH's
// SphSimulation::state and resume; a checkpoint file holds one: backend/store/CheckpointFile.h). Taken just after
// a neighbour rebuild, where resuming's own rebuild reproduces the run's order and lists. docs/operations.md.
#pragma once
#include <cstdint>
#include <vector>

#include "compute/particles/ParticleSnapshot.h"

namespace pflow::compute {

struct SimulationState {
  // The owned particles' kMigrate and kCheckpoint fields in the table's types, row-major (FieldRows::stateArrays).
  ParticleSnapshot particles;
  int contactSlots = 0, wallSlots = 0;  // DEM: the history slots per particle
  std::int64_t step = 0, stepBase = 0, rebuilds = 0;
  double time = 0, timeBase = 0;  // [s]; DEM: t = timeBase + (step - stepBase) dt
  double dt = 0;                  // [s] DEM: the step; SPH: the last step taken
  double dtBefore = 0;            // [s] SPH Verlet: the step before it
  int reductions = 0;             // DEM: simulation.on_instability: reduce_dt's so far
  std::vector<double> wallDrive;  // DEM: the driven walls' state (WallDrives::state), empty without them

  // Everything but the particles, as exact doubles (a distributed resume broadcasts rank 0's), and back: kScalars
  // values, then the driven walls' state.
  static constexpr std::size_t kScalars = 10;
  std::vector<double> scalars() const {
    std::vector<double> v{double(contactSlots), double(wallSlots), double(step), double(stepBase), double(rebuilds), time, timeBase, dt, dtBefore,
                          double(reductions)};
    v.insert(v.end(), wallDrive.begin(), wallDrive.end());
    return v;
  }
  void setScalars(const std::vector<double>& v) {
    if (v.size() < kScalars) return;
    wallDrive.assign(v.begin() + kScalars, v.end());
    contactSlots = int(v[0]);
    wallSlots = int(v[1]);
    step = std::int64_t(v[2]);
    stepBase = std::int64_t(v[3]);
    rebuilds = std::int64_t(v[4]);
    time = v[5];
    timeBase = v[6];
    dt = v[7];
    dtBefore = v[8];
    reductions = int(v[9]);
  }
};

}  // namespace pflow::compute
