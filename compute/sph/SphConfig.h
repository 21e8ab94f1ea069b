// The plain, validated description of one SPH run (solver: sph): the fluid, the numerical method and the
// particles the frontend generated (fluid on a lattice, walls as layers of boundary particles). SI units.
// docs/sph.md gives every parameter's meaning and default; docs/scene-format.md the scene keys.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/core/VectorMath.h"
#include "compute/sph/SphMdbc.h"
#include "compute/sph/SphPhysics.h"

namespace pflow::compute {
struct SimulationSettings;
}

namespace pflow::compute::sph {

enum class ParticleKind : std::int32_t { kFluid = 0, kBoundary = 1 };

// How the tank's walls act (sph.boundary): layers of dynamic boundary particles (Crespo et al. 2007), or mirror
// images of the fluid across the tank's flat walls (seed 002; MirrorWalls in SphPhysics.h). Obstacles are
// boundary particles either way.
enum class BoundaryKind { kDynamic, kMirror };

// The time integration (sph.integrator): the symplectic position-Verlet predictor-corrector (two evaluations of
// the rates per step), velocity Verlet (kick-drift-kick: one evaluation per step), or Verlet (Monaghan 1989; one
// evaluation per step, an Euler step every sph.verlet_steps to keep the two interleaved solutions together):
// docs/sph.md, "Time integration".
enum class Integrator { kSymplectic, kVerlet, kVelocityVerlet };
// The integrator's name in scenes ("symplectic", "verlet", "velocity_verlet").
const char* integratorName(Integrator i);

// A named region the frontend filled (fluid block, tank, obstacle): for messages and checks.
struct SphRegion {
  std::string name;  // "fluid.blocks[0]" style path or the entry's name
  Vec3d lo{0, 0, 0}, hi{0, 0, 0};
};

// A point where the pressure is sampled (a probe) or a vertical line along which the free-surface height is
// measured (a gauge), every output.probe_interval seconds, into the HDF5 file (docs/sph.md, "Probes").
struct SphProbe {
  std::string name;
  Vec3d point{0, 0, 0};
  bool gauge = false;  // a height gauge at (x, y): point.z is ignored
};

struct SphConfig {
  // The method.
  int dimension = 2;           // 2: planar flow in the x-z plane (y is the plane's normal); 3
  double spacing = 0;          // dp: lattice spacing of the particles [m]
  double smoothingRatio = 1.5; // h / dp
  KernelKind kernel = KernelKind::kWendlandC2;
  double density = 0;          // rho0 [kg/m^3], required
  std::optional<double> soundSpeed;  // c0 [m/s]; unset: 10 x the expected maximum speed (derived())
  double gamma = 7;            // Tait exponent
  double artificialViscosity = 0.01;  // Monaghan alpha
  double kinematicViscosity = 0;      // laminar nu [m^2/s]; 0: off
  double densityDiffusion = 0.1;      // delta of Molteni & Colagrossi (2009); 0: off
  bool hydrostaticDiffusion = true;   // Fourtakas et al. (2019) correction of the density diffusion
  double cfl = 0.2;
  Integrator integrator = Integrator::kSymplectic;
  int verletSteps = 40;        // Verlet: every verletSteps-th step is an Euler step (DualSPHysics's default)
  std::optional<double> dt;    // fixed step [s] (the convergence study); unset: CFL limits each step
  BoundaryKind boundary = BoundaryKind::kDynamic;  // the tank's walls
  bool freeSlip = false;       // mirror walls: the image keeps the tangential velocity (sph.wall_slip: free_slip)
  int boundaryLayers = 0;      // dynamic walls: 0 = enough to cover the kernel support, ceil(2h/dp)
  // sph.boundary_density: mdbc: every boundary particle's density extrapolated from the fluid at its ghost node
  // (English et al. 2022, SphMdbc.h) instead of the dynamic boundary's continuity equation.
  bool mdbc = false;
  double skin = 0.25;          // neighbour skin as a fraction of h: cells are 2h + skin wide
  // The rates pass reads hit masks, marked by the first pass after each sort (SphKernels.h, RatePass), instead of
  // testing every candidate of the walk: the same pairs in the same order, so the same sums; faster from rest, level
  // in a flow that sorts every few steps (docs/sph.md, Performance). Not a scene key: pflow-sph-bench --masks.
  bool hitMasks = false;
  // Density bounds (DualSPHysics's RhopOut): a fluid particle outside [min, max] x rho0 stops the run.
  double minDensityRatio = 0.7, maxDensityRatio = 1.3;

  // The particles (the frontend's generators fill them): fluid first, then boundary.
  std::vector<Vec3d> position;
  std::vector<Vec3d> velocity;  // empty: at rest
  std::vector<ParticleKind> kind;
  std::vector<SphRegion> fluidBlocks;  // what was filled with fluid
  std::optional<SphRegion> tank;       // the container (inside of its walls)
  bool tankOpenTop = true;             // no wall (or mirror) at tank->hi.z
  std::vector<SphRegion> obstacles;
  std::vector<SphProbe> probes;
  double probeInterval = 0;  // [s]; 0: at the snapshots only
  // output.probe_sampling: false ("instant"): a sample is the reading at the step that reaches it; true ("mean"): the
  // time average of the readings of every step since the previous sample (a sensor that integrates over the
  // record's interval), at the cost of a reading every step.
  bool probeMean = false;

  std::size_t size() const { return position.size(); }
  std::size_t fluidCount() const;
  // Every problem at once, each naming the scene key ("sph.spacing") and the bound it breaks. `sim`: the
  // run's duration, gravity and snapshots.
  ErrorList validate(const SimulationSettings& sim) const;
};

// sph.boundary_density: mdbc: the interfaces of the tank's walls and the obstacles as the lattice fills them (whole
// spacings from each box's low corner, SphLattice.cc), and which obstacle faces meet the fluid (not those standing on
// the tank's wall or against another obstacle). Obstacles past MdbcGeometry::kMaxObstacles are left out (validate()
// names them).
MdbcGeometry mdbcGeometry(const SphConfig& c);
// The obstacles thinner than twice the kernel's support along an axis whose both faces meet the fluid: where fluid
// reaches both sides, its particles' density comes from the nearer side only, and the fluid on the other sees it. A
// warning each (SphSimulation::create logs them), not an error: a box whose far side stays dry for most of a run is
// served well.
std::vector<std::string> mdbcThinObstacles(const SphConfig& c);

// What follows from the configuration: the quantities the engine runs with and where each came from.
struct SphDerived {
  double h = 0;              // smoothing length [m]
  double c0 = 0;             // speed of sound [m/s]
  double expectedSpeed = 0;  // the maximum speed the flow is expected to reach [m/s] (c0's basis)
  double fluidHeight = 0;    // the deepest fluid column along gravity [m]
  int boundaryLayers = 0;
  double particleMass = 0;   // rho0 dp^d [kg]
  std::string soundSpeedReason;
};
SphDerived derive(const SphConfig& c, const SimulationSettings& sim);

// The kernel's name in scenes ("wendland", "cubic_spline").
const char* kernelName(KernelKind k);

}  // namespace pflow::compute::sph
