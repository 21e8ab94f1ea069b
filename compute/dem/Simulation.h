// A DEM run: validated configuration in, steps out. Owns the host side (time, step count, time step
// choice, timers) and drives an Engine through the phases of the step loop.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "common/Status.h"
#include "compute/core/ExecutorKind.h"
#include "compute/sim/Domain.h"
#include "compute/dem/Engine.h"
#include "compute/sim/PhaseTimers.h"
#include "compute/sim/RunConfig.h"
#include "compute/sim/SimulationState.h"
#include "compute/dem/TimeStep.h"
#include "compute/dem/WallDrive.h"

namespace pflow::compute {

struct SimulationOptions {
  ExecutorKind executor = ExecutorKind::kCpu;
  int device = 0;  // CUDA device index (of the visible ones)
  EngineSetup::Layout layout = EngineSetup::Layout::kExecutor;  // tests: another executor's data layouts
  // How the run is split across processes (compute/mpi's MpiDomain); null: one process.
  std::shared_ptr<Domain> domain;
  // Distributed runs: compute the interior particles' forces while the halo travels (false: in sequence).
  bool overlapHalo = true;
  // Candidates in global-id order (EngineSetup::canonicalOrder): one process reproducing a distributed run
  // bit for bit. Distributed runs always use it.
  bool canonicalOrder = false;
  // The CPU executor in one process evaluates each contact once (EngineSetup::pairsOnce); false: from both
  // sides, as the GPU does (tests compare the two).
  bool pairsOnce = true;
  // The CPU's pairs once evaluates the contact law by batches in SIMD lanes (EngineSetup::batchedContacts); false:
  // one contact at a time (the same bits: tests and measurements compare the two).
  bool batchedContacts = true;
  // One process: a step's second half kick waits for the next step's first, both done in one pass over the
  // particles (the same bits, one read and write of them fewer), where nothing looks at the state in between
  // (Simulation::secondHalfCanWait says when). false: every step ends with its own (tests compare the two).
  bool deferSecondHalf = true;
};

class Simulation {
 public:
  // Validates the configuration (every error at once) and sets up the engine with forces at t = 0.
  static Result<std::unique_ptr<Simulation>> create(const RunConfig& config, const SimulationOptions& options = {});

  // One velocity-Verlet step. With simulation.on_instability: reduce_dt, a detector's error instead
  // restores the last checkpoint and halves dt (the step count and time go back to the checkpoint's;
  // OK is returned), up to kMaxDtReductions times.
  Status step();
  // Steps until `time` (the last step may not overshoot by more than dt/2); after each step calls
  // `observer`, which may stop the run by returning a non-OK status.
  Status runUntil(double time, const std::function<Status(const Simulation&)>& observer = {});
  Status runSteps(std::int64_t steps);
  // The end of a run (pflow run, a job): the energy balance with the contacts' stored energy (host copies, once;
  // collective). NUMERICAL "energy growth: ..." when the run gained energy without a source.
  Status finishRun();

  // File checkpoints. justRebuilt(): the last step ended with a neighbour rebuild, where state() may be taken.
  // resume(): this run, created from the same scene, goes on from `s` as the run it came from did; call
  // scheduleOutput afterwards. Distributed runs: both are collective; state() gathers the rows to rank 0 (in id
  // order), resume() reads them from rank 0's argument and splits them over this run's ranks, whatever their number.
  bool justRebuilt() const { return m_rebuiltAt == m_step; }
  Result<SimulationState> state() const;
  Status resume(const SimulationState& s);

  // Output schedule (pflow run, pflow-worker): outputDue() is true after the step that reaches each
  // multiple of `interval` (rounded to whole steps of the dt of the moment; 0: none) and after the step
  // that reaches `end`. Checkpoints are also taken there, so a reduction never goes back past an output.
  void scheduleOutput(double interval, double end);
  bool outputDue() const { return m_outputDue; }
  // Time-step reductions so far (reduce_dt).
  int dtReductions() const { return m_reductions; }
  static constexpr int kMaxDtReductions = 6;
  // Mechanical energy checks: every this many steps (docs/physics.md, "Instability detectors").
  static constexpr int kEnergyCheckSteps = 10;
  // Allowed growth of the mechanical energy beyond what the start's elastic energy can give back, as a
  // fraction of the energy scale (initial kinetic + elastic + M |g| H).
  static constexpr double kEnergyTolerance = 0.05;

  std::int64_t stepCount() const { return m_step; }
  double time() const { return m_time; }
  double dt() const { return m_timeStep.dt; }
  const TimeStepInfo& timeStep() const { return m_timeStep; }
  const CellGrid& grid() const { return m_grid; }
  double skin() const { return m_skin; }
  std::size_t numParticles() const { return m_engine->size(); }  // on this rank
  std::int64_t rebuilds() const { return m_rebuilds; }
  // Steps whose second half kick was done with the next step's first (SimulationOptions::deferSecondHalf).
  std::int64_t fusedHalves() const { return m_fusedHalves; }

  // Host copy of the particles now: the fields named (scene output.fields), or every snapshot field. In a
  // distributed run every rank calls it and rank 0 gets all particles, ordered by id; `localOnly`: this
  // rank's own particles, no communication.
  ParticleSnapshot snapshot(const std::vector<std::string>& fields = {}, bool localOnly = false) const {
    settle();
    ParticleSnapshot s = m_engine->snapshot(m_step, m_time, fields);
    return localOnly ? s : m_domain->gather(std::move(s));
  }
  GeometrySnapshot geometry() const { return m_engine->geometry(); }
  ContactStats contactStats() const { return settle(), m_engine->contactStats(); }
  // Wall loads (Engine::recordWallLoads) summed during the forces of the steps a series samples at the end of:
  // every output step (atOutputs) and each step reaching a multiple of `interval` s (seriesSampleDue; 0: none).
  // wallLoads(): 6 per surface number from the last such step, wallLoadsStep() (-1: none yet).
  void recordWallLoads(bool atOutputs, double interval) { m_loadsAtOutputs = atOutputs, m_loadsInterval = interval; }
  std::vector<double> wallLoads() const { return m_engine->wallLoads(); }
  // Walls driven by a force or torque (motion.drive): their state after the last step.
  const WallDrives& wallDrives() const { return m_drives; }
  std::int64_t wallLoadsStep() const { return m_loadsStep; }
  const PhaseTimers& timers() const { return m_timers; }
  PhaseTimers& timers() { return m_timers; }
  std::string executorDescription() const { return m_engine->executorDescription(); }
  ExecutorKind executorKind() const { return m_executor; }
  std::size_t deviceBytes() const { return m_engine->deviceBytes(); }
  std::size_t devicePeakBytes() const { return m_engine->devicePeakBytes(); }
  Engine& engine() { return settle(), *m_engine; }
  const Engine& engine() const { return settle(), *m_engine; }
  // Distributed runs: overlap the halo with the interior forces (SimulationOptions::overlapHalo).
  void setOverlapHalo(bool on) { m_overlapHalo = on; }

 private:
  Simulation(const EngineSetup& setup, TimeStepInfo ts, std::unique_ptr<Engine> engine);
  Status stepPhases();  // the step loop itself (Simulation.cc, top of the file)
  Status initialise();
  Status rebuild(bool keepForces = false);
  Status haloAndForces(double dt, double time);
  void driveWalls(double tNext, double dt);
  Status firstHalf(double dt, double& moved);
  bool secondHalfCanWait(std::int64_t next, double tNext, bool outputStep) const;
  Status withStep(Status s) const;
  Status atStep(Status s, std::int64_t step) const;  // s named at `step` (done), not at the step in progress
  // A deferred second half kick (deferSecondHalf) done now, before the state is read: every accessor of particle
  // state calls it. Its checks' error, if any, is kept for the next step() to return (a read cannot).
  void settle() const;
  bool reportSlotGrowth();  // true when slots grew
  Status guardedStep();      // stepPhases, exceptions as errors
  Status checkEnergy();
  void takeCheckpoint();
  Status restoreCheckpoint(const Status& cause);
  double timeAt(std::int64_t step) const { return m_timeBase + double(step - m_stepBase) * m_timeStep.dt; }
  void advanceOutput();

  struct Checkpoint {
    std::vector<std::byte> rows;
    Index count = 0;
    int slots = 0, wallSlots = 0;
    std::int64_t step = 0;
    double time = 0;
    std::int64_t nextOutput = 0, endOutput = 0;
    bool valid = false;
  };

  CellGrid m_grid;  // of the engine, for reports
  double m_skin;    // neighbour skin [m]
  TimeStepInfo m_timeStep;
  std::unique_ptr<Engine> m_engine;
  std::shared_ptr<Domain> m_domain;
  PhaseTimers m_timers;
  double m_costMark = 0;  // contacts + forces seconds at the last rebuild (the domain's cost measure)
  std::int64_t m_step = 0;
  double m_time = 0;
  // t = m_timeBase + (m_step - m_stepBase) dt: exact multiples of dt until dt changes (reduce_dt).
  std::int64_t m_stepBase = 0;
  double m_timeBase = 0;
  // Energy detector (disabled while a mesh moves: its work is not accounted for).
  bool m_energyCheck = false;
  double m_energyStart = 0, m_energyAllowance = 0, m_energyScale = 0, m_elasticStart = 0;
  double m_adhesionAllowance = 0;  // the kinetic energy adhesion may release (a bound; 0 without adhesion)
  WallDrives m_drives;             // walls moved by a force or torque drive (none: empty)
  // reduce_dt
  OnInstability m_onInstability = OnInstability::kStop;
  int m_checkpointSteps = 1000;
  int m_reductions = 0;
  Checkpoint m_checkpoint;
  // output schedule (steps)
  std::int64_t m_outputSteps = 0, m_nextOutput = -1, m_endOutput = -1;
  bool m_outputDue = false;
  bool m_loadsAtOutputs = false;
  double m_loadsInterval = 0;
  std::int64_t m_loadsStep = -1;
  bool m_checkpointDue = false;
  bool m_started = false;  // initialise() done: errors before are the start's (step 0)  // after the step in progress (stepPhases decides)
  std::int64_t m_rebuilds = 0;
  std::int64_t m_rebuiltAt = 0;  // the step that ended with the last rebuild (0: the start's)
  int m_rebuildInterval = 0;  // SimulationSettings::rebuildInterval (0 = automatic)
  ExecutorKind m_executor = ExecutorKind::kCpu;
  bool m_overlapHalo = true;
  // The deferred second half (SimulationOptions::deferSecondHalf): allowed, pending (the last step's is not done
  // yet), and the last step of the runSteps/runUntil call in progress (its own is never deferred: the caller reads
  // the state after it). An error of a second half done by settle() waits in m_deferredError.
  bool m_deferSecondHalf = true;
  mutable bool m_secondHalfPending = false;
  mutable Status m_deferredError;
  std::int64_t m_lastStepOfCall = -1;
  std::int64_t m_fusedHalves = 0;
  int m_historySlots = 0, m_wallHistorySlots = 0;  // last reported
};

// Host preparation, exposed for tests and benchmarks: masses, contact table, walls, domain and grid.
Result<EngineSetup> prepareEngineSetup(const RunConfig& config);

}  // namespace pflow::compute
