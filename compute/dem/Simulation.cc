#include "compute/dem/Simulation.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "common/Log.h"
#include "compute/core/Memory.h"
#include "compute/dem/ModelChoice.h"
#include "compute/dem/contact/ForceKernel.h"

namespace pflow::compute {

namespace {
Status fromException();  // the exception in flight as a Status (below)
}  // namespace

#define PFLOW_RETURN_IF_ERROR(expr)         \
  do {                                      \
    ::pflow::Status _st = (expr);           \
    if (!_st.isOk()) return withStep(_st);  \
  } while (0)
// Inside a step's parts (PFLOW_TRY, common/Status.h): the step is named once, where the step's status is agreed.

// ---------------------------------------------------------------------------------------------
// The step loop. One velocity-Verlet step, top to bottom, a timer per phase.
Status Simulation::stepPhases() {
  const double dt = m_timeStep.dt, tNext = timeAt(m_step + 1);
  double moved, meshMoved;
  if (Status st = firstHalf(dt, moved); !st.isOk()) return st;  // with the last step's second half if it waited
  { auto t = m_timers.time(Phase::kMeshes);     m_drives.beginStep(m_time, dt, *m_engine);  // driven walls' half kick
                                                 meshMoved = std::sqrt(m_engine->moveMeshes(tNext)); }
  Status s;
  const bool due = m_rebuildInterval > 0 ? (m_step + 1) % m_rebuildInterval == 0  // fixed interval: may miss contacts
                                         : 2 * moved > m_skin || moved + meshMoved > m_skin;
  const bool rebuildNow = m_domain->anyRebuild(due);
  const bool loads = (m_loadsAtOutputs && ((m_nextOutput >= 0 && m_step + 1 >= m_nextOutput) || m_step + 1 == m_endOutput)) ||
                     seriesSampleDue(m_time, tNext, m_loadsInterval) ||  // the steps advanceOutput will call due
                     !m_drives.empty();                                   // driven walls move by their loads
  m_engine->recordWallLoads(loads);
  if (rebuildNow) s = rebuild(), m_rebuiltAt = m_step + 1;
  if (!rebuildNow && m_domain->ranks() > 1) s = haloAndForces(dt, tNext);  // ghosts refreshed (ranks)
  else if (s.isOk()) { auto t = m_timers.time(Phase::kForces);     s = m_engine->computeForces(dt, tNext); }
  const std::int64_t next = m_step + 1;
  const bool outputStep = (m_nextOutput >= 0 && next >= m_nextOutput) || next == m_endOutput;
  if (s.isOk() && secondHalfCanWait(next, tNext, outputStep)) m_secondHalfPending = true;  // done with the next first
  else if (s.isOk()) { auto t = m_timers.time(Phase::kIntegrate2); s = m_engine->integrateSecondHalf(dt); }
  if (s.isOk() && !m_drives.empty()) { auto t = m_timers.time(Phase::kMeshes); driveWalls(tNext, dt); }
  PFLOW_RETURN_IF_ERROR(m_domain->agree(s));  // every rank stops on any rank's error
  // reduce_dt checkpoints: every checkpointSteps, at outputs (a reduction never goes back past one) and
  // when slots grew (a checkpoint holds rows of one slot count); the energy is checked there too, so a
  // checkpoint never holds a state the detector would reject.
  const bool slotsGrew = reportSlotGrowth();  // logged in every mode
  m_checkpointDue = m_onInstability == OnInstability::kReduceDt &&
                    (slotsGrew || outputStep || next - m_checkpoint.step >= m_checkpointSteps);
  // The energy detector: every kEnergyCheckSteps, at checkpoints, and at every output and the run's end, so that no
  // state it would reject is written or ends a run (one reduction: 8 bytes to the host).
  if (m_energyCheck && (next % kEnergyCheckSteps == 0 || m_checkpointDue || outputStep)) {
    auto t = m_timers.time(Phase::kIntegrate2);  // the integration's own check, like the non-finite one
    PFLOW_RETURN_IF_ERROR(checkEnergy());
  }
  ++m_step;
  m_time = tNext;
  if (loads) m_loadsStep = m_step;
  return Status::ok();
}

// The first half kick and drift, with the last step's second half when it waited (secondHalfCanWait): one pass for
// both, its checks' error named at that step.
Status Simulation::firstHalf(double dt, double& moved) {
  auto t = m_timers.time(Phase::kIntegrate1);
  if (!m_secondHalfPending) return moved = std::sqrt(m_engine->integrateFirstHalf(dt)), Status::ok();
  m_secondHalfPending = false;
  ++m_fusedHalves;
  const Status s = m_engine->integrateBothHalves(dt, moved);
  moved = std::sqrt(moved);
  return s.isOk() ? s : atStep(s, m_step);
}

// A step's second half kick may wait for the next step's first half unless something reads the state between the
// two: the last step of the runSteps/runUntil call, outputs and series samples, the energy detector's steps,
// reduce_dt's checkpoints (those runs never defer); one process only (a distributed step agrees on its errors once,
// after its second half). Anything else that reads the state in between (an observer's checkpoint, a test) goes
// through settle().
bool Simulation::secondHalfCanWait(std::int64_t next, double tNext, bool outputStep) const {
  return m_deferSecondHalf && next < m_lastStepOfCall && m_domain->ranks() == 1 &&
         m_onInstability != OnInstability::kReduceDt && !outputStep && !seriesSampleDue(m_time, tNext, m_loadsInterval) &&
         !(m_energyCheck && next % kEnergyCheckSteps == 0);
}

// Driven walls (WallDrive.h): their contact loads of this step, summed over ranks (every rank moves them alike),
// their drives and second half kick.
void Simulation::driveWalls(double tNext, double dt) {
  std::vector<double> loads = m_engine->wallLoads();
  m_domain->sum(loads);
  m_drives.endStep(loads, tNext, dt);
}

// Neighbour rebuild: particles to the ranks that own them, sort by cell (reordering every field), the
// ghosts, then candidate lists. One process: the sort and the lists. The sort drops the forces (the step's own
// follow) unless keepForces.
Status Simulation::rebuild(bool keepForces) {
  const double cost = m_timers.seconds(Phase::kContacts) + m_timers.seconds(Phase::kForces);
  { auto t = m_timers.time(Phase::kMigrate);  PFLOW_TRY(m_domain->migrate(*m_engine, cost - m_costMark)); }
  { auto t = m_timers.time(Phase::kSort);     m_engine->sortByCell(keepForces); }
  { auto t = m_timers.time(Phase::kHalo);     PFLOW_TRY(m_domain->exchangeGhosts(*m_engine)); }
  { auto t = m_timers.time(Phase::kContacts); PFLOW_TRY(m_engine->buildContacts()); }
  m_costMark = m_timers.seconds(Phase::kContacts) + m_timers.seconds(Phase::kForces);
  ++m_rebuilds;
  return Status::ok();
}

// Between rebuilds of a distributed run: the ghosts' refresh travels while the forces of the interior
// particles (no ghost among their candidates) are computed, queued on the GPU or computed here on the CPU;
// the boundary particles' forces follow once the ghosts are written. "halo" counts only what the forces
// did not hide. SimulationOptions::overlapHalo = false runs it in sequence (the measure of the gain).
Status Simulation::haloAndForces(double dt, double time) {
  using Set = Engine::ForceSet;
  if (!m_overlapHalo) {
    { auto t = m_timers.time(Phase::kHalo);
      PFLOW_TRY(m_domain->startRefresh(*m_engine));
      PFLOW_TRY(m_domain->awaitRefresh());
      PFLOW_TRY(m_domain->finishRefresh(*m_engine)); }
    auto t = m_timers.time(Phase::kForces);
    return m_engine->computeForces(dt, time);
  }
  { auto t = m_timers.time(Phase::kHalo);           PFLOW_TRY(m_domain->startRefresh(*m_engine)); }
  { auto t = m_timers.timeUnfenced(Phase::kForces); PFLOW_TRY(m_engine->computeForces(dt, time, Set::kInterior)); }
  { auto t = m_timers.timeUnfenced(Phase::kHalo);   PFLOW_TRY(m_domain->awaitRefresh()); }
  { auto t = m_timers.time(Phase::kForces); }  // the interior pass completes
  { auto t = m_timers.time(Phase::kHalo);           PFLOW_TRY(m_domain->finishRefresh(*m_engine)); }
  auto t = m_timers.time(Phase::kForces);
  return m_engine->computeForces(dt, time, Set::kBoundary);
}
// ---------------------------------------------------------------------------------------------

// A step, with an exception from the engine reported as an error of that step instead of escaping:
// an allocation that does not fit (history slots or candidate rows grown beyond the device's memory) as
// RESOURCE_EXHAUSTED, anything else (a CUDA fault) as INTERNAL.
Status Simulation::guardedStep() {
  try {
    return stepPhases();
  } catch (...) {
    return withStep(fromException());
  }
}

// A step; with reduce_dt, checkpoints and the recovery from a detector's error.
Status Simulation::step() {
  if (!m_deferredError.isOk()) return std::exchange(m_deferredError, Status::ok());  // from settle()
  const bool reduce = m_onInstability == OnInstability::kReduceDt;
  try {
    if (reduce && !m_checkpoint.valid) takeCheckpoint();
  } catch (...) {
    return withStep(fromException());
  }
  Status s = guardedStep();
  if (!s.isOk()) {
    if (!reduce || s.code() != StatusCode::kNumerical) return s;
    return restoreCheckpoint(s);
  }
  advanceOutput();
  if (m_checkpointDue) {
    try {
      takeCheckpoint();
    } catch (...) {
      return withStep(fromException());
    }
  }
  return s;
}

// Mechanical energy (kinetic + gravitational) against its start: with fixed walls and dissipative contacts
// it can exceed the start only by the elastic energy stored in the start's contacts. Growth beyond that
// plus the tolerance is energy the integration made up: the step is too large (docs/physics.md).
Status Simulation::checkEnergy() {
  const double total = m_domain->sum(m_engine->mechanicalEnergy());  // the same decision on every rank
  const double excess = total - m_energyStart;
  if (excess <= m_energyAllowance) return Status::ok();
  const ParticleProbe p = m_engine->fastestParticle();
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "energy growth: the mechanical energy (kinetic + gravitational, %.4g J) is %.4g J above its start, beyond "
                "the %.4g J allowed (the elastic energy stored at the start plus %.0f%% of the energy scale %.4g J) with "
                "no energy input; the fastest is ",
                total, excess, m_energyAllowance, 100 * kEnergyTolerance, m_energyScale);
  return numericalError(buf + describeParticle(p) + ": the integration gains energy (time step too large for these contacts)" +
                        dtSuggestion(m_timeStep.dt, p));
}

void Simulation::takeCheckpoint() {
  Checkpoint& c = m_checkpoint;
  m_engine->save(c.rows);
  c.count = Index(m_engine->size());
  c.slots = m_engine->historySlots();
  c.wallSlots = m_engine->wallHistorySlots();
  c.step = m_step;
  c.time = m_time;
  c.nextOutput = m_nextOutput;
  c.endOutput = m_endOutput;
  c.valid = true;
}

// reduce_dt: back to the checkpoint with half the step; the step count and the time go back to the
// checkpoint's, and the steps left to each scheduled output double.
Status Simulation::restoreCheckpoint(const Status& cause) {
  if (m_reductions >= kMaxDtReductions)
    return Status(cause.code(), cause.message() + "; gave up after " + std::to_string(m_reductions) +
                                    " time-step reductions (simulation.on_instability: reduce_dt)");
  const Checkpoint& c = m_checkpoint;
  m_secondHalfPending = false;  // (never set in reduce_dt runs) the checkpoint's state is a whole step's
  const double oldDt = m_timeStep.dt;
  m_timeStep.dt = 0.5 * oldDt;
  ++m_reductions;
  m_step = m_stepBase = c.step;
  m_time = m_timeBase = c.time;
  if (m_outputSteps > 0) m_outputSteps *= 2;
  m_nextOutput = c.nextOutput >= 0 ? c.step + 2 * (c.nextOutput - c.step) : -1;
  m_endOutput = c.endOutput >= 0 ? c.step + 2 * (c.endOutput - c.step) : -1;
  m_outputDue = false;
  spdlog::warn("{}; going back to step {} (t = {:.6g} s) and halving the time step to {:.4g} s (reduction {} of {})",
               cause.message(), c.step, c.time, m_timeStep.dt, m_reductions, kMaxDtReductions);
  try {
    m_engine->restore(c.rows, c.count, c.slots, c.wallSlots);
    m_engine->moveMeshes(c.time);
    Status s = rebuild();
    if (s.isOk()) s = m_engine->computeForces(0.0, c.time);
    if (!s.isOk()) return withStep(s);
  } catch (...) {
    return withStep(fromException());
  }
  m_historySlots = m_engine->historySlots();
  m_wallHistorySlots = m_engine->wallHistorySlots();
  return Status::ok();
}

void Simulation::scheduleOutput(double interval, double end) {
  const double dt = m_timeStep.dt;
  m_endOutput = m_stepBase + std::llround((end - m_timeBase) / dt);
  m_outputSteps = interval > 0 ? std::max<std::int64_t>(1, std::llround(interval / dt)) : 0;
  // At whole multiples of the interval from the time base: a resumed run's outputs fall on the steps of the run it
  // resumes.
  m_nextOutput = interval > 0 ? m_stepBase + ((m_step - m_stepBase) / m_outputSteps + 1) * m_outputSteps : -1;
  m_outputDue = false;
  if (m_checkpoint.valid && m_checkpoint.step == m_step) {
    m_checkpoint.nextOutput = m_nextOutput;
    m_checkpoint.endOutput = m_endOutput;
  }
}

void Simulation::advanceOutput() {
  m_outputDue = false;
  if (m_nextOutput >= 0 && m_step >= m_nextOutput) {
    m_outputDue = true;
    while (m_nextOutput <= m_step) m_nextOutput += m_outputSteps;
  }
  if (m_step == m_endOutput) m_outputDue = true;
}

namespace {
Status fromException() {
  try {
    throw;
  } catch (const OutOfDeviceMemory& e) {
    return Status(StatusCode::kResourceExhausted, e.what());
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kResourceExhausted, "host memory exhausted");
  } catch (const std::exception& e) {
    return Status(StatusCode::kInternal, e.what());
  }
}
}  // namespace

// History slots grow on demand (never silently): say so once per growth.
bool Simulation::reportSlotGrowth() {
  const int slots = m_engine->historySlots(), wallSlots = m_engine->wallHistorySlots();
  if (slots != m_historySlots)
    spdlog::info("step {}: a particle has more contacts than tangential-history slots; grew from {} to {} per particle",
                 m_step + 1, m_historySlots, slots);
  if (wallSlots != m_wallHistorySlots)
    spdlog::info("step {}: a particle has more wall contacts than wall-history slots; grew from {} to {} per particle",
                 m_step + 1, m_wallHistorySlots, wallSlots);
  const bool grew = slots != m_historySlots || wallSlots != m_wallHistorySlots;
  m_historySlots = slots;
  m_wallHistorySlots = wallSlots;
  return grew;
}

Status Simulation::atStep(Status s, std::int64_t step) const {
  return Status(s.code(), s.message() + " at step " + std::to_string(step) + " (t = " + std::to_string(timeAt(step)) + " s)");
}

Status Simulation::withStep(Status s) const {
  if (s.isOk()) return s;
  if (!m_started) return Status(s.code(), s.message() + " at step 0 (t = " + std::to_string(m_time) + " s, the start)");
  return atStep(s, m_step + 1);
}

Status Simulation::initialise() {
  m_historySlots = m_engine->historySlots();
  m_wallHistorySlots = m_engine->wallHistorySlots();
  Status s = rebuild();
  m_engine->recordWallLoads(!m_drives.empty());  // a driven wall's first acceleration comes from them
  if (s.isOk()) s = m_engine->computeForces(0.0, 0.0);
  if (s.isOk() && !m_drives.empty()) {
    std::vector<double> loads = m_engine->wallLoads();
    m_domain->sum(loads);
    m_drives.start(loads, m_time, m_timeStep.dt);
  }
  PFLOW_RETURN_IF_ERROR(m_domain->agree(s));
  reportSlotGrowth();
  m_started = true;
  if (m_energyCheck) {
    // The reference of the energy detector: the mechanical energy now, the elastic energy stored in the
    // start's contacts (which may turn into kinetic energy) and the energy scale of the tolerance.
    m_energyStart = m_domain->sum(m_engine->mechanicalEnergy());
    const double kinetic = m_domain->sum(m_engine->kineticEnergy()), elastic = m_domain->sum(m_engine->elasticEnergy());
    m_energyScale = kinetic + elastic + m_energyScale;  // m_energyScale held M |g| H (create)
    m_energyAllowance = elastic + kEnergyTolerance * m_energyScale + m_adhesionAllowance;
    m_elasticStart = elastic;
  }
  return Status::ok();
}

Result<SimulationState> Simulation::state() const {
  settle();
  if (!m_deferredError.isOk()) return m_deferredError;
  if (!justRebuilt())
    return Status(StatusCode::kFailedPrecondition, "a checkpoint is taken just after a neighbour rebuild (step " +
                                                       std::to_string(m_rebuiltAt) + " was the last; this is " + std::to_string(m_step) + ")");
  SimulationState s;
  // Distributed: every rank's rows gathered to rank 0 in id order (the other ranks' state has no particles), with
  // the same history slots on every rank (the rebuild's force pass may have grown one rank's).
  if (m_domain->ranks() > 1)
    m_engine->ensureSlots(int(m_domain->max(double(m_engine->historySlots()))), int(m_domain->max(double(m_engine->wallHistorySlots()))));
  s.particles = m_domain->gather(m_engine->stateArrays(m_step, m_time));
  // The arrays' own slot count: a history pool's entries are merged into the inline slots (EnginePool.h), which
  // may take more slots than the engine carries inline.
  const SnapshotArray* partners = s.particles.find("history_partner");
  s.contactSlots = partners ? partners->components : m_engine->historySlots();
  s.wallSlots = m_engine->wallHistorySlots();
  s.step = m_step;
  s.stepBase = m_stepBase;
  s.rebuilds = m_rebuilds;
  s.time = m_time;
  s.timeBase = m_timeBase;
  s.dt = m_timeStep.dt;
  s.reductions = m_reductions;
  s.wallDrive = m_drives.state();
  return s;
}

// The rows as they were after the run's rebuild at s.step: sorting them again keeps their order (the same cells,
// a stable sort) and the lists come out the same; the forces are the run's (not recomputed), so the next step is
// the run's own.
Status Simulation::resume(const SimulationState& state) {
  SimulationState s;  // distributed: rank 0's scalars on every rank (its particles below)
  s.setScalars(state.scalars());
  m_secondHalfPending = false;  // the loaded state is a whole step's
  m_deferredError = Status::ok();
  try {
    if (m_domain->ranks() > 1) {
      // Rank 0's state on every rank, split as a new run's scene is, each rank keeping its share.
      auto share = shareForResume(*m_domain, m_grid, state, s);
      PFLOW_RETURN_IF_ERROR(share.status());
      PFLOW_RETURN_IF_ERROR(m_domain->agree(m_engine->loadState(share.value().rows, s.contactSlots, s.wallSlots)));
    } else {
      PFLOW_RETURN_IF_ERROR(m_engine->loadState(state.particles, s.contactSlots, s.wallSlots));
    }
    m_step = s.step;
    m_stepBase = s.stepBase;
    m_time = s.time;
    m_timeBase = s.timeBase;
    m_timeStep.dt = s.dt;
    m_reductions = s.reductions;
    PFLOW_RETURN_IF_ERROR(m_drives.restore(s.wallDrive, s.time, *m_engine));
    m_engine->moveMeshes(s.time);
    PFLOW_RETURN_IF_ERROR(rebuild(/*keepForces=*/true));
  } catch (...) {
    return withStep(fromException());
  }
  m_rebuilds = s.rebuilds;
  m_rebuiltAt = m_step;
  m_historySlots = m_engine->historySlots();
  m_wallHistorySlots = m_engine->wallHistorySlots();
  m_outputDue = false;
  if (m_onInstability == OnInstability::kReduceDt) takeCheckpoint();
  return Status::ok();
}

Status Simulation::runSteps(std::int64_t steps) {
  m_lastStepOfCall = m_step + steps;
  for (std::int64_t k = 0; k < steps; ++k)
    if (Status s = step(); !s.isOk()) return s;
  return Status::ok();
}

void Simulation::settle() const {
  if (!m_secondHalfPending) return;
  m_secondHalfPending = false;
  Status s = m_engine->integrateSecondHalf(m_timeStep.dt);
  if (!s.isOk() && m_deferredError.isOk()) m_deferredError = atStep(s, m_step);
}

// The end of a run: the whole energy balance, mechanical plus the elastic energy stored in the contacts, against the
// start's. The detector during the run compares the mechanical energy alone with the start's mechanical plus
// elastic energy (the elastic energy is host copies), so a gain that still sits in the contacts escapes it: 5 steps
// at 1.5 Rayleigh times of a compressed block took the total from 14.2 J to 18.0 J with the mechanical part below
// its bound. Collective; host copies once.
Status Simulation::finishRun() {
  settle();
  if (!m_deferredError.isOk()) return std::exchange(m_deferredError, Status::ok());
  if (!m_energyCheck || m_step == 0) return Status::ok();
  const double mechanical = m_domain->sum(m_engine->mechanicalEnergy()), elastic = m_domain->sum(m_engine->elasticEnergy());
  const double excess = (mechanical + elastic) - (m_energyStart + m_elasticStart);
  if (excess <= kEnergyTolerance * m_energyScale + m_adhesionAllowance) return Status::ok();
  const ParticleProbe p = m_engine->fastestParticle();
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "energy growth: at the run's end the energy (mechanical %.4g J plus %.4g J stored in contacts) is %.4g J above "
                "its start, beyond the %.0f%% of the energy scale %.4g J allowed, with no energy input; the fastest is ",
                mechanical, elastic, excess, 100 * kEnergyTolerance, m_energyScale);
  return Status(StatusCode::kNumerical, buf + describeParticle(p) + ": the integration gains energy (time step too large for these contacts)" +
                                            dtSuggestion(m_timeStep.dt, p) + " at step " + std::to_string(m_step));
}

Status Simulation::runUntil(double time, const std::function<Status(const Simulation&)>& observer) {
  // The last step recomputed each time: a reduce_dt recovery changes dt and the steps left.
  while (m_step < m_stepBase + std::llround((time - m_timeBase) / m_timeStep.dt)) {
    m_lastStepOfCall = m_stepBase + std::llround((time - m_timeBase) / m_timeStep.dt);
    if (Status s = step(); !s.isOk()) return s;
    if (observer)
      if (Status s = observer(*this); !s.isOk()) return s;
  }
  return Status::ok();
}

Simulation::Simulation(const EngineSetup& setup, TimeStepInfo ts, std::unique_ptr<Engine> engine)
    : m_grid(setup.grid),
      m_skin(setup.skin),
      m_timeStep(std::move(ts)),
      m_engine(std::move(engine)) {}

Result<std::unique_ptr<Simulation>> Simulation::create(const RunConfig& config, const SimulationOptions& options) {
  if (ErrorList errors = config.validate(); !errors.empty()) return errors.toStatus("invalid run configuration");
  auto ts = chooseTimeStep(config);
  if (!ts) return ts.status();
  auto setup = prepareEngineSetup(config);
  if (!setup) return setup.status();
  setup.value().layout = options.layout;
  setup.value().canonicalOrder = options.canonicalOrder;
  setup.value().pairsOnce = options.pairsOnce;
  setup.value().batchedContacts = options.batchedContacts;
  setup.value().dt = ts.value().dt;
  std::shared_ptr<Domain> domain = options.domain ? options.domain : std::make_shared<Domain>();
  double totalMass = 0;  // the whole scene's (every rank prepares it), before the partition keeps a share
  for (double m : setup.value().mass) totalMass += m;
  // Adhesion releases kinetic energy as contacts form: at most one well depth a contact (adhesionWellDepth at
  // R* = r_i, which bounds both a pair's R* and a wall's), for max_contacts pair contacts (each counted by both
  // partners: half each) and kMaxWallContacts wall contacts per particle.
  double adhesion = 0;
  if (setup.value().model.cohesion) {
    const EngineSetup& su = setup.value();
    for (std::size_t i = 0; i < su.radius.size(); ++i) {
      double depth = 0;
      for (int m = 0; m < su.numMaterials; ++m)
        depth = std::max(depth, adhesionWellDepth(su.contactTable[std::size_t(su.material[i]) * su.numMaterials + m], su.radius[i]));
      adhesion += (0.5 * su.maxContacts + kMaxWallContacts) * depth;
    }
  }
  if (Status s = domain->partition(setup.value()); !s.isOk()) return s;
  auto drives = WallDrives::create(config, setup.value());
  if (!drives) return drives.status();
  std::unique_ptr<Simulation> sim(new Simulation(setup.value(), ts.value(), nullptr));
  sim->m_drives = std::move(drives).value();
  sim->m_domain = std::move(domain);
  sim->m_overlapHalo = options.overlapHalo;
  sim->m_deferSecondHalf = options.deferSecondHalf;
  sim->m_onInstability = config.sim.onInstability;
  sim->m_checkpointSteps = config.sim.checkpointSteps;
  if (sim->m_onInstability == OnInstability::kReduceDt && sim->m_domain->ranks() > 1)
    return invalidArgument("simulation.on_instability: reduce_dt runs in one process only (this run has " +
                           std::to_string(sim->m_domain->ranks()) + " ranks); use stop, or run on one rank");
  // Energy detector: off while a mesh moves (the work it does on the particles is not accounted for).
  sim->m_energyCheck = std::none_of(config.meshes.begin(), config.meshes.end(), [](const MeshConfig& m) { return m.motion.moves(); });
  if (!sim->m_energyCheck) spdlog::info("energy-growth detector off: a mesh moves (its work on the particles is not accounted for)");
  {
    // M |g| H: the gravitational energy the particles can exchange across the grid's height along g.
    const double g = norm(config.sim.gravity);
    const Vec3d ext = sim->m_grid.cellSize * Vec3d{double(sim->m_grid.nx), double(sim->m_grid.ny), double(sim->m_grid.nz)};
    const double height = g > 0 ? (std::fabs(config.sim.gravity.x) * ext.x + std::fabs(config.sim.gravity.y) * ext.y +
                                   std::fabs(config.sim.gravity.z) * ext.z) / g : 0.0;
    sim->m_energyScale = totalMass * g * height;
  }
  sim->m_adhesionAllowance = adhesion;
  sim->m_rebuildInterval = config.sim.rebuildInterval;
  ExecutorKind kind = options.executor;
  if (kind == ExecutorKind::kAuto) kind = cudaDeviceCount() > 0 ? ExecutorKind::kCuda : ExecutorKind::kCpu;
  // The least model (prepareEngineSetup applied its flags); the precision may follow the accuracy target.
  ModelOptions modelOptions;
  modelOptions.executor = kind == ExecutorKind::kCuda ? "cuda" : "cpu";
  const ModelChoice model = deriveModel(config, modelOptions);
  spdlog::debug("model:\n{}", model.text());
  const bool single = model.precision == Precision::kFloat;
  Status made;
  if (kind == ExecutorKind::kCuda) {
    auto engine = makeCudaEngine(std::move(setup).value(), options.device, single);
    if (engine) {
      sim->m_engine = std::move(engine).value();
      // Kernels run asynchronously: each phase timer waits for its own work.
      sim->m_timers.setFence([e = sim->m_engine.get()] { e->fence(); });
    } else {
      made = engine.status();
    }
  } else {
    try {
      sim->m_engine = makeCpuEngine(std::move(setup).value(), single);
    } catch (...) {
      made = fromException();
    }
  }
  // A device that fails on one rank fails the run on all (the others would wait in the first exchange).
  if (Status s = sim->m_domain->agree(made); !s.isOk()) return s;
  sim->m_executor = kind;
  try {
    if (Status s = sim->initialise(); !s.isOk()) return s;
  } catch (...) {
    return fromException();
  }
  return sim;
}

Result<ExecutorKind> parseExecutorKind(const std::string& name, const std::string& flag) {
  if (name == "cpu") return ExecutorKind::kCpu;
  if (name == "cuda") return ExecutorKind::kCuda;
  if (name == "auto") return ExecutorKind::kAuto;
  return invalidArgument(flag + ": '" + name + "' is not one of auto, cpu, cuda");
}

Result<EngineSetup> prepareEngineSetup(const RunConfig& c) {
  EngineSetup s;
  const auto& p = c.particles;
  const std::size_t n = p.size();
  s.position = p.position;
  // Empty = at rest (assigned, not built in a ternary: GCC 12 then warns falsely about the temporary).
  s.velocity = p.velocity;
  if (s.velocity.empty()) s.velocity.assign(n, Vec3d{0, 0, 0});
  s.angularVelocity = p.angularVelocity;
  if (s.angularVelocity.empty()) s.angularVelocity.assign(n, Vec3d{0, 0, 0});
  s.radius = p.radius;
  s.material = p.material;
  s.mass.resize(n);
  double maxR = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = p.radius[i];
    s.mass[i] = c.materials[std::size_t(p.material[i])].density * 4.0 / 3.0 * std::numbers::pi * r * r * r;
    maxR = std::max(maxR, r);
  }
  s.maxRadius = maxR;
  s.numMaterials = int(c.materials.size());
  s.contactTable = buildContactTable(c.materials, c.pairs);
  for (std::size_t m = 0; m < c.materials.size() && m < 64; ++m)
    if (c.materials[m].fixed) s.fixedMaterials |= std::uint64_t(1) << m;
  s.gravity = c.sim.gravity;
  s.historySlots = c.sim.historySlots;
  s.wallHistorySlots = c.sim.wallHistorySlots;
  // The least model the scene needs (simulation.model: auto): without friction, no history slots at all.
  s.model = deriveModel(c).flags;
  if (!s.model.tangential) s.historySlots = s.wallHistorySlots = 0;
  s.threads = c.sim.threads;
  s.maxOverlap = c.sim.maxOverlap;
  s.maxContacts = c.sim.maxContacts;
  s.reproducible = c.sim.reproducible;
  if (c.sim.domain) {  // only a domain the scene states is a boundary (a derived one is just the grid's extent)
    s.checkDomain = true;
    s.domainLo = c.sim.domain->lo;
    s.domainHi = c.sim.domain->hi;
  }

  if (n >= kMaxParticles)
    return invalidArgument("particles: " + std::to_string(n) + " particles, at most " + std::to_string(kMaxParticles - 1) +
                           " in one run (history slots key partners by 32-bit id)");
  if (c.planes.size() > std::size_t(kMaxPlanes))
    return invalidArgument("geometry: " + std::to_string(c.planes.size()) + " planes, at most " +
                           std::to_string(kMaxPlanes) + " infinite planes are supported; use a box or mesh for more walls");
  for (const auto& pl : c.planes) {
    s.planes.push_back({pl.point, (1.0 / norm(pl.normal)) * pl.normal, pl.material});
    s.planeNames.push_back(pl.name);
    s.planeSurface.push_back(pl.surface);
  }
  for (std::size_t m = 0; m < c.meshes.size(); ++m) {
    const auto& mc = c.meshes[m];
    for (std::size_t t = 0; t < mc.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) s.triVerts.push_back(mc.vertices[mc.triangles[t][k]]);
      s.triMesh.push_back(std::int32_t(m));
      s.triMaterial.push_back(mc.material);
      s.triSurface.push_back(mc.surface.empty() ? 0 : mc.surface[t]);
    }
    const auto& mo = mc.motion;
    const double axisLen = norm(mo.axis);
    MeshMotionParams mp{mo.velocity, mo.axisPoint, axisLen > 0 ? (1.0 / axisLen) * mo.axis : Vec3d{0, 0, 1}, mo.angularSpeed,
                        mo.startTime, mo.vibrates() ? mo.vibration : Vec3d{0, 0, 0},
                        mo.vibrates() ? 2 * std::numbers::pi * mo.frequency : 0.0, mo.phase, 0, {}, {}, Vec3d{0, 0, 0}, 0.0};
    if (mo.drive) mp.velocity = Vec3d{0, 0, 0}, mp.angularSpeed = 0;  // held still: its drive moves it (WallDrives)
    for (const auto& p : mo.profile) {
      if (mp.profilePoints == kMaxProfilePoints) break;  // validate() refuses more
      mp.profileTau[mp.profilePoints] = p.tau;
      mp.profileVelocity[mp.profilePoints++] = p.velocity;
    }
    s.meshMotion.push_back(mp);
    s.meshNames.push_back(mc.name);
  }

  s.surfaceNames = c.surfaceNames;

  s.skin = c.sim.skin > 0 ? c.sim.skin : 0.1 * 2.0 * maxR;
  if (!(s.skin > 0)) s.skin = 1e-3;  // no particles: any positive value works

  // Domain: given, or the box around particles and mesh vertices with a margin.
  Aabb box;
  if (c.sim.domain) {
    box = *c.sim.domain;
  } else {
    Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    auto grow = [&](Vec3d v, double r) {
      lo = {std::min(lo.x, v.x - r), std::min(lo.y, v.y - r), std::min(lo.z, v.z - r)};
      hi = {std::max(hi.x, v.x + r), std::max(hi.y, v.y + r), std::max(hi.z, v.z + r)};
    };
    for (std::size_t i = 0; i < n; ++i) grow(p.position[i], p.radius[i]);
    for (const auto& v : s.triVerts) grow(v, 0);
    if (lo.x > hi.x) lo = hi = Vec3d{0, 0, 0};
    // Particles end up against the planes (a floor below a falling cloud): include the projection of
    // the box centre onto each plane, so they do not all pile into one layer of boundary cells.
    const Vec3d centre = 0.5 * (lo + hi);
    for (const auto& pl : s.planes) grow(centre - dot(centre - pl.point, pl.normal) * pl.normal, 0);
    const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
    const double margin = 0.05 * extent + 2 * (2 * maxR + s.skin);
    box = {lo - Vec3d{margin, margin, margin}, hi + Vec3d{margin, margin, margin}};
  }
  // Cells at least one largest diameter plus skin wide; coarser if the grid would be huge: more than 16 cells a
  // particle (64 B a particle for the cell starts, and as much for the triangle bins) in a sparse scene, such as a
  // pile poured in a wide box. With 4 a particle, a poured pile's cells were 3.1 mm for 1.32 mm contact ranges, 13
  // times the candidate volume (docs/performance.md, "Small and sparse scenes").
  const Vec3d ext = box.hi - box.lo;
  double cell = std::max(2 * maxR + s.skin, 1e-12);
  const double maxCells = std::max(4096.0, 16.0 * double(n) + double(s.triMesh.size()));
  const int axis = s.model.planarAxis;  // 2D: one layer of cells along it
  if (axis < 0) {
    const double volume = std::max(ext.x, cell) * std::max(ext.y, cell) * std::max(ext.z, cell);
    if (volume / (cell * cell * cell) > maxCells) cell = std::cbrt(volume / maxCells);
  } else {
    const double e[3] = {ext.x, ext.y, ext.z};
    const double area = std::max(e[(axis + 1) % 3], cell) * std::max(e[(axis + 2) % 3], cell);
    if (area / (cell * cell) > maxCells) cell = std::sqrt(area / maxCells);
  }
  s.grid.lo = box.lo;
  s.grid.cellSize = cell;
  s.grid.invCellSize = 1.0 / cell;
  // Cubic cells of exactly `cell`; the grid may reach slightly past the domain's upper corner.
  s.grid.nx = std::max(1, int(std::ceil(ext.x / cell)));
  s.grid.ny = std::max(1, int(std::ceil(ext.y / cell)));
  s.grid.nz = std::max(1, int(std::ceil(ext.z / cell)));
  if (axis >= 0) {  // the layer centred on the particles' plane (the integrator keeps them in it)
    const double at = axis == 0 ? p.position[0].x : axis == 1 ? p.position[0].y : p.position[0].z;
    (axis == 0 ? s.grid.lo.x : axis == 1 ? s.grid.lo.y : s.grid.lo.z) = at - 0.5 * cell;
    (axis == 0 ? s.grid.nx : axis == 1 ? s.grid.ny : s.grid.nz) = 1;
  }
  return s;
}

std::string PhaseTimers::report() const {
  std::string out = "PERFORMANCE";
  const double tot = total();
  for (int p = 0; p < int(Phase::kCount); ++p) {
    char buf[96];
    std::snprintf(buf, sizeof buf, " %s %.3f s (%.1f%%)", kPhaseNames[p], m_seconds[p], tot > 0 ? 100 * m_seconds[p] / tot : 0.0);
    out += buf;
  }
  return out;
}

}  // namespace pflow::compute
