// `pflow run` and `pflow validate` for solver: sph scenes: the same options, output file and progress lines
// as a DEM run (RunCommand.cc), driven by compute::sph::SphSimulation (variable time step: outputs and the
// progress line go by simulated time).
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

#include "backend/store/ProbeSeries.h"
#include "backend/store/SnapshotFile.h"
#include "cli/RunCheckpoints.h"
#include "cli/SphRunCommand.h"
#include "common/Log.h"
#include "compute/core/Format.h"
#include "compute/sph/SphLattice.h"
#include "compute/sph/SphSimulation.h"

namespace pflow::cli {

using compute::sph::SphSimulation;

Result<RunSummary> runSphScene(const RunOptions& o, const frontend::LoadedScene& scene, const std::string& outputPath,
                               const std::optional<backend::CheckpointData>& resume) {
  compute::RunConfig cfg = scene.config;
  if (o.threads > 0) cfg.sim.threads = o.threads;
  compute::sph::SphOptions so;
  auto kind = compute::parseExecutorKind(o.executor);
  if (!kind) return kind.status();
  so.executor = kind.value();
  so.device = o.device;
  auto created = SphSimulation::create(cfg, so);
  if (!created) return created.status();
  SphSimulation& sim = *created.value();
  auto checkpoints = RunCheckpoints::open(o, outputPath, resume, "sph", sim.precisionName(), resume ? resume->state.step : 0,
                                          resume ? resume->state.time : 0.0, scene.checkpointInterval);
  if (!checkpoints) return checkpoints.status();
  if (resume) {
    if (Status s = sim.resume(resume->state); !s.isOk()) return s;
    spdlog::info("resumed from {} at step {} (t = {:.6g} s)", o.resumePath, sim.stepCount(), sim.time());
  }
  const std::int64_t firstStep = sim.stepCount();
  const auto& d = sim.derived();
  spdlog::info("SPH: {} particles ({} fluid, {} boundary), {}D, dp {:.4g} m, h {:.4g} m, {} kernel; executor: {}, {} precision",
               sim.numParticles(), sim.fluidParticles(), sim.numParticles() - sim.fluidParticles(), cfg.sph.dimension,
               cfg.sph.spacing, d.h, compute::sph::kernelName(cfg.sph.kernel), sim.executorDescription(), sim.precisionName());
  spdlog::info("speed of sound {:.4g} m/s ({}); first step {:.4g} s (CFL {})", d.c0, d.soundSpeedReason, sim.stableDt(), cfg.sph.cfl);

  RunSummary sum;
  sum.outputPath = outputPath;
  sum.executor = sim.executorDescription() + ", " + sim.precisionName();
  sum.particles = sim.numParticles();
  auto writer = openOutput(sum.outputPath);
  if (!writer) return writer.status();
  sum.xdmfPath = writer.value()->xdmfPath();
  if (Status s = writer.value()->writeGeometry({}); !s.isOk()) return s;
  auto writeSnapshot = [&]() -> Status {
    auto t = sim.timers().time(compute::Phase::kOutput);
    ++sum.snapshots;
    return writer.value()->writeSnapshot(sim.snapshot(scene.outputFields));
  };
  if (!resume)
    if (Status s = writeSnapshot(); !s.isOk()) return s;
  if (o.initialOnly) {  // `pflow build`: the initial state (hydrostatic densities and pressures included)
    if (Status s = writer.value()->close(); !s.isOk()) return s;
    spdlog::info("initial state of {} particles written to {} (open {} in ParaView)", sum.particles, sum.outputPath, sum.xdmfPath);
    return sum;
  }
  const double duration = cfg.sim.duration;
  sim.scheduleOutput(cfg.sim.snapshotInterval, duration);
  backend::ProbeRecorder probes(sim, cfg.sph.probeInterval, cfg.sph.probeMean);
  spdlog::info("running to t = {} s, a snapshot every {} s, output {}", duration,
               cfg.sim.snapshotInterval > 0 ? cfg.sim.snapshotInterval : duration, sum.outputPath);
  const auto wallStart = std::chrono::steady_clock::now();
  auto lastReport = wallStart;
  auto observer = [&](const SphSimulation& s) -> Status {
    if (s.outputDue())
      if (Status st = writeSnapshot(); !st.isOk()) return st;
    probes.sample(s);
    PFLOW_TRY(checkpoints.value().maybeWrite(s, sim.timers()));
    if (o.maxSteps >= 0 && s.stepCount() >= o.maxSteps) return Status(StatusCode::kCancelled, "step limit");
    const auto now = std::chrono::steady_clock::now();
    if (o.progressSeconds > 0 && std::chrono::duration<double>(now - lastReport).count() >= o.progressSeconds) {
      lastReport = now;
      const double wall = std::chrono::duration<double>(now - wallStart).count();
      const double rate = double(s.numParticles()) * double(std::max<std::int64_t>(1, s.stepCount() - firstStep)) / wall;
      const double eta = s.time() > 0 ? wall / s.time() * (duration - s.time()) : 0;
      spdlog::info("step {} t = {:.5g}/{} s, dt {:.3g} s, {:.3g} particle-steps/s, ETA {}", s.stepCount(), s.time(), duration,
                   s.dt(), rate, humanSeconds(eta));
    }
    return Status::ok();
  };
  Status run = sim.runUntil(duration, observer);
  if (run.code() == StatusCode::kCancelled && o.maxSteps >= 0) {
    run = Status::ok();
    if (!sim.outputDue())
      if (Status st = writeSnapshot(); !st.isOk()) run = st;
  }
  sum.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
  sum.steps = sim.stepCount() - firstStep;
  sum.simulatedTime = sim.time();
  sum.particleStepsPerSecond = sum.wallSeconds > 0 ? double(sum.particles) * double(sum.steps) / sum.wallSeconds : 0;
  if (Status s = writer.value()->close(); !s.isOk() && run.isOk()) run = s;
  if (!probes.empty()) {  // what was measured, also when the run failed
    const backend::ProbeSeries all = resume ? backend::withEarlierSamples(sum.outputPath, probes.series()) : probes.series();
    if (Status s = backend::writeProbeFiles(sum.outputPath, all); !s.isOk() && run.isOk()) run = s;
    spdlog::info("{} probe samples of {} probes in {} (/probes) and {}", probes.series().time.size(), probes.series().names.size(),
                 sum.outputPath, backend::probesCsvPathFor(sum.outputPath));
  }
  spdlog::info("{}", sim.timers().report());
  if (!run.isOk()) {
    spdlog::error("{}", run.message());
    spdlog::error("snapshots up to step {} are in {}", sim.stepCount(), sum.outputPath);
    return run;
  }
  spdlog::info("done: {} steps in {}, {:.3g} particle-steps/s; {} snapshots in {}; {} cell sorts", sum.steps, humanSeconds(sum.wallSeconds),
               sum.particleStepsPerSecond, sum.snapshots, sum.outputPath, sim.rebuilds());
  return sum;
}

int validateSphScene(const std::string& scenePath, const frontend::LoadedScene& scene, bool json) {
  const compute::RunConfig& c = scene.config;
  const compute::sph::SphDerived d = compute::sph::derive(c.sph, c.sim);
  auto setup = compute::sph::prepareSphSetup(c);
  if (!setup) {
    std::fprintf(stderr, "%s\n", setup.status().message().c_str());
    return exitCodeFor(setup.status());
  }
  const std::size_t n = c.sph.size(), fluid = c.sph.fluidCount();
  const compute::CellGrid& g = setup.value().grid;
  // The first step: the acoustic limit (the fluid starts at rest or at its block velocities).
  const double dt0 = compute::sph::stableDt(c.sph.cfl, d.h, c.sph.kinematicViscosity, compute::sph::inverseStep(d.h, d.c0, 0, 0, false));
  if (json) {
    nlohmann::json fills = nlohmann::json::array();
    for (const auto& b : c.sph.fluidBlocks) {
      const compute::sph::LatticeFill f = compute::sph::latticeFill(c.sph, b.lo, b.hi);
      fills.push_back({{"name", b.name}, {"size", {b.hi.x - b.lo.x, b.hi.y - b.lo.y, b.hi.z - b.lo.z}},
                       {"filled", {f.filled.x, f.filled.y, f.filled.z}}, {"particles", f.particles()}, {"volume_fraction", f.volumeFraction}});
    }
    nlohmann::json j{{"valid", true},         {"solver", "sph"},    {"particles", n},         {"fluid_particles", fluid},
                     {"boundary_particles", n - fluid}, {"dimension", c.sph.dimension}, {"spacing", c.sph.spacing},
                     {"smoothing_length", d.h}, {"sound_speed", d.c0}, {"sound_speed_reason", d.soundSpeedReason},
                     {"boundary_layers", d.boundaryLayers}, {"boundary_density", c.sph.mdbc ? "mdbc" : "continuity"},
                     {"dt", dt0},  {"duration", c.sim.duration},
                     {"kernel", compute::sph::kernelName(c.sph.kernel)}, {"fluid_blocks", fills}};
    std::printf("%s\n", j.dump().c_str());
    return kExitOk;
  }
  std::printf("%s: valid (solver: sph)\n", scenePath.c_str());
  std::printf("  particles   %zu: %zu fluid, %zu boundary (%d layers), %dD, spacing %.4g m\n", n, fluid, n - fluid,
              d.boundaryLayers, c.sph.dimension, c.sph.spacing);
  if (n > fluid)
    std::printf("  boundary    %s\n", c.sph.mdbc ? "density extrapolated from the fluid at ghost nodes (sph.boundary_density: mdbc)"
                                                   : "density by continuity (dynamic boundary particles)");
  for (const std::string& w : compute::sph::mdbcThinObstacles(c.sph)) std::printf("  warning     obstacles: %s\n", w.c_str());
  for (const auto& b : c.sph.fluidBlocks) {  // each block as the lattice fills it (whole spacings from its low corner)
    const compute::sph::LatticeFill f = compute::sph::latticeFill(c.sph, b.lo, b.hi);
    const Vec3d asked = b.hi - b.lo;
    if (c.sph.dimension == 2)
      std::printf("  fluid       %s: %zu particles, %.4g x %.4g m (x, z) of the %.4g x %.4g m asked (%.1f %% of its area)\n",
                  b.name.c_str(), f.particles(), f.filled.x, f.filled.z, asked.x, asked.z, 100.0 * f.volumeFraction);
    else
      std::printf("  fluid       %s: %zu particles, %.4g x %.4g x %.4g m of the %.4g x %.4g x %.4g m asked (%.1f %% of its volume)\n",
                  b.name.c_str(), f.particles(), f.filled.x, f.filled.y, f.filled.z, asked.x, asked.y, asked.z, 100.0 * f.volumeFraction);
  }
  std::printf("  method      %s kernel, h = %.4g m (h/dp %.3g), Tait gamma %.3g, alpha %.3g, delta %.3g%s, nu %.3g m^2/s\n",
              compute::sph::kernelName(c.sph.kernel), d.h, c.sph.smoothingRatio, c.sph.gamma, c.sph.artificialViscosity,
              c.sph.densityDiffusion, c.sph.hydrostaticDiffusion ? " (hydrostatic correction)" : "", c.sph.kinematicViscosity);
  std::printf("  sound speed %.4g m/s: %s\n", d.c0, d.soundSpeedReason.c_str());
  std::printf("  time step   %.4g s at the start (CFL %.3g; adapted every step), %.4g s simulated\n", dt0, c.sph.cfl, c.sim.duration);
  std::printf("  cells       %d x %d x %d of %.4g m\n", g.nx, g.ny, g.nz, g.cellSize);
  if (!c.sph.probes.empty())
    std::printf("  probes      %s, %s\n", c.sph.probeInterval > 0 ? ("every " + format::num(c.sph.probeInterval) + " s").c_str() : "at the snapshots",
                c.sph.probeMean ? "each the mean since the one before (output.probe_sampling: mean)" : "each an instant's reading");
  for (const auto& p : c.sph.probes)
    std::printf("  %-6s %-10s at (%.4g, %.4g, %.4g) m\n", p.gauge ? "gauge" : "probe", p.name.c_str(), p.point.x, p.point.y, p.point.z);
  return kExitOk;
}

}  // namespace pflow::cli
