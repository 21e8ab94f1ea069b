// The device side of a simulation: particle arrays, cell list, contact lists, walls, and one method
// per phase of the step. Simulation (host orchestration) drives it; an executor (OpenMP now, CUDA
// next) runs it. Nothing here includes an executor-specific header.
#pragma once
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/Status.h"
#include "compute/core/ExecutorKind.h"
#include "compute/dem/contact/ContactParams.h"
#include "compute/dem/contact/ForceKernel.h"
#include "compute/neighbor/CellGrid.h"
#include "compute/particles/DistributedRows.h"
#include "compute/particles/ParticleSnapshot.h"
#include "compute/dem/ModelFlags.h"

namespace pflow::compute {

// Everything an engine needs, prepared on the host from a validated RunConfig.
struct EngineSetup {
  // particles, in input order; gid = position in these arrays unless `gid` is given (a rank of a
  // distributed run holds only its own particles, with their global ids)
  std::vector<Vec3d> position, velocity, angularVelocity;
  std::vector<Gid> gid;
  std::vector<double> radius, mass;
  std::vector<std::int32_t> material;
  // walls
  std::vector<PlaneParams> planes;
  std::vector<std::string> planeNames;
  std::vector<std::int32_t> planeSurface;
  std::vector<std::string> surfaceNames;  // by surface number
  std::vector<Vec3d> triVerts;  // 3 per triangle, at t <= the motion's start
  std::vector<std::int32_t> triMesh, triMaterial, triSurface;
  std::vector<MeshMotionParams> meshMotion;  // per mesh
  std::vector<std::string> meshNames;
  // physics
  std::vector<ContactParams> contactTable;  // numMaterials^2
  int numMaterials = 0;
  std::uint64_t fixedMaterials = 0;  // MaterialConfig::fixed, bit m for material m (the first 64)
  Vec3d gravity{0, 0, 0};
  // neighbour search
  CellGrid grid;
  double skin = 0;
  double maxRadius = 0;
  int historySlots = 8;
  // Contact slots every particle carries at most where a history pool can take the rest (HistoryPool.h: the GPU's
  // pass in one process, without adhesion); 0: all inline (distributed runs: MpiDomain::partition).
  // PFLOW_INLINE_SLOTS=k overrides a nonzero value (measurements). 7: on the settled bed 311 B a particle in float,
  // the fastest of 5-8 (docs/performance.md, "The history pool").
  int inlineHistorySlots = 7;
  int wallHistorySlots = 4;
  // run-time detectors (docs/physics.md, "Instability detectors")
  double maxOverlap = 0.5;  // overlap limit, relative to the smaller radius (simulation.max_overlap)
  int maxContacts = 64;     // simultaneous particle contacts of one particle (simulation.max_contacts)
  bool checkDomain = false; // the scene stated simulation.domain: a centre leaving it is an error
  double dt = 0;            // the run's step at the start (errors at t = 0 suggest from it)
  Vec3d domainLo{0, 0, 0}, domainHi{0, 0, 0};
  int threads = 0;
  // Candidates in ascending global id (BuildNeighbors::canonicalOrder): the forces then do not depend on
  // the order of the rows, so a distributed run equals one process bit for bit. Set by distributed runs
  // (MpiDomain::partition) and by one-process runs that are compared with them (SimulationOptions).
  bool canonicalOrder = false;
  // Executors that can (the CPU's), in one process without canonicalOrder: each contact evaluated once and
  // its reaction added to the partner (kernels::ComputePairsOnce), half the arithmetic of evaluating it from
  // both sides. The sums then depend on the cell grid (the slabs), not on the thread count.
  bool pairsOnce = true;
  // The CPU's pairs once evaluates the contact law a batch of contacts at a time, in the core's SIMD lanes
  // (kernels::batchedSlab, ContactBatch.h): the same bits as one contact at a time (false; tests, measurements).
  bool batchedContacts = true;
  // simulation.reproducible: false lets a one-rank GPU run evaluate each contact once, by its lower index, with the
  // reactions added by atomic adds (ComputeForces' kHalf): the sums in no fixed order. PFLOW_GPU_HALF_PAIRS=1 does
  // the same on any executor that evaluates pairs from both sides (tests of it on the CPU, measurements).
  bool reproducible = true;
  // What to compute (deriveModel): 2D, tangential history, rolling torque, wall phases. Default: everything.
  ModelFlags model;
  // Data layouts: the executor's own, or forced to the GPU's (column-major candidate rows, slot-major
  // history) or the CPU's, so the CPU executor can be compared with itself across layouts in tests.
  enum class Layout { kExecutor, kGpu, kCpu } layout = Layout::kExecutor;
};

struct ContactStats {
  std::size_t particleContacts = 0;  // pairs in contact (each counted once)
  std::size_t wallContacts = 0;     // particle-plane and particle-triangle contacts (a particle on a triangle edge: two)
  double coordinationNumber = 0;     // 2 * pairs / N
  double maxOverlapRatio = 0;        // max over contacts of overlap / smaller radius (walls: / radius)
  double kineticEnergy = 0;          // translational + rotational [J]
  double translationalEnergy = 0;    // translational part [J] (a rattler may spin freely in its void)
  double maxSpeed = 0;               // [m/s]
  // Tangential histories held, particle and wall, as the evaluation from both sides keeps them: a particle
  // pair's counts twice (once per partner) also where its owner alone keeps it (EngineSetup::pairsOnce).
  std::size_t historyEntries = 0;
  double candidatesPerParticle = 0;  // mean length of the neighbour candidate lists
};

// One particle as the host sees it, for error messages (copied off the device on the error path only).
struct ParticleProbe {
  Gid gid = kNoGid;
  Vec3d position{0, 0, 0}, velocity{0, 0, 0};
  double radius = 0, speed = 0;
  // Hertz duration of a head-on impact on a particle of its own size and material at its speed [s]
  // (0 at rest or when not finite): the time scale a step must resolve.
  double contactTime = 0;
};

// The step an error suggests: half the current one, or a twentieth of the culprit's Hertz contact time
// at its measured speed when that is shorter.
inline double suggestedDt(double dt, const ParticleProbe& p) {
  double s = 0.5 * dt;
  if (p.contactTime > 0 && p.contactTime < 1e300 && p.contactTime / 20 < s) s = p.contactTime / 20;
  return s;
}

// How the detectors' errors name a particle: "particle G (radius r m at (x, y, z) m, speed v m/s)".
inline std::string describeParticle(const ParticleProbe& p) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "particle %llu (radius %.4g m at (%.6g, %.6g, %.6g) m, speed %.4g m/s)",
                (unsigned long long)p.gid, p.radius, p.position.x, p.position.y, p.position.z, p.speed);
  return buf;
}
// The end of a detector's error: "; suggested dt X s (now Y s)".
inline std::string dtSuggestion(double dt, const ParticleProbe& p) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "; suggested dt %.3g s (now %.3g s)", suggestedDt(dt, p), dt);
  return buf;
}

// The DEM engine. Its local rows (owned, then ghosts) and their exchange are DistributedRows's.
class Engine : public DistributedRows {
 public:
  virtual std::string executorDescription() const = 0;
  virtual const char* precisionName() const = 0;  // "float" or "double" (simulation.precision)

  // Phases, in step order. The first two return the largest squared displacement since the last
  // rebuild (particles and mesh vertices), for the skin criterion.
  virtual double integrateFirstHalf(double dt) = 0;
  virtual double moveMeshes(double time) = 0;
  // A mesh's motion from now on (a driven wall's, each step: WallDrives); the mesh then counts as moving.
  virtual void setMeshMotion(int mesh, const MeshMotionParams& motion) = 0;
  // A rebuild is sortByCell then buildContacts, always both: buildContacts restarts the skin reference,
  // which the sort does not carry through the reorder. Nor does it carry the forces and torques (kRecomputed: the
  // forces that follow overwrite them) unless `keepForces` (a resumed run: the next step's first half kick reads
  // the checkpoint's).
  virtual void sortByCell(bool keepForces = false) = 0;
  virtual Status buildContacts() = 0;
  // Forces of every owned particle (kAll), or, between rebuilds of a distributed run, in two passes so the
  // halo can be in flight during the first: kInterior (particles with no ghost among their candidates; only
  // queued, conditions not read) then kBoundary (the rest, once the ghosts are refreshed; reads the
  // conditions of both). Without ghosts every particle is interior.
  enum class ForceSet { kAll, kInterior, kBoundary };
  virtual Status computeForces(double dt, double time, ForceSet set) = 0;
  Status computeForces(double dt, double time) { return computeForces(dt, time, ForceSet::kAll); }
  // Owned particles with a ghost candidate (the kBoundary pass), as of the last buildContacts.
  virtual std::size_t boundaryParticles() const = 0;
  virtual Status integrateSecondHalf(double dt) = 0;
  // The last step's second half kick (deferred by Simulation, with its checks) and this step's first half in one
  // pass: the same bits as integrateSecondHalf then integrateFirstHalf, one read and write of the particles fewer.
  // The largest squared displacement in `moved2`; the status is the second half's checks'.
  virtual Status integrateBothHalves(double dt, double& moved2) = 0;

  // Explicit host copies for output and diagnostics (snapshot(): DistributedRows; the fields named, every
  // kSnapshot field when empty, unknown names ignored: only those are copied off the device).
  virtual GeometrySnapshot geometry() const = 0;
  virtual ContactStats contactStats() const = 0;
  // Device reductions over the owned particles, one pass and 8 bytes to the host each: kinetic (translational
  // plus rotational) and gravitational energy (relative to the grid's lower corner), and the kinetic alone [J].
  virtual double mechanicalEnergy() const = 0;
  virtual double kineticEnergy() const = 0;
  // Wall loads: with recording on, the force computations sum each surface's load over its wall contacts (atomics:
  // for the steps a series samples only); wallLoads() is 6 per surface number (force on the wall [N], torque on it
  // about the origin [N m]) from the last computeForces that recorded, over the owned particles.
  virtual void recordWallLoads(bool on) = 0;
  virtual std::vector<double> wallLoads() const = 0;
  // Mass of the owned particles whose centre lies past the plane (point, unit normal) [kg]: one device reduction.
  virtual double massPastPlane(const Vec3d& point, const Vec3d& normal) const = 0;
  // Elastic energy stored in the owned particles' contacts now (the Hertz potential (8/15) E* sqrt(R*)
  // delta^5/2; a pair with another owned particle counted half by each, so ranks' values add up). Host
  // copies: called once, at the start.
  virtual double elasticEnergy() const = 0;
  // The owned particle with the largest kinetic energy (host copies: error path only); gid kNoGid when none.
  virtual ParticleProbe fastestParticle() const = 0;
  virtual std::size_t deviceBytes() const = 0;
  virtual std::size_t devicePeakBytes() const = 0;  // the most deviceBytes() has been (growth transients included)

  // Every neighbour candidate pair (i, j) as global ids, sorted (diagnostics and executor comparisons).
  virtual std::vector<std::pair<Gid, Gid>> candidatePairs() const = 0;
  // ---- Distributed runs (compute/mpi): DistributedRows. The DEM rebuild there is dropGhosts, keepOwned +
  // appendOwned (migration), sortByCell, setGhosts, buildContacts; between rebuilds refreshGhosts after
  // integrateFirstHalf.
  // ---- Checkpoints (simulation.on_instability: reduce_dt). save: every kMigrate field of the owned rows,
  // packed (pack's layout at the current slot counts). restore: the engine holds exactly those rows again,
  // with those slot counts (slots that grew since shrink back); the caller then rebuilds and recomputes the
  // forces (they are not saved).
  virtual void save(std::vector<std::byte>& out) const = 0;
  virtual void restore(const std::vector<std::byte>& rows, Index count, int contactSlots, int wallSlots) = 0;
  // ---- File checkpoints (Simulation::state, resume): the owned rows' kMigrate and kCheckpoint fields (the forces
  // too: the step after a checkpoint starts from them unrecomputed) in the table's types, row-major whatever the
  // executor (FieldRows::stateArrays), and their load into an engine of either executor at those slot counts.
  virtual ParticleSnapshot stateArrays(std::int64_t step, double time) const = 0;
  virtual Status loadState(const ParticleSnapshot& s, int contactSlots, int wallSlots) = 0;

  // Waits for the device's queued work (phase timers call it so each phase is timed whole).
  virtual void fence() const = 0;
  // How the executor chose its launch configuration (CUDA: measured block size per kernel); empty on the CPU.
  virtual std::vector<std::string> launchReport() const = 0;
};

// `singlePrecision`: float physics (simulation.precision: float); positions stay double.
std::unique_ptr<Engine> makeCpuEngine(EngineSetup setup, bool singlePrecision = false);

// The CUDA engine on `device` (compute/dem/CudaEngine.cu). An error, never a fall-back, where this pflow
// was built without CUDA or the device is missing.
Result<std::unique_ptr<Engine>> makeCudaEngine(EngineSetup setup, int device, bool singlePrecision = false);

}  // namespace pflow::compute
