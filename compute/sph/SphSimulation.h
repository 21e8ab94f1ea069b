// An SPH run: validated configuration in, steps out. Owns the host side (time, the variable time step,
// outputs, timers) and drives an SphEngine through the phases of the symplectic step (SphSimulation.cc).
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/core/ExecutorKind.h"
#include "compute/sim/Domain.h"
#include "compute/sim/PhaseTimers.h"
#include "compute/sim/RunConfig.h"
#include "compute/sim/SimulationState.h"
#include "compute/sph/SphConfig.h"
#include "compute/sph/SphEngine.h"

namespace pflow::compute::sph {

struct SphOptions {
  ExecutorKind executor = ExecutorKind::kCpu;
  int device = 0;
  // How the run is split across processes (compute/mpi's MpiDomain, the same as DEM's); null: one process.
  std::shared_ptr<Domain> domain;
  // Distributed runs: compute the interior particles' rates while the halo travels (seed 003); false: in sequence.
  bool overlapHalo = true;
  // Neighbours summed in global-id order (SphSetup::canonicalOrder): one process reproducing a distributed run
  // bit for bit. Distributed runs always use it.
  bool canonicalOrder = false;
};

class SphSimulation {
 public:
  // Validates the configuration (every error at once), sets up the engine, sorts and computes the rates at t = 0.
  static Result<std::unique_ptr<SphSimulation>> create(const RunConfig& config, const SphOptions& options = {});

  // One symplectic step of the CFL step (or sph.dt), shortened to land on the next output time.
  Status step();
  // Steps until `time`; after each step calls `observer`, which may stop the run by returning an error.
  Status runUntil(double time, const std::function<Status(const SphSimulation&)>& observer = {});
  Status runSteps(std::int64_t steps);

  // Checkpoints (docs/operations.md), as DEM's Simulation: justRebuilt() after a step that ended with a cell
  // sort, where state() may be taken; resume() goes on from it in a run created from the same scene (then
  // scheduleOutput). Distributed runs: both are collective; state() gathers the rows to rank 0 (in id order),
  // resume() reads them from rank 0's argument and splits them over this run's ranks, whatever their number.
  bool justRebuilt() const { return m_rebuiltAt == m_step; }
  Result<SimulationState> state() const;
  Status resume(const SimulationState& s);

  // Outputs every `interval` seconds (0: none) and at `end`: steps are shortened to land on those times
  // exactly, and outputDue() is true after each.
  void scheduleOutput(double interval, double end);
  bool outputDue() const { return m_outputDue; }

  std::int64_t stepCount() const { return m_step; }
  double time() const { return m_time; }
  double dt() const { return m_dt; }          // the last step's
  double stableDt() const { return m_stable; } // the CFL limit at the current state
  std::size_t numParticles() const { return m_engine->size(); }  // on this rank
  std::size_t totalParticles() const { return m_total; }        // on every rank
  std::size_t fluidParticles() const { return m_fluid; }        // on every rank
  std::int64_t rebuilds() const { return m_rebuilds; }
  const SphDerived& derived() const { return m_derived; }
  const CellGrid& grid() const { return m_grid; }
  // Collective in a distributed run (every rank calls them and gets the same value).
  double fluidReach(Vec3d direction) const { return m_domain->max(m_engine->fluidReach(direction)); }
  // The scene's probes now, in their order: a pressure probe's Shepard-interpolated pressure [Pa] (0 where no
  // fluid reaches it), a gauge's free-surface height above the tank's floor [m] (going up the vertical through it,
  // where the fluid's kernel share first falls to 1/2; 0 when dry). docs/sph.md, "Probes and gauges".
  std::vector<double> probeValues() const;
  const std::vector<SphProbe>& probes() const { return m_method.probes; }
  // Host copy of the particles now; in a distributed run every rank calls it and rank 0 gets all of them in id
  // order (`localOnly`: this rank's own, no communication).
  ParticleSnapshot snapshot(const std::vector<std::string>& fields = {}, bool localOnly = false) const {
    ParticleSnapshot s = m_engine->snapshot(m_step, m_time, fields);
    return localOnly ? s : m_domain->gather(std::move(s));
  }
  const PhaseTimers& timers() const { return m_timers; }
  PhaseTimers& timers() { return m_timers; }
  std::string executorDescription() const { return m_engine->executorDescription(); }
  const char* precisionName() const { return m_engine->precisionName(); }
  std::size_t deviceBytes() const { return m_engine->deviceBytes(); }
  SphEngine& engine() { return *m_engine; }

 private:
  SphSimulation() = default;
  Status stepPhases();  // the step loop itself (SphSimulation.cc, top of the file)
  Status rates(double moved2);  // rebuild or refresh the ghosts, then the rates
  Status rebuild();
  double nextDt();
  Status withStep(Status s) const;

  std::unique_ptr<SphEngine> m_engine;
  std::shared_ptr<Domain> m_domain;
  bool m_overlapHalo = true;
  std::size_t m_total = 0;
  double m_costMark = 0;  // rate seconds at the last rebuild (the domain's cost measure)
  SphDerived m_derived;
  SphConfig m_method;  // the configuration, without its particles
  double m_dtBefore = 0;  // Verlet: the last step taken
  CellGrid m_grid;
  double m_skin = 0;
  // Where probeValues() reads: each probe's point, each gauge's column (floor to top in steps of dp/2), placed once;
  // probe k's points are [m_probeFirst[k], m_probeFirst[k + 1]).
  std::vector<Vec3d> m_probePoints;
  std::vector<std::size_t> m_probeFirst;
  mutable std::vector<double> m_probeFraction, m_probePressure;  // probeValues()'s kernel sums, kept between calls
  void placeProbes();
  PhaseTimers m_timers;
  std::int64_t m_step = 0, m_rebuilds = 0;
  std::int64_t m_rebuiltAt = 0;  // the step whose end had the last cell sort (0: the start's)
  double m_time = 0, m_dt = 0, m_stable = 0;
  std::size_t m_fluid = 0;
  double m_outputInterval = 0, m_nextOutput = -1, m_end = -1;
  bool m_outputDue = false;
  bool m_warnedFixedDt = false;
};

// Host preparation, exposed for tests and benchmarks: masses, the hydrostatic initial density, the grid.
Result<SphSetup> prepareSphSetup(const RunConfig& config);

}  // namespace pflow::compute::sph
