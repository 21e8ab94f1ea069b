// The device side of an SPH run: the particle arrays (the SPH field table), the cell list and one method
// per phase of the step. SphSimulation drives it; an executor (OpenMP or CUDA) runs it through the shared
// machinery: FieldStore/FieldRows (reorder, snapshots), the cell hash and sort, the executors' primitives.
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/neighbor/CellGrid.h"
#include "compute/particles/DistributedRows.h"
#include "compute/particles/ParticleSnapshot.h"
#include "compute/sph/SphMdbc.h"
#include "compute/sph/SphPhysics.h"

namespace pflow::compute::sph {

// Everything the engine needs, prepared on the host from a validated SphConfig (prepareSphSetup).
struct SphSetup {
  std::vector<Vec3d> position, velocity;
  std::vector<double> density, mass;
  std::vector<std::int32_t> kind;  // ParticleKind
  std::vector<Gid> gid;            // empty: the index
  KernelKind kernel = KernelKind::kWendlandC2;
  int dimension = 2;
  double h = 0;
  double rho0 = 1000, c0 = 0, gamma = 7;
  double alpha = 0, nu = 0, delta = 0;
  bool hydrostaticDiffusion = true;
  Vec3d gravity{0, 0, -9.81};
  double minDensity = 0, maxDensity = 0;  // [kg/m^3], fluid
  bool checkBox = false;  // leak check (the tank's outer walls; open top)
  Vec3d boxLo{0, 0, 0}, boxHi{0, 0, 0};
  MirrorWalls mirror;     // sph.boundary: mirror (mirror.any false: none)
  MdbcGeometry mdbc;      // sph.boundary_density: mdbc (mdbc.on false: the dynamic boundary's continuity)
  CellGrid grid;
  double skin = 0;  // [m]
  bool hitMasks = false;  // SphConfig::hitMasks
  // The walk in two phases (RatePass::kTwoPhase) or in one; unset: two on the GPU in float (0.94-0.97 of the one
  // phase's time on SPHERIC at 4.8e6 on an H100; 1.25 in double), one on the CPU. No scene key (the same sums
  // either way): for timing.
  std::optional<bool> twoPhaseWalk;
  // simulation.reproducible: false lets a one-process GPU run evaluate each pair once (Interact's kOnce: half the
  // candidates and pairs, the partner's share by an atomic add; sums in no fixed order, so reruns agree to rounding).
  bool reproducible = true;
  // The pairs once on this engine's executor or not; unset: on the GPU in float where reproducible is false (with the
  // two-phase walk, the GPU's default in float: 0.62 of its time on SPHERIC at 4.8e6, H200; in double 1.08 of the
  // one-phase walk's, so not there), never on the CPU (its atomic adds are compare-and-swap loops: for the tests).
  // Never with ghosts, canonical order or hit masks (SphSetup::hitMasks set).
  std::optional<bool> pairsOnce;
  int threads = 0;
  // Neighbours summed in global-id order (SortCellByGid): forces independent of the rows' order, so a
  // distributed run equals one process with this set, bit for bit. Distributed runs always set it.
  bool canonicalOrder = false;
  // Distributed runs: each particle's cost weight (sphCostWeight) as the scene's partition used it, the balance's
  // weights until the engine's first cell sort (then its own wet flags). Empty: one process.
  std::vector<double> costWeight;
};

// The balance's weights (DistributedRows::costWeights): a fluid particle 1; a wall particle with fluid listed within
// reach (wet, MarkWet) walks the same candidates as a fluid one but evaluates its fluid neighbours only, about half
// the pairs: 0.5; a dry wall particle is skipped by the rates pass, leaving its share of the sort, the packing and
// the integration: 0.05. Estimates from the pass's structure, not measurements; where a run measures its costs
// (MpiDomainOptions::Cost::kMeasured) each rebuild rescales them by the rank's measured seconds.
inline double sphCostWeight(bool fluid, bool wet) { return fluid ? 1.0 : wet ? 0.5 : 0.05; }
// The weights of a scene's particles before any sort: wet from the grid's cells within reach of a fluid particle's.
std::vector<double> sphCostWeights(const CellGrid& grid, const std::vector<Vec3d>& position, const std::vector<std::int32_t>& kind);

// One particle as the host sees it, for error messages (copied off the device on the error path only).
struct SphProbeState {
  Gid gid = kNoGid;
  bool fluid = true;
  Vec3d position{0, 0, 0}, velocity{0, 0, 0};
  double density = 0, pressure = 0;
};

// The SPH engine. Its local rows (owned, then ghosts of other ranks) and their exchange are
// DistributedRows's: a distributed run's rebuild is dropGhosts, keepOwned + appendOwned, sortByCell, setGhosts;
// between rebuilds refreshGhosts before each evaluation of the rates.
class SphEngine : public DistributedRows {
 public:
  virtual std::string executorDescription() const = 0;
  virtual const char* precisionName() const = 0;

  // Phases, in step order (SphSimulation::stepPhases).
  // The owned particles sorted by cell (every field reordered); positions now are the skin's reference.
  virtual void sortByCell() = 0;
  // Acceleration, density rate and viscous rate of every owned particle at the current state (ghosts are
  // neighbours).
  // Between rebuilds of a distributed run the rates go in two passes so the halo can travel during the first:
  // kInterior (particles with no ghost in the cells within reach; only queued) then kBoundary (the rest, once the
  // ghosts are refreshed). Without ghosts every particle is interior.
  enum class RateSet { kAll, kInterior, kBoundary };
  virtual void computeRates(RateSet set) = 0;
  void computeRates() { computeRates(RateSet::kAll); }
  // The largest inverseStep over the owned particles (SphPhysics.h): the time step's input, one reduction.
  virtual double maxInverseStep() const = 0;
  // The two halves of the symplectic step; each returns the largest squared displacement since the sort.
  virtual double predictor(double dt) = 0;
  virtual Status corrector(double dt, double& moved2) = 0;
  // One Verlet step (sph.integrator: verlet) of dt after one of dtBefore (0: an Euler step), checked as the
  // corrector is.
  virtual Status verlet(double dt, double dtBefore, double& moved2) = 0;
  // Velocity Verlet (sph.integrator: velocity_verlet): the first kick and the drift (x a step on, v and rho predicted
  // for the rates; returns the largest squared displacement since the sort), then, with the rates at the new
  // positions, the second kick, checked as the corrector is.
  virtual double kickDrift(double dt) = 0;
  virtual Status kick(double dt) = 0;
  // The furthest a fluid particle reaches along the unit vector `direction`: max of x.direction [m] (one
  // device reduction; the surge front of a dam break is this along +x).
  virtual double fluidReach(Vec3d direction) const = 0;
  // The owned fluid's kernel sums at `points` (SampleRows and SampleSum in SphKernels.h): its share of the kernel there and the
  // share-weighted pressure sum [Pa] (the Shepard pressure is their ratio once summed over ranks). Points in a 2D
  // run lie in its plane.
  virtual void sample(const std::vector<Vec3d>& points, std::vector<double>& fraction, std::vector<double>& pressure) const = 0;

  // Checkpoints (SphSimulation::state, resume): the owned rows' kMigrate and kCheckpoint fields, row-major
  // (FieldRows::stateArrays), and their load into an engine of either executor.
  virtual ParticleSnapshot stateArrays(std::int64_t step, double time) const = 0;
  // `costWeight`: the rows' balance weights until the first sort (a distributed resume's partition's; empty: one process).
  virtual Status loadState(const ParticleSnapshot& s, std::vector<double> costWeight = {}) = 0;

  virtual SphProbeState probe(Index i) const = 0;
  virtual std::size_t deviceBytes() const = 0;
  virtual void fence() const = 0;
  // The rates pass from the next one on (pflow-sph-bench --variants: timed one after another from the same flow):
  // hit masks (SphSetup::hitMasks, marked at the next sort), or the walk in two phases or in one (SphSetup::twoPhaseWalk),
  // each pair from both sides or once (SphSetup::pairsOnce).
  virtual void setRatePasses(bool hitMasks, bool twoPhaseWalk, bool pairsOnce) = 0;
  // Whether the last rates pass evaluated each pair once (SphSetup::pairsOnce and the conditions it needs).
  virtual bool pairsOnce() const = 0;
  // The last rates pass over every row: "walk", "twophase", "mark", "masks", "walk_once" or "twophase_once" ("none"
  // before the first; "walk" for a distributed run's two passes).
  virtual const char* lastRatePass() const = 0;
};

std::unique_ptr<SphEngine> makeCpuSphEngine(SphSetup setup, bool singlePrecision);
// An error, never a fall-back, where this pflow was built without CUDA or the device is missing.
Result<std::unique_ptr<SphEngine>> makeCudaSphEngine(SphSetup setup, int device, bool singlePrecision);

}  // namespace pflow::compute::sph
