// The standard throughput scene (../shared/design/benchmarks.md): a box with walls on five faces,
// spheres on a jittered cubic lattice that settle under gravity into a dense bed.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/Status.h"
#include "compute/particles/ParticleSnapshot.h"
#include "compute/sim/RunConfig.h"

namespace pflow::bench {

struct BedSpec {
  int nx = 100, ny = 100, nz = 20;  // lattice sites
  double diameter = 1e-3;           // d [m]; polydisperse radii are uniform in [d/4, d/2]
  bool polydisperse = false;
  double spacing = 1.05;            // lattice spacing in diameters
  double jitter = 0.02;             // per-axis random shift, in diameters
  double dt = 5e-6;                 // [s]
  double skin = 0.1;                // in diameters
  std::uint64_t seed = 1;
  int threads = 0;
};

// Material per benchmarks.md: rho 2500, E 1e7, nu 0.3, e 0.5, mu 0.5, no rolling friction; walls
// of the same material; planes at x = 0, x = Lx, y = 0, y = Ly, z = 0.
compute::RunConfig bedScene(const BedSpec& spec);

// nx = ny chosen so that nx * ny * nz is close to n.
BedSpec bedSpecFor(std::int64_t n, bool polydisperse);

// A large bed made of tx x ty copies of a settled small one (`bed` as built by bedScene, `settled` its
// state after settling), side by side in a box tx times as long and ty times as wide: the standard bed
// at 10^6..10^8 spheres without settling each at full size. Positions, velocities and spins are copied;
// contact history starts empty (it rebuilds within a few steps of a resettle).
compute::RunConfig tiledBed(const compute::RunConfig& bed, const compute::ParticleSnapshot& settled, int tx, int ty);
// The same with about n spheres: the tx x ty closest to n / settled.n copies, as square as possible.
compute::RunConfig tiledBed(const compute::RunConfig& bed, const compute::ParticleSnapshot& settled, long n);

// `cfg` with the positions, velocities and spins of `state` (a snapshot of a run of cfg: rows by gid).
compute::RunConfig withState(compute::RunConfig cfg, const compute::ParticleSnapshot& state);

// A settled bed's state kept between runs (pflow-bench --base-cache DIR): a pflow snapshot file (HDF5 with its
// XDMF sidecar, so ParaView shows the bed) whose name says what was settled and how, e.g.
// DIR/settled-200000-mono-30000-cuda.h5. loadSettledBed returns false when there is none.
std::string settledBedPath(const std::string& dir, long size, bool polydisperse, int settleSteps, const std::string& executor);
Status saveSettledBed(const std::string& path, const compute::ParticleSnapshot& state);
bool loadSettledBed(const std::string& path, compute::ParticleSnapshot& out);

// The fewest bytes per particle that each phase of a step must move through device memory (every array it
// needs read once, every result written once; neighbours' data assumed to come from cache), for `realBytes`
// of 4 (float) or 8 (double), `candidates` and `contacts` per particle. docs/performance.md derives it.
std::vector<std::pair<std::string, double>> compulsoryTraffic(int realBytes, double candidates, double contacts);

}  // namespace pflow::bench
