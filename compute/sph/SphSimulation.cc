#include "compute/sph/SphSimulation.h"

#include <algorithm>
#include <cmath>

#include "common/Log.h"
#include "compute/core/Memory.h"
#include "compute/sph/SphLattice.h"

namespace pflow::compute::sph {

// ---------------------------------------------------------------------------------------------
// The step loop. One step, top to bottom, a timer per phase: symplectic (position-Verlet predictor-corrector,
// two evaluations of the rates), velocity Verlet (kick-drift-kick, one) or Verlet (one); the rates of the state at the start of the step were computed
// at the end of the previous one. Errors come back through PFLOW_TRY; step() adds the step and time once.
Status SphSimulation::stepPhases() {
  const double dt = nextDt();  // the CFL limits of the rates at the start (all ranks), or sph.dt; lands on outputs
  m_dt = dt;                   // the step being taken (errors name it)
  double moved2 = 0;
  if (m_method.integrator == Integrator::kVelocityVerlet) {
    { auto t = m_timers.time(Phase::kIntegrate1); moved2 = m_engine->kickDrift(dt); }  // v, rho half a step, x a step
    const std::int64_t sorts = m_rebuilds;
    PFLOW_TRY(rates(moved2));                                                         // rates at t + dt (v, rho predicted)
    if (m_rebuilds != sorts) m_rebuiltAt = m_step + 1;
    Status s;
    { auto t = m_timers.time(Phase::kIntegrate2); s = m_engine->kick(dt); }            // v, rho the second half
    PFLOW_TRY(m_domain->agree(s));
    ++m_step;
    m_time += dt;
    return Status::ok();
  }
  if (m_method.integrator == Integrator::kVerlet) {
    const double before = m_step % m_method.verletSteps == 0 ? 0.0 : m_dtBefore;  // 0: an Euler step
    Status s;
    { auto t = m_timers.time(Phase::kIntegrate2); s = m_engine->verlet(dt, before, moved2); } // x, v, rho to t + dt
    PFLOW_TRY(m_domain->agree(s));
    const std::int64_t sorts = m_rebuilds;
    PFLOW_TRY(rates(moved2));                                                         // rates at t + dt
    if (m_rebuilds != sorts) m_rebuiltAt = m_step + 1;
    m_dtBefore = dt;
    ++m_step;
    m_time += dt;
    return Status::ok();
  }
  { auto t = m_timers.time(Phase::kIntegrate1); moved2 = m_engine->predictor(dt); }     // x, v, rho to t + dt/2
  PFLOW_TRY(rates(moved2));                                                         // rates at t + dt/2
  Status s;
  { auto t = m_timers.time(Phase::kIntegrate2); s = m_engine->corrector(dt, moved2); } // x, v, rho to t + dt
  PFLOW_TRY(m_domain->agree(s));
  const std::int64_t sorts = m_rebuilds;
  PFLOW_TRY(rates(moved2));                                                         // rates at t + dt
  if (m_rebuilds != sorts) m_rebuiltAt = m_step + 1;
  ++m_step;
  m_time += dt;
  return Status::ok();
}

// The rates of the state now: a rebuild when some particle on some rank may have moved half the skin since the
// last sort, else (ranks) the ghosts' refresh; with the halo overlap the interior particles' rates are computed
// while it travels (seed 003), the boundary particles' once it has arrived.
Status SphSimulation::rates(double moved2) {
  using Set = SphEngine::RateSet;
  if (m_domain->anyRebuild(2 * std::sqrt(moved2) > m_skin)) {
    PFLOW_TRY(rebuild());
  } else if (m_domain->ranks() > 1 && m_overlapHalo) {
    { auto t = m_timers.time(Phase::kHalo);           PFLOW_TRY(m_domain->startRefresh(*m_engine)); }
    { auto t = m_timers.timeUnfenced(Phase::kForces); m_engine->computeRates(Set::kInterior); }
    { auto t = m_timers.timeUnfenced(Phase::kHalo);   PFLOW_TRY(m_domain->awaitRefresh()); }
    { auto t = m_timers.time(Phase::kForces); }  // the interior pass completes
    { auto t = m_timers.time(Phase::kHalo);           PFLOW_TRY(m_domain->finishRefresh(*m_engine)); }
    auto t = m_timers.time(Phase::kForces);
    m_engine->computeRates(Set::kBoundary);
    return Status::ok();
  } else if (m_domain->ranks() > 1) {
    auto t = m_timers.time(Phase::kHalo);
    PFLOW_TRY(m_domain->startRefresh(*m_engine));
    PFLOW_TRY(m_domain->awaitRefresh());
    PFLOW_TRY(m_domain->finishRefresh(*m_engine));
  }
  auto t = m_timers.time(Phase::kForces);
  m_engine->computeRates(Set::kAll);
  return Status::ok();
}

// Particles to the ranks that own their cells (ghosts dropped, balance kept), the cell sort, the ghosts.
Status SphSimulation::rebuild() {
  const double cost = m_timers.seconds(Phase::kForces);
  { auto t = m_timers.time(Phase::kMigrate); PFLOW_TRY(m_domain->migrate(*m_engine, cost - m_costMark)); }
  { auto t = m_timers.time(Phase::kSort);    m_engine->sortByCell(); }
  { auto t = m_timers.time(Phase::kHalo);    PFLOW_TRY(m_domain->exchangeGhosts(*m_engine)); }
  m_costMark = m_timers.seconds(Phase::kForces);
  ++m_rebuilds;
  return Status::ok();
}
// ---------------------------------------------------------------------------------------------

// The step: CFL x min(force limit, acoustic-viscous limit[, viscous limit]) of the current rates (docs/sph.md,
// equation 10), or the fixed sph.dt; shortened to land on the next output time (two equal steps when one
// would leave a sliver).
double SphSimulation::nextDt() {
  double inverse;
  { auto t = m_timers.time(Phase::kIntegrate1); inverse = m_domain->max(m_engine->maxInverseStep()); }
  m_stable = sph::stableDt(m_method.cfl, m_derived.h, m_method.kinematicViscosity, inverse);
  double dt = m_stable;
  if (m_method.dt) {
    dt = *m_method.dt;
    if (dt > m_stable && !m_warnedFixedDt) {
      spdlog::warn("sph.dt {:.4g} s exceeds the CFL limit {:.4g} s at t = {:.4g} s: the run may blow up", dt, m_stable, m_time);
      m_warnedFixedDt = true;
    }
  }
  double target = m_end;
  if (m_nextOutput >= 0 && (target < 0 || m_nextOutput < target)) target = m_nextOutput;
  if (target > m_time) {
    const double left = target - m_time;
    if (dt >= left * (1 - 1e-12)) dt = left;
    else if (!m_method.dt && 2 * dt > left) dt = 0.5 * left;
  }
  return dt;
}

Status SphSimulation::step() {
  Status s;
  try {
    s = withStep(stepPhases());
  } catch (const OutOfDeviceMemory& e) {
    s = withStep(Status(StatusCode::kResourceExhausted, e.what()));
  } catch (const std::exception& e) {
    s = withStep(Status(StatusCode::kInternal, e.what()));
  }
  if (!s.isOk()) return s;
  m_outputDue = false;
  const double eps = 1e-9 * std::max(m_dt, 1e-300);
  if (m_nextOutput >= 0 && m_time >= m_nextOutput - eps) {
    m_outputDue = true;
    while (m_nextOutput <= m_time + eps) m_nextOutput += m_outputInterval;
  }
  if (m_end >= 0 && std::fabs(m_time - m_end) <= eps) m_outputDue = true;
  return s;
}

void SphSimulation::scheduleOutput(double interval, double end) {
  m_outputInterval = interval;
  // Multiples of the interval, summed as step() sums them: a resumed run's outputs fall where its run's did.
  m_nextOutput = interval > 0 ? interval : -1;
  const double eps = 1e-9 * std::max(m_dt, 1e-300);
  while (interval > 0 && m_nextOutput <= m_time + eps) m_nextOutput += interval;
  m_end = end;
  m_outputDue = false;
}

Result<SimulationState> SphSimulation::state() const {
  if (!justRebuilt())
    return Status(StatusCode::kFailedPrecondition, "a checkpoint is taken just after a cell sort (step " + std::to_string(m_rebuiltAt) +
                                                       " was the last; this is " + std::to_string(m_step) + ")");
  SimulationState s;
  // Distributed: every rank's rows gathered to rank 0 in id order (the other ranks' state has no particles).
  s.particles = m_domain->gather(m_engine->stateArrays(m_step, m_time));
  s.step = m_step;
  s.rebuilds = m_rebuilds;
  s.time = m_time;
  s.dt = m_dt;
  s.dtBefore = m_dtBefore;
  return s;
}

// The rows as the run's sort at s.step left them: sorting them again keeps their order, and the rates are the run's
// (not recomputed), so the next step is the run's own.
Status SphSimulation::resume(const SimulationState& state) {
  SimulationState s;  // distributed: rank 0's scalars on every rank (its particles below)
  s.setScalars(state.scalars());
  try {
    if (m_domain->ranks() > 1) {
      // Rank 0's state on every rank, split as a new run's scene is (by expected work), each keeping its share.
      auto share = shareForResume(*m_domain, m_grid, state, s, [this](const ParticleSnapshot& all, const std::vector<Vec3d>& pos) {
        const SnapshotArray* kind = all.find("kind");
        if (!kind) return std::vector<double>();  // counted alike
        return sphCostWeights(m_grid, pos, std::vector<std::int32_t>(kind->as<std::int32_t>(), kind->as<std::int32_t>() + all.n));
      });
      PFLOW_TRY(share.status());
      PFLOW_TRY(m_domain->agree(m_engine->loadState(share.value().rows, std::move(share.value().weights))));
    } else {
      PFLOW_TRY(m_engine->loadState(state.particles));
    }
    m_step = s.step;
    m_time = s.time;
    m_dt = s.dt;
    m_dtBefore = s.dtBefore;
    PFLOW_TRY(rebuild());
  } catch (const std::exception& e) {
    return withStep(Status(StatusCode::kInternal, e.what()));
  }
  m_rebuilds = s.rebuilds;
  m_rebuiltAt = m_step;
  m_outputDue = false;
  return Status::ok();
}

Status SphSimulation::runSteps(std::int64_t steps) {
  for (std::int64_t k = 0; k < steps; ++k)
    if (Status s = step(); !s.isOk()) return s;
  return Status::ok();
}

Status SphSimulation::runUntil(double time, const std::function<Status(const SphSimulation&)>& observer) {
  if (m_end < 0 || m_end > time) m_end = time;
  while (m_time < time * (1 - 1e-12) - 1e-300) {
    if (Status s = step(); !s.isOk()) return s;
    if (observer)
      if (Status s = observer(*this); !s.isOk()) return s;
  }
  return Status::ok();
}

void SphSimulation::placeProbes() {
  const auto& probes = m_method.probes;
  m_probePoints.clear();
  m_probeFirst.assign(probes.size() + 1, 0);
  const double floor = m_method.tank ? m_method.tank->lo.z : m_grid.lo.z;
  const double top = m_grid.lo.z + m_grid.cellSize * m_grid.nz, dz = 0.5 * m_method.spacing;
  const double plane = m_grid.lo.y + 0.5 * m_grid.cellSize;  // 2D: the particles' plane
  for (std::size_t k = 0; k < probes.size(); ++k) {
    m_probeFirst[k] = m_probePoints.size();
    Vec3d x = probes[k].point;
    if (m_method.dimension == 2) x.y = plane;
    if (!probes[k].gauge) m_probePoints.push_back(x);
    else
      for (double z = floor; z <= top; z += dz) m_probePoints.push_back({x.x, x.y, z});
  }
  m_probeFirst[probes.size()] = m_probePoints.size();
}

std::vector<double> SphSimulation::probeValues() const {
  const auto& probes = m_method.probes;
  const std::vector<Vec3d>& points = m_probePoints;
  const std::vector<std::size_t>& first = m_probeFirst;
  const double floor = m_method.tank ? m_method.tank->lo.z : m_grid.lo.z, dz = 0.5 * m_method.spacing;
  std::vector<double>& fraction = m_probeFraction;
  std::vector<double>& pressure = m_probePressure;
  std::vector<double> values(probes.size(), 0.0);
  m_engine->sample(points, fraction, pressure);
  if (m_domain->ranks() > 1) {  // every rank's fluid near the points, in one sum
    const std::size_t n = points.size();
    fraction.insert(fraction.end(), pressure.begin(), pressure.end());
    m_domain->sum(fraction);
    pressure.assign(fraction.begin() + std::ptrdiff_t(n), fraction.end());
    fraction.resize(n);
  }
  for (std::size_t k = 0; k < probes.size(); ++k) {
    if (!probes[k].gauge) {
      values[k] = fraction[first[k]] > 0.05 ? pressure[first[k]] / fraction[first[k]] : 0.0;
      continue;
    }
    // From the floor up: the first sample where the fluid's share falls below 1/2 after being above it, so a
    // splash or a sheet higher up does not count (a dry gauge reads 0).
    bool wet = false;
    for (std::size_t i = first[k]; i < first[k + 1]; ++i) {
      if (fraction[i] >= 0.5) {
        wet = true;
        continue;
      }
      if (!wet) continue;
      const double below = fraction[i - 1];
      values[k] = points[i - 1].z + (below - 0.5) / (below - fraction[i]) * dz - floor;
      break;
    }
  }
  return values;
}

Status SphSimulation::withStep(Status s) const {
  if (s.isOk()) return s;
  char buf[160];
  std::snprintf(buf, sizeof buf, " at step %lld (t = %.6g s, dt %.3g s; the CFL limit was %.3g s)", (long long)(m_step + 1),
                m_time + m_dt, m_dt, m_stable);
  return Status(s.code(), s.message() + buf);
}

Result<std::unique_ptr<SphSimulation>> SphSimulation::create(const RunConfig& config, const SphOptions& options) {
  if (config.solver != Solver::kSph) return invalidArgument("SphSimulation: the scene's solver is not sph");
  if (ErrorList errors = config.validate(); !errors.empty()) return errors.toStatus("invalid SPH configuration");
  auto setup = prepareSphSetup(config);
  if (!setup) return setup.status();
  std::unique_ptr<SphSimulation> sim(new SphSimulation());
  sim->m_domain = options.domain ? options.domain : std::make_shared<Domain>();
  for (const std::string& w : mdbcThinObstacles(config.sph)) spdlog::warn("obstacles: {}", w);
  if (config.sph.mdbc && sim->m_domain->ranks() > 1)
    return invalidArgument("sph.boundary_density: mdbc runs in one process only: a ghost node's fluid on another rank is "
                           "not exchanged yet (use continuity, or one rank)");
  sim->m_overlapHalo = options.overlapHalo;
  {
    // This rank's share of the scene's particles, their scene index as global id.
    SphSetup& st = setup.value();
    std::vector<std::size_t> mine;
    // Balanced by expected work (fluid and wet walls more than dry walls: sphCostWeight), not by count.
    if (sim->m_domain->ranks() > 1) st.costWeight = sphCostWeights(st.grid, st.position, st.kind);
    if (Status s = sim->m_domain->partitionPoints(st.grid, st.position, mine, st.costWeight); !s.isOk()) return s;
    keepRows(st.costWeight, mine);
    keepRows(st.position, mine);
    keepRows(st.velocity, mine);
    keepRows(st.density, mine);
    keepRows(st.mass, mine);
    keepRows(st.kind, mine);
    st.gid.assign(mine.begin(), mine.end());
    st.canonicalOrder = options.canonicalOrder || sim->m_domain->ranks() > 1;
  }
  sim->m_total = config.sph.size();
  sim->m_derived = derive(config.sph, config.sim);
  sim->m_method = config.sph;  // the method and the probes; the particles are the engine's now
  std::vector<Vec3d>().swap(sim->m_method.position);
  std::vector<Vec3d>().swap(sim->m_method.velocity);
  std::vector<ParticleKind>().swap(sim->m_method.kind);
  sim->m_grid = setup.value().grid;
  sim->m_skin = setup.value().skin;
  sim->placeProbes();
  sim->m_fluid = config.sph.fluidCount();
  const bool single = config.sim.precision == Precision::kFloat;
  ExecutorKind kind = options.executor;
  if (kind == ExecutorKind::kAuto) kind = cudaDeviceCount() > 0 ? ExecutorKind::kCuda : ExecutorKind::kCpu;
  Status made;
  try {
    if (kind == ExecutorKind::kCuda) {
      auto engine = makeCudaSphEngine(std::move(setup).value(), options.device, single);
      if (engine) {
        sim->m_engine = std::move(engine).value();
        sim->m_timers.setFence([e = sim->m_engine.get()] { e->fence(); });
      } else {
        made = engine.status();
      }
    } else {
      sim->m_engine = makeCpuSphEngine(std::move(setup).value(), single);
    }
  } catch (const OutOfDeviceMemory& e) {
    made = Status(StatusCode::kResourceExhausted, e.what());
  } catch (const std::bad_alloc&) {
    made = Status(StatusCode::kResourceExhausted, "host memory exhausted");
  }
  // A device that fails on one rank fails the run on all (the others would wait in the first exchange).
  if (Status s = sim->m_domain->agree(made); !s.isOk()) return s;
  try {
    if (Status s = sim->rebuild(); !s.isOk()) return s;
    sim->m_engine->computeRates(SphEngine::RateSet::kAll);
  } catch (const OutOfDeviceMemory& e) {
    return Status(StatusCode::kResourceExhausted, e.what());
  }
  return sim;
}

std::vector<double> sphCostWeights(const CellGrid& g, const std::vector<Vec3d>& position, const std::vector<std::int32_t>& kind) {
  // Cells holding fluid, widened by the grid's reach along each axis in turn: then a particle's cell is marked when
  // a fluid particle is listed within reach of it (MarkWet's test).
  std::vector<std::uint8_t> near(g.numCells(), 0), line;
  for (std::size_t i = 0; i < position.size(); ++i)
    if (kind[i] == std::int32_t(ParticleKind::kFluid)) near[g.cellOf(position[i])] = 1;
  const int n[3] = {g.nx, g.ny, g.nz};
  const std::size_t stride[3] = {1, std::size_t(g.nx), std::size_t(g.nx) * std::size_t(g.ny)};
  for (int axis = 0; axis < 3; ++axis) {
    const int len = n[axis];
    line.resize(std::size_t(len));
    for (std::size_t first = 0; first < near.size(); ++first) {
      if ((first / stride[axis]) % std::size_t(len) != 0) continue;  // a line starts where its axis index is 0
      for (int k = 0; k < len; ++k) line[std::size_t(k)] = near[first + std::size_t(k) * stride[axis]];
      for (int k = 0; k < len; ++k) {
        std::uint8_t any = 0;
        for (int d = std::max(0, k - g.reach); d <= std::min(len - 1, k + g.reach); ++d) any |= line[std::size_t(d)];
        near[first + std::size_t(k) * stride[axis]] = any;
      }
    }
  }
  std::vector<double> w(position.size());
  for (std::size_t i = 0; i < position.size(); ++i)
    w[i] = sphCostWeight(kind[i] == std::int32_t(ParticleKind::kFluid), near[g.cellOf(position[i])] != 0);
  return w;
}

Result<SphSetup> prepareSphSetup(const RunConfig& config) {
  const SphConfig& c = config.sph;
  const SphDerived d = derive(c, config.sim);
  SphSetup s;
  const std::size_t n = c.size();
  s.position = c.position;
  s.velocity = c.velocity;
  if (s.velocity.empty()) s.velocity.assign(n, Vec3d{0, 0, 0});
  s.kind.resize(n);
  for (std::size_t i = 0; i < n; ++i) s.kind[i] = std::int32_t(c.kind[i]);
  s.kernel = c.kernel;
  s.dimension = c.dimension;
  s.h = d.h;
  s.rho0 = c.density;
  s.c0 = d.c0;
  s.gamma = c.gamma;
  s.alpha = c.artificialViscosity;
  s.nu = c.kinematicViscosity;
  s.delta = c.densityDiffusion;
  s.hydrostaticDiffusion = c.hydrostaticDiffusion;
  s.gravity = config.sim.gravity;
  s.minDensity = c.minDensityRatio * c.density;
  s.maxDensity = c.maxDensityRatio * c.density;
  s.threads = config.sim.threads;
  s.mass.assign(n, d.particleMass);

  // Hydrostatic initial density: a particle under a fluid block carries the pressure rho0 g depth of the
  // block's free surface above it (walls too, so the floor holds the column from the first step).
  const Tait<double> eos = Tait<double>::make(c.density, d.c0, c.gamma);
  const double g = norm(config.sim.gravity);
  s.density.assign(n, c.density);
  if (g > 0) {
    const Vec3d up = (-1.0 / g) * config.sim.gravity;
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3d x = c.position[i];
      double depth = 0;
      for (const SphRegion& b : c.fluidBlocks) {
        // Inside the block's extent across gravity (any height below its top).
        const Vec3d lo = b.lo - Vec3d{0.5 * c.spacing, 0.5 * c.spacing, 0.5 * c.spacing};
        const Vec3d hi = b.hi + Vec3d{0.5 * c.spacing, 0.5 * c.spacing, 0.5 * c.spacing};
        const double top = std::max({dot(b.lo, up), dot(b.hi, up)});
        const Vec3d across = x - dot(x, up) * up;
        bool under = true;
        for (int k = 0; k < 3; ++k) {
          const double a = (&across.x)[k], upk = (&up.x)[k];
          if (std::fabs(upk) > 0.5) continue;  // the vertical axis
          if (a < (&lo.x)[k] || a > (&hi.x)[k]) under = false;
        }
        if (under) depth = std::max(depth, top - dot(x, up));
      }
      const double p = c.density * g * depth;
      s.density[i] = std::max(c.density, eos.density(p));
    }
  }

  // The leak check: fluid outside the tank's outer walls below their top (a closed tank: its lid's outside).
  if (c.tank && c.boundary == BoundaryKind::kMirror) {  // the tank's walls as mirrors: every flat wall but an open top
    MirrorWalls& m = s.mirror;
    m.any = true;
    m.noSlip = !c.freeSlip;
    m.reach = Kernel<double>::make(c.kernel, c.dimension, d.h).support();
    for (int a = 0; a < 3; ++a) {
      const bool across = a == 1 && c.dimension == 2;  // a 2D run's plane has no walls across it
      m.lo[a] = !across;
      m.hi[a] = !across && !(a == 2 && c.tankOpenTop);
      m.loAt[a] = (&c.tank->lo.x)[a];
      m.hiAt[a] = (&c.tank->hi.x)[a];
    }
  }
  if (c.mdbc) {
    if (c.obstacles.size() > std::size_t(MdbcGeometry::kMaxObstacles))
      return invalidArgument("sph.boundary_density: mdbc takes at most " + std::to_string(MdbcGeometry::kMaxObstacles) + " obstacles");
    s.mdbc = mdbcGeometry(c);
  }
  if (c.tank) {
    const double wall = (d.boundaryLayers + 1) * c.spacing;
    s.checkBox = true;
    s.boxLo = c.tank->lo - Vec3d{wall, wall, wall};
    s.boxHi = c.tank->hi + Vec3d{wall, wall, wall};
    if (c.dimension == 2) {
      s.boxLo.y = -1e300;
      s.boxHi.y = 1e300;
    }
  }

  // The grid: cells h + skin/2 wide (two of them hold every neighbour: reach 2) over the particles' box plus
  // 2h + skin, one layer across a 2D run's plane.
  s.skin = c.skin * d.h;
  s.hitMasks = c.hitMasks;
  s.reproducible = config.sim.reproducible;
  const double reachLength = 2 * d.h + s.skin;
  const double cell = 0.5 * reachLength;
  s.grid.reach = 2;
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3d& x : c.position) {
    lo = {std::min(lo.x, x.x), std::min(lo.y, x.y), std::min(lo.z, x.z)};
    hi = {std::max(hi.x, x.x), std::max(hi.y, x.y), std::max(hi.z, x.z)};
  }
  if (n == 0) lo = hi = Vec3d{0, 0, 0};
  if (c.tank && c.boundary == BoundaryKind::kMirror) {  // no wall particles: the tank's inside bounds the flow
    lo = {std::min(lo.x, c.tank->lo.x), std::min(lo.y, c.tank->lo.y), std::min(lo.z, c.tank->lo.z)};
    hi = {std::max(hi.x, c.tank->hi.x), std::max(hi.y, c.tank->hi.y), std::max(hi.z, c.tank->hi.z)};
  }
  lo = lo - Vec3d{reachLength, reachLength, reachLength};
  hi = hi + Vec3d{reachLength, reachLength, reachLength};
  const Vec3d ext = hi - lo;
  s.grid.lo = lo;
  s.grid.cellSize = cell;
  s.grid.invCellSize = 1.0 / cell;
  s.grid.nx = std::max(1, int(std::ceil(ext.x / cell)));
  s.grid.ny = std::max(1, int(std::ceil(ext.y / cell)));
  s.grid.nz = std::max(1, int(std::ceil(ext.z / cell)));
  if (c.dimension == 2) {
    s.grid.lo.y = (n ? c.position[0].y : 0.0) - 0.5 * cell;
    s.grid.ny = 1;
  }
  const double cells = double(s.grid.nx) * s.grid.ny * s.grid.nz;
  if (cells > (4.0 * double(n) + 1e6) * (c.dimension == 3 ? 8 : 4))
    return invalidArgument("sph: the particles span " + std::to_string(s.grid.nx) + " x " + std::to_string(s.grid.ny) + " x " +
                           std::to_string(s.grid.nz) + " cells of " + std::to_string(cell) +
                           " m, far more than particles: a particle is far from the others");
  return s;
}

}  // namespace pflow::compute::sph
