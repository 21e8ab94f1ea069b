#include "cli/RunCommand.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <map>
#include <numbers>

#include "backend/store/SnapshotFile.h"
#include "common/Log.h"
#include "compute/sim/Simulation.h"
#include "frontend/SceneLoader.h"

namespace pflow::cli {

namespace fs = std::filesystem;

int exitCodeFor(const Status& s) {
  switch (s.code()) {
    case StatusCode::kOk: return kExitOk;
    case StatusCode::kInvalidArgument:
    case StatusCode::kNotFound:
    case StatusCode::kFailedPrecondition: return kExitInvalid;
    case StatusCode::kIo: return kExitIo;
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

std::string humanSeconds(double s) {
  char buf[64];
  if (s < 120) std::snprintf(buf, sizeof buf, "%.1f s", s);
  else if (s < 7200) std::snprintf(buf, sizeof buf, "%.1f min", s / 60);
  else std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
  return buf;
}

}  // namespace

Result<RunSummary> runScene(const RunOptions& o) {
  auto scene = frontend::loadScene(o.scenePath);
  if (!scene) return scene.status();
  compute::RunConfig cfg = scene.value().config;
  if (o.threads > 0) cfg.sim.threads = o.threads;

  compute::SimulationOptions so;
  if (o.executor == "cuda") so.executor = compute::ExecutorKind::kCuda;
  else if (o.executor != "cpu" && o.executor != "auto")
    return invalidArgument("--executor: '" + o.executor + "' is not one of auto, cpu, cuda");

  auto created = compute::Simulation::create(cfg, so);
  if (!created) return created.status();
  compute::Simulation& sim = *created.value();
  const auto& ts = sim.timeStep();
  spdlog::info("{} particles, {} planes, {} mesh(es); executor: {}", sim.numParticles(), cfg.planes.size(),
               cfg.meshes.size(), sim.executorDescription());
  spdlog::info("time step {:.4g} s: {}", ts.dt, ts.reason);
  for (const auto& w : ts.warnings) spdlog::warn("{}", w);

  RunSummary sum;
  sum.outputPath = o.outputPath.empty() ? defaultOutput(scene.value(), o.scenePath) : o.outputPath;
  sum.executor = sim.executorDescription();
  sum.particles = sim.numParticles();
  auto writer = backend::SnapshotWriter::create(sum.outputPath);
  if (!writer) return writer.status();
  sum.xdmfPath = writer.value()->xdmfPath();
  if (Status s = writer.value()->writeGeometry(sim.geometry()); !s.isOk()) return s;
  const std::vector<std::string>& fields = scene.value().outputFields;
  auto writeSnapshot = [&]() -> Status {
    auto t = sim.timers().time(compute::Phase::kOutput);
    ++sum.snapshots;
    compute::ParticleSnapshot snap = sim.snapshot();
    if (!fields.empty())  // output.fields: keep only the arrays asked for
      std::erase_if(snap.arrays, [&](const compute::SnapshotArray& a) {
        return std::find(fields.begin(), fields.end(), a.name) == fields.end();
      });
    return writer.value()->writeSnapshot(snap);
  };
  if (Status s = writeSnapshot(); !s.isOk()) return s;
  if (o.initialOnly) {
    if (Status s = writer.value()->close(); !s.isOk()) return s;
    spdlog::info("initial state written to {} (open {} in ParaView)", sum.outputPath, sum.xdmfPath);
    return sum;
  }

  const double duration = cfg.sim.duration, interval = cfg.sim.snapshotInterval;
  auto totalSteps = std::int64_t(std::llround(duration / sim.dt()));
  if (o.maxSteps >= 0 && o.maxSteps < totalSteps) totalSteps = o.maxSteps;
  const auto stepsPerSnapshot = interval > 0 ? std::max<std::int64_t>(1, std::llround(interval / sim.dt())) : totalSteps;
  spdlog::info("running {} steps to t = {} s, a snapshot every {} steps, output {}", totalSteps, duration,
               stepsPerSnapshot, sum.outputPath);

  const auto wallStart = std::chrono::steady_clock::now();
  auto lastReport = wallStart;
  auto observer = [&](const compute::Simulation& s) -> Status {
    if (s.stepCount() % stepsPerSnapshot == 0 || s.stepCount() == totalSteps)
      if (Status st = writeSnapshot(); !st.isOk()) return st;
    const auto now = std::chrono::steady_clock::now();
    if (o.progressSeconds > 0 && std::chrono::duration<double>(now - lastReport).count() >= o.progressSeconds) {
      lastReport = now;
      const double wall = std::chrono::duration<double>(now - wallStart).count();
      const double rate = double(s.numParticles()) * double(s.stepCount()) / wall;
      const double eta = wall / double(s.stepCount()) * double(totalSteps - s.stepCount());
      spdlog::info("step {}/{} t = {:.5g} s, {:.3g} particle-steps/s, ETA {}", s.stepCount(), totalSteps, s.time(),
                   rate, humanSeconds(eta));
    }
    return Status::ok();
  };
  Status run = sim.runUntil(o.maxSteps >= 0 ? double(totalSteps) * sim.dt() : duration, observer);
  sum.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
  sum.steps = sim.stepCount();
  sum.simulatedTime = sim.time();
  sum.particleStepsPerSecond = sum.wallSeconds > 0 ? double(sum.particles) * double(sum.steps) / sum.wallSeconds : 0;
  if (Status s = writer.value()->close(); !s.isOk() && run.isOk()) run = s;
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
    return kExitInvalid;
  }
  const auto& c = scene.value().config;
  auto ts = compute::chooseTimeStep(c);
  if (!ts) {
    std::fprintf(stderr, "%s\n", ts.status().message().c_str());
    return kExitInvalid;
  }
  const auto& p = c.particles;
  double rmin = 0, rmax = 0, solid = 0;
  if (p.size()) {
    rmin = *std::min_element(p.radius.begin(), p.radius.end());
    rmax = *std::max_element(p.radius.begin(), p.radius.end());
  }
  for (double r : p.radius) solid += 4.0 / 3.0 * std::numbers::pi * r * r * r;
  std::size_t triangles = 0;
  for (const auto& m : c.meshes) triangles += m.triangles.size();
  auto setup = compute::prepareEngineSetup(c);
  // Field table bytes plus neighbour rows (about 16 candidates of 5 bytes) and double-buffered history.
  const double bytesPerParticle = 8.0 * (3 * 5 + 2 + 2) + (8 + 24) * 2.0 * (c.sim.historySlots + c.sim.wallHistorySlots) + 16 * 5 + 16;
  const double memory = bytesPerParticle * double(p.size());
  nlohmann::json j{{"valid", true},
                   {"particles", p.size()},
                   {"radius_min_m", rmin},
                   {"radius_max_m", rmax},
                   {"solid_volume_m3", solid},
                   {"planes", c.planes.size()},
                   {"meshes", c.meshes.size()},
                   {"triangles", triangles},
                   {"rayleigh_time_s", ts.value().rayleighTime},
                   {"dt_s", ts.value().dt},
                   {"dt_reason", ts.value().reason},
                   {"warnings", ts.value().warnings},
                   {"steps", std::llround(c.sim.duration / ts.value().dt)},
                   {"memory_estimate_bytes", memory}};
  if (setup) {
    const auto& g = setup.value().grid;
    j["cells"] = {g.nx, g.ny, g.nz};
    j["cell_size_m"] = g.cellSize;
    if (c.sim.domain) {
      const auto e = c.sim.domain->hi - c.sim.domain->lo;
      j["solid_fraction_of_domain"] = solid / (e.x * e.y * e.z);
    }
  }
  if (json) {
    std::printf("%s\n", j.dump().c_str());
    return kExitOk;
  }
  std::printf("%s: valid\n", scenePath.c_str());
  std::printf("  particles      %zu, radius %.4g .. %.4g m, solid volume %.4g m^3\n", p.size(), rmin, rmax, solid);
  std::printf("  walls          %zu plane(s), %zu mesh(es) with %zu triangles\n", c.planes.size(), c.meshes.size(), triangles);
  for (std::size_t m = 0; m < c.meshes.size(); ++m) {
    std::map<int, int> perSurface;
    for (std::size_t t = 0; t < c.meshes[m].triangles.size(); ++t)
      ++perSurface[c.meshes[m].surface.empty() ? 0 : c.meshes[m].surface[t]];
    std::printf("    mesh '%s':", c.meshes[m].name.c_str());
    for (auto [s, n] : perSurface) std::printf(" surface %d: %d triangles;", s, n);
    std::printf("\n");
  }
  std::printf("  time step      %.4g s (%s); Rayleigh time %.4g s; %lld steps for %.4g s\n", ts.value().dt,
              ts.value().reason.c_str(), ts.value().rayleighTime, (long long)std::llround(c.sim.duration / ts.value().dt),
              c.sim.duration);
  for (const auto& w : ts.value().warnings) std::printf("  warning: %s\n", w.c_str());
  std::printf("  memory         about %.3g MB on the executing device\n", memory / 1e6);
  return kExitOk;
}

}  // namespace pflow::cli
