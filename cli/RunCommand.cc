#include "cli/RunCommand.h"

#include "cli/RunCheckpoints.h"
#include "cli/SphRunCommand.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <optional>
#include <nlohmann/json.hpp>
#include <map>
#include <numbers>

#include "backend/store/CheckpointFile.h"
#include "backend/store/DemSeries.h"
#include "backend/store/SnapshotFile.h"
#include "common/Log.h"
#include "compute/dem/Simulation.h"
#include "frontend/SceneLoader.h"
#include "frontend/SceneSummary.h"
#include "frontend/service/InitialState.h"

namespace pflow::cli {

namespace fs = std::filesystem;

int exitCodeFor(const Status& s) {
  switch (s.code()) {
    case StatusCode::kOk: return kExitOk;
    case StatusCode::kInvalidArgument:
    case StatusCode::kNotFound:
    case StatusCode::kFailedPrecondition: return kExitInvalid;
    case StatusCode::kIo: return kExitIo;
    case StatusCode::kUnavailable:
    case StatusCode::kDeadlineExceeded: return kExitUnavailable;
    case StatusCode::kResourceExhausted: return kExitRefused;
    case StatusCode::kCancelled: return kExitCancelled;
    case StatusCode::kAlreadyExists: return kExitInvalid;
    case StatusCode::kUnauthenticated:
    case StatusCode::kPermissionDenied: return kExitDenied;
    default: return kExitSimulation;
  }
}

namespace {

std::string defaultOutput(const frontend::LoadedScene& scene, const std::string& scenePath) {
  if (!scene.outputFile.empty()) {
    const fs::path p(scene.outputFile);
    return p.is_absolute() ? p.string() : (fs::path(scenePath).parent_path() / p).string();
  }
  fs::path p(scenePath);
  return (p.parent_path() / (p.stem().string() + ".h5")).string();
}

}  // namespace

std::string humanSeconds(double s) {
  char buf[64];
  if (s < 120) std::snprintf(buf, sizeof buf, "%.1f s", s);
  else if (s < 7200) std::snprintf(buf, sizeof buf, "%.1f min", s / 60);
  else std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
  return buf;
}

Result<std::unique_ptr<backend::SnapshotWriter>> openOutput(const std::string& path) {
  if (const fs::path parent = fs::path(path).parent_path(); !parent.empty()) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) return ioError("cannot create the output folder '" + parent.string() + "': " + ec.message());
  }
  return backend::SnapshotWriter::create(path);
}

Result<RunSummary> runScene(const RunOptions& o) {
  std::optional<backend::CheckpointData> resume;
  auto scene = sceneOf(o, resume);
  if (!scene) return scene.status();
  if (scene.value().config.solver == compute::Solver::kSph)
    return runSphScene(o, scene.value(), o.outputPath.empty() ? defaultOutput(scene.value(), o.scenePath) : o.outputPath, resume);
  if (o.initialOnly) {  // `pflow build`: the frontend's initial-state writer, the one the model store uses
    RunSummary sum;
    sum.outputPath = o.outputPath.empty() ? defaultOutput(scene.value(), o.scenePath) : o.outputPath;
    sum.xdmfPath = backend::xdmfPathFor(sum.outputPath);
    sum.particles = scene.value().config.particles.size();
    sum.snapshots = 1;
    if (Status s = frontend::writeInitialState(scene.value(), sum.outputPath); !s.isOk()) return s;
    spdlog::info("initial state of {} particles written to {} (open {} in ParaView)", sum.particles, sum.outputPath, sum.xdmfPath);
    return sum;
  }
  compute::RunConfig cfg = scene.value().config;
  if (o.threads > 0) cfg.sim.threads = o.threads;

  compute::SimulationOptions so;
  auto kind = compute::parseExecutorKind(o.executor);
  if (!kind) return kind.status();
  so.executor = kind.value();
  so.device = o.device;

  auto created = compute::Simulation::create(cfg, so);
  if (!created) return created.status();
  compute::Simulation& sim = *created.value();
  auto checkpoints = RunCheckpoints::open(o, o.outputPath.empty() ? defaultOutput(scene.value(), o.scenePath) : o.outputPath, resume, "dem",
                                         sim.engine().precisionName(), resume ? resume->state.step : 0, resume ? resume->state.time : 0.0,
                                         scene.value().checkpointInterval);
  if (!checkpoints) return checkpoints.status();
  if (resume) {
    if (Status s = sim.resume(resume->state); !s.isOk()) return s;
    spdlog::info("resumed from {} at step {} (t = {:.6g} s)", o.resumePath, sim.stepCount(), sim.time());
  }
  const std::int64_t firstStep = sim.stepCount();
  const auto& ts = sim.timeStep();
  spdlog::info("{} particles, {} planes, {} mesh(es); executor: {}, {} precision", sim.numParticles(),
               cfg.planes.size(), cfg.meshes.size(), sim.executorDescription(), sim.engine().precisionName());
  spdlog::info("time step {:.4g} s: {}", ts.dt, ts.reason);
  for (const auto& w : ts.warnings) spdlog::warn("{}", w);

  RunSummary sum;
  sum.outputPath = o.outputPath.empty() ? defaultOutput(scene.value(), o.scenePath) : o.outputPath;
  sum.executor = sim.executorDescription() + ", " + sim.engine().precisionName();
  sum.particles = sim.numParticles();
  auto writer = openOutput(sum.outputPath);
  if (!writer) return writer.status();
  sum.xdmfPath = writer.value()->xdmfPath();
  if (Status s = writer.value()->writeGeometry(sim.geometry()); !s.isOk()) return s;
  const std::vector<std::string>& fields = scene.value().outputFields;
  auto writeSnapshot = [&]() -> Status {
    auto t = sim.timers().time(compute::Phase::kOutput);
    ++sum.snapshots;
    return writer.value()->writeSnapshot(sim.snapshot(fields));
  };
  if (!resume)
    if (Status s = writeSnapshot(); !s.isOk()) return s;
  // The run's series (backend/store/DemSeries.h), appended to /probes after each snapshot so that a killed run
  // keeps them; a resumed run into the same file goes on where the file's end (earlier samples kept, repeats dropped).
  compute::Domain single;
  backend::DemSeriesRecorder series(sim, single, cfg.series, cfg.surfaceNames);
  std::size_t seriesStored = 0;
  auto storeSeries = [&]() -> Status {
    seriesStored = std::min(seriesStored, series.series().time.size());
    if (seriesStored == series.series().time.size()) return Status::ok();
    auto stored = writer.value()->appendProbes(backend::probeSamples(series.series(), seriesStored));
    if (!stored) return stored.status();
    seriesStored = series.series().time.size();
    return Status::ok();
  };
  if (Status s = storeSeries(); !s.isOk()) return s;

  const double duration = cfg.sim.duration, interval = cfg.sim.snapshotInterval;
  auto totalSteps = std::int64_t(std::llround(duration / sim.dt()));
  if (o.maxSteps >= 0 && o.maxSteps < totalSteps) totalSteps = o.maxSteps;
  const auto stepsPerSnapshot = interval > 0 ? std::max<std::int64_t>(1, std::llround(interval / sim.dt())) : totalSteps;
  spdlog::info("running {} steps to t = {} s, a snapshot every {} steps, output {}", totalSteps, duration,
               stepsPerSnapshot, sum.outputPath);
  // Snapshot steps from the simulation's schedule: they stay at the same times when reduce_dt halves dt.
  sim.scheduleOutput(interval, double(totalSteps) * sim.dt());

  const auto wallStart = std::chrono::steady_clock::now();
  auto lastReport = wallStart;
  auto observer = [&](const compute::Simulation& s) -> Status {
    if (s.outputDue())
      if (Status st = writeSnapshot(); !st.isOk()) return st;
    series.sample(s, single);
    if (s.outputDue())
      if (Status st = storeSeries(); !st.isOk()) return st;
    PFLOW_TRY(checkpoints.value().maybeWrite(s, sim.timers()));
    const auto now = std::chrono::steady_clock::now();
    if (o.progressSeconds > 0 && std::chrono::duration<double>(now - lastReport).count() >= o.progressSeconds) {
      lastReport = now;
      const double wall = std::chrono::duration<double>(now - wallStart).count();
      const double done = double(std::max<std::int64_t>(1, s.stepCount() - firstStep));
      const double rate = double(s.numParticles()) * done / wall;
      const double eta = wall / done * double(totalSteps - s.stepCount());
      spdlog::info("step {}/{} t = {:.5g} s, {:.3g} particle-steps/s, ETA {}", s.stepCount(), totalSteps, s.time(),
                   rate, humanSeconds(eta));
    }
    return Status::ok();
  };
  Status run = sim.runUntil(o.maxSteps >= 0 ? double(totalSteps) * sim.dt() : duration, observer);
  if (run.isOk()) run = sim.finishRun();  // no run that gained energy ends as a success
  sum.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
  sum.steps = sim.stepCount() - firstStep;
  sum.simulatedTime = sim.time();
  sum.particleStepsPerSecond = sum.wallSeconds > 0 ? double(sum.particles) * double(sum.steps) / sum.wallSeconds : 0;
  if (Status s = storeSeries(); !s.isOk() && run.isOk()) run = s;  // samples since the last snapshot, also of a failed run
  if (Status s = writer.value()->close(); !s.isOk() && run.isOk()) run = s;
  if (Status s = backend::writeProbesCsv(sum.outputPath); !s.isOk() && run.isOk()) run = s;
  spdlog::info("{}", sim.timers().report());
  if (!run.isOk()) {
    spdlog::error("{}", run.message());
    spdlog::error("snapshots up to step {} are in {}", sim.stepCount(), sum.outputPath);
    return run;
  }
  const auto st = sim.contactStats();
  spdlog::info("done: {} steps in {}, {:.3g} particle-steps/s; {} snapshots in {}", sum.steps,
               humanSeconds(sum.wallSeconds), sum.particleStepsPerSecond, sum.snapshots, sum.outputPath);
  spdlog::info("final state: coordination {:.2f}, max overlap {:.3g} of the radius, kinetic energy {:.4g} J, {} neighbour rebuilds",
               st.coordinationNumber, st.maxOverlapRatio, st.kineticEnergy, sim.rebuilds());
  return sum;
}

int validateScene(const std::string& scenePath, bool json) {
  auto scene = frontend::loadScene(scenePath);
  if (!scene) {
    if (json) std::printf("%s\n", nlohmann::json{{"valid", false}, {"errors", scene.status().message()}}.dump().c_str());
    else std::fprintf(stderr, "%s\n", scene.status().message().c_str());
    return exitCodeFor(scene.status());
  }
  if (scene.value().config.solver == compute::Solver::kSph) return validateSphScene(scenePath, scene.value(), json);
  auto summary = frontend::summarize(scene.value());
  if (!summary) {
    std::fprintf(stderr, "%s\n", summary.status().message().c_str());
    return exitCodeFor(summary.status());
  }
  const frontend::SceneSummary& s = summary.value();
  if (json) {
    nlohmann::json j = nlohmann::json::parse(frontend::toJson(s));
    j["valid"] = true;
    std::printf("%s\n", j.dump().c_str());
    return kExitOk;
  }
  std::printf("%s: valid\n", scenePath.c_str());
  std::printf("  particles   %zu, radius %.4g .. %.4g m, solid volume %.4g m^3\n", s.particles, s.minRadius, s.maxRadius, s.solidVolume);
  for (const auto& set : s.sets) {
    std::printf("    %-12s %-8s %8zu particles, radius %.4g .. %.4g m", set.info.name.c_str(), set.info.method.c_str(), set.info.count,
                set.info.minRadius, set.info.maxRadius);
    if (set.solidFraction > 0) std::printf(", solid fraction %.3f of its region", set.solidFraction);
    std::printf("\n");
  }
  std::printf("  walls       %zu plane(s), %zu mesh(es) with %zu triangles; surfaces:\n", s.planes, s.meshes, s.triangles);
  for (const auto& f : s.surfaces) {
    if (f.triangles == 0 && f.area == 0 && f.name == f.wall && s.planes > 0) std::printf("    %3d  %-24s plane\n", f.id, f.name.c_str());
    else std::printf("    %3d  %-24s %7zu triangles, %.4g m^2\n", f.id, f.name.c_str(), f.triangles, f.area);
  }
  std::printf("  domain      [%.4g, %.4g, %.4g] .. [%.4g, %.4g, %.4g] m, %d x %d x %d cells of %.4g m; solid fraction %.3f of it\n",
              s.domain.lo.x, s.domain.lo.y, s.domain.lo.z, s.domain.hi.x, s.domain.hi.y, s.domain.hi.z, s.cells[0], s.cells[1], s.cells[2],
              s.cellSize, s.domainSolidFraction);
  std::printf("  time step   %.4g s: %s\n", s.dt, s.dtReason.c_str());
  std::printf("              %lld steps to %.4g s\n", (long long)s.steps, scene.value().config.sim.duration);
  for (const auto& w : s.warnings) std::printf("  warning: %s\n", w.c_str());
  std::printf("  memory      about %.3g MB on the executing device (%.0f bytes per particle)\n", s.memoryBytes / 1e6, s.bytesPerParticle);
  std::printf("Model (simulation.model: auto derives the least model; full computes everything)\n%s", s.model.text().c_str());
  return kExitOk;
}

}  // namespace pflow::cli
