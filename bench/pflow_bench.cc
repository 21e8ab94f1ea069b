// pflow-bench: throughput of the DEM step loop on the standard settled bed
// (../shared/design/benchmarks.md), and of LAMMPS on the very same bed, for the ratio.
// Prints one JSON line per run (pflow, then LAMMPS) on stdout.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <cstdio>
#include <ctime>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/BedScene.h"
#include "bench/BenchUtil.h"
#include "bench/LammpsRunner.h"
#include "common/Log.h"
#include "compute/dem/Simulation.h"

namespace {

using pflow::bench::shell;
using pflow::bench::today;

// OpenMP threads of a CPU run, from its executor description ("OpenMP on N thread(s)").
int threadsOf(const pflow::compute::Simulation& s) {
  const std::string d = s.executorDescription();
  return std::stoi(d.substr(d.find(" on ") + 4));
}


}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"pflow-bench: settled-bed throughput of pflow and LAMMPS"};
  std::vector<long> sizes{100000};
  int settleSteps = 30000, steps = 3000, threads = 0, lammpsRanks = 0;
  bool poly = false, noLammps = false;
  std::string executor = "cpu";
  int gpu = 0;
  std::string device = shell("lscpu | sed -n 's/^Model name: *//p' | head -1");
  app.add_option("-n,--particles", sizes, "particle counts (nx = ny scaled, nz = 20)")->delimiter(',');
  app.add_option("--settle-steps", settleSteps, "steps to settle the bed before timing")->capture_default_str();
  app.add_option("--steps", steps, "timed steps")->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads (0: all cores)");
  app.add_option("--executor", executor, "cpu, cuda or auto")->capture_default_str();
  std::string settleExecutor;
  app.add_option("--settle-executor", settleExecutor,
                 "executor that settles the beds (default: --executor); the timed run then starts from that state");
  app.add_option("--gpu", gpu, "CUDA device index")->capture_default_str();
  app.add_option("--lammps-ranks", lammpsRanks, "LAMMPS MPI ranks (0: as many as pflow's threads)");
  app.add_flag("--poly", poly, "polydisperse bed: radii uniform in [d/4, d/2]");
  app.add_flag("--no-lammps", noLammps, "skip the LAMMPS run");
  long tileFrom = 0;
  int resettleSteps = 1000;
  app.add_option("--tile-from", tileFrom,
                 "settle a bed of about this many spheres for --settle-steps, then build each size from copies of it "
                 "and resettle those for --resettle-steps (0: settle every size itself)");
  app.add_option("--resettle-steps", resettleSteps, "steps a tiled bed settles before timing")->capture_default_str();
  std::string baseCache;
  bool notReproducible = false;
  app.add_flag("--not-reproducible", notReproducible,
               "simulation.reproducible: false (one GPU: each contact evaluated once, the sums by atomic adds)");
  bool noDefer = false;
  app.add_flag("--no-deferred-half", noDefer,
               "every step ends with its own second half kick (SimulationOptions::deferSecondHalf off: the A/B of the "
               "combined pass)");
  bool noBatch = false;
  app.add_flag("--no-batched-contacts", noBatch,
               "the CPU's pairs once evaluates one contact at a time (SimulationOptions::batchedContacts off: the A/B of "
               "the contact law in SIMD lanes; the same bits)");
  int historySlots = 0, wallHistorySlots = 0;
  app.add_option("--wall-history-slots", wallHistorySlots,
                 "initial wall-contact slots per particle (simulation.wall_history_slots; 0: the default, 1)");
  app.add_option("--history-slots", historySlots,
                 "initial tangential-history slots per particle (simulation.history_slots; 0: the bed's 8, 16 "
                 "polydisperse). The slots grow on demand, and a growth holds the old and the new slot fields at once: "
                 "for the largest bed a card holds, start at the count the bed ends with");
  app.add_option("--base-cache", baseCache,
                 "with --tile-from: keep the settled small bed in this directory (a snapshot file named after the bed, "
                 "the settle steps and the settling executor) and reuse it when a later run asks for the same");
  std::vector<std::string> precisions{"double"};
  app.add_option("--precision", precisions, "double, float, or both (comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"double", "float"}));
  double copyBandwidth = 0;
  app.add_option("--copy-bandwidth", copyBandwidth,
                 "the device's measured copy bandwidth [GB/s] (pflow-gpu-bandwidth), for the achieved fraction");
  app.add_option("--device", device, "device name for the results table");
  std::string commit = shell("git rev-parse --short HEAD 2>/dev/null");
  app.add_option("--commit", commit, "commit for the results table (default: git rev-parse)");
  CLI11_PARSE(app, argc, argv);
  pflow::log::init("pflow-bench", "warn");

  std::ostringstream cmdline;
  for (int i = 0; i < argc; ++i) cmdline << (i ? " " : "") << argv[i];
  const std::string caseName = poly ? "settled_bed_poly" : "settled_bed_mono";
  int rc = 0;

  auto kind = pflow::compute::parseExecutorKind(executor);
  if (!kind) {
    std::fprintf(stderr, "%s\n", kind.status().toString().c_str());
    return 1;
  }
  pflow::compute::SimulationOptions so;
  so.executor = kind.value();
  so.device = gpu;
  so.deferSecondHalf = !noDefer;
  so.batchedContacts = !noBatch;
  auto settleKind = pflow::compute::parseExecutorKind(settleExecutor.empty() ? executor : settleExecutor);
  if (!settleKind) {
    std::fprintf(stderr, "%s\n", settleKind.status().toString().c_str());
    return 1;
  }
  pflow::compute::SimulationOptions settleOptions = so;
  settleOptions.executor = settleKind.value();
  // Settles `cfg` for nsteps on the settling executor; hands over to the timed executor (positions,
  // velocities and spins carried; history rebuilt within a step) when that is another one.
  auto settle = [&](const pflow::compute::RunConfig& cfg, int nsteps, double& wallOut)
      -> std::unique_ptr<pflow::compute::Simulation> {
    auto sim = pflow::compute::Simulation::create(cfg, settleOptions);
    if (!sim) {
      std::fprintf(stderr, "%s\n", sim.status().toString().c_str());
      return nullptr;
    }
    const auto t0 = std::chrono::steady_clock::now();
    if (auto st = sim.value()->runSteps(nsteps); !st.isOk()) {
      std::fprintf(stderr, "settling failed: %s\n", st.toString().c_str());
      return nullptr;
    }
    wallOut = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (settleOptions.executor == so.executor) return std::move(sim).value();
    auto timed = pflow::compute::Simulation::create(pflow::bench::withState(cfg, sim.value()->snapshot()), so);
    if (!timed) {
      std::fprintf(stderr, "%s\n", timed.status().toString().c_str());
      return nullptr;
    }
    return std::move(timed).value();
  };

  // --tile-from: settle one small bed the standard way, then build every size from copies of it.
  pflow::compute::RunConfig baseBed;
  pflow::compute::ParticleSnapshot baseState;
  double baseSettleWall = 0;
  if (tileFrom > 0) {
    auto spec = pflow::bench::bedSpecFor(tileFrom, poly);
    spec.threads = threads;
    baseBed = pflow::bench::bedScene(spec);
    const std::string cached = baseCache.empty() ? std::string()
                                                 : pflow::bench::settledBedPath(baseCache, tileFrom, poly, settleSteps,
                                                                                settleExecutor.empty() ? executor : settleExecutor);
    if (cached.empty() || !pflow::bench::loadSettledBed(cached, baseState)) {
      auto base = settle(baseBed, settleSteps, baseSettleWall);
      if (!base) return 1;
      baseState = base->snapshot();
      if (!cached.empty())
        if (pflow::Status st = pflow::bench::saveSettledBed(cached, baseState); !st.isOk())
          std::fprintf(stderr, "warning: the settled bed was not kept: %s\n", st.toString().c_str());
    }
  }

  for (long n : sizes) {
    pflow::compute::RunConfig cfg;
    if (tileFrom > 0) {
      cfg = pflow::bench::tiledBed(baseBed, baseState, n);
    } else {
      auto spec = pflow::bench::bedSpecFor(n, poly);
      spec.threads = threads;
      cfg = pflow::bench::bedScene(spec);
    }
    if (historySlots > 0) cfg.sim.historySlots = historySlots;
    if (wallHistorySlots > 0) cfg.sim.wallHistorySlots = wallHistorySlots;
    cfg.sim.reproducible = !notReproducible;
    std::unique_ptr<pflow::compute::Simulation> last;
    std::vector<std::pair<std::string, double>> rates;
    for (const std::string& precision : precisions) {
    cfg.sim.precision = precision == "float" ? pflow::compute::Precision::kFloat : pflow::compute::Precision::kDouble;
    double settleWall = 0;
    auto simPtr = settle(cfg, tileFrom > 0 ? resettleSteps : settleSteps, settleWall);
    if (!simPtr) return 1;
    auto& s = *simPtr;
    const auto before = s.contactStats();
    s.timers().reset();
    const auto rebuilds0 = s.rebuilds(), fused0 = s.fusedHalves();
    const auto t1 = std::chrono::steady_clock::now();
    if (auto st = s.runSteps(steps); !st.isOk()) {
      std::fprintf(stderr, "timed run failed: %s\n", st.toString().c_str());
      return 1;
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    const double rate = double(s.numParticles()) * steps / wall;
    rates.emplace_back(precision, rate);
    nlohmann::json phases;
    for (int p = 0; p < int(pflow::compute::Phase::kCount); ++p)
      phases[pflow::compute::kPhaseNames[p]] = s.timers().seconds(pflow::compute::Phase(p));
    const bool onGpu = s.executorKind() == pflow::compute::ExecutorKind::kCuda;
    const int usedThreads = onGpu ? 0 : threadsOf(s);
    const std::string execName = onGpu ? "cuda" : "cpu";
    const std::string where = onGpu ? s.executorDescription() : device;
    // The fewest bytes each phase must move per step (docs/performance.md), and the rate achieved on them.
    const auto traffic = pflow::bench::compulsoryTraffic(precision == "float" ? 4 : 8, before.candidatesPerParticle,
                                                        before.coordinationNumber);
    nlohmann::json achieved;
    for (const auto& [phase, bytes] : traffic) {
      const double secs = s.timers().seconds(pflow::compute::phaseByName(phase));
      const double gbps = secs > 0 ? bytes * double(s.numParticles()) * steps / secs / 1e9 : 0.0;
      achieved[phase] = {{"bytes_per_particle", bytes}, {"gb_per_s", gbps},
                         {"of_copy_bandwidth", copyBandwidth > 0 ? gbps / copyBandwidth : 0.0}};
    }
    nlohmann::json j{{"code", "pflow"}, {"executor", execName}, {"executor_description", s.executorDescription()},
                     {"launch", s.engine().launchReport()}, {"threads", usedThreads},
                     {"precision", s.engine().precisionName()},
                     {"case", caseName}, {"n", s.numParticles()}, {"settle_steps", settleSteps},
                     {"settle_s", settleWall}, {"tiled_from", tileFrom > 0 ? long(baseState.n) : 0L},
                     {"tiles", tileFrom > 0 ? cfg.particles.size() / baseState.n : 1}, {"resettle_steps", tileFrom > 0 ? resettleSteps : 0},
                     {"base_settle_s", baseSettleWall}, {"steps", steps}, {"wall_s", wall},
                     {"particle_steps_per_s", rate}, {"phases_s", phases}, {"traffic", achieved},
                     {"copy_bandwidth_gb_per_s", copyBandwidth},
                     {"coordination", before.coordinationNumber},
                     {"candidates_per_particle", before.candidatesPerParticle},
                     {"rebuilds", s.rebuilds() - rebuilds0}, {"fused_halves", s.fusedHalves() - fused0}, {"batched_contacts", !noBatch},
                     {"history_slots", s.engine().historySlots()}, {"reproducible", cfg.sim.reproducible},
                     {"wall_history_slots", s.engine().wallHistorySlots()},
                     {"device_bytes_per_particle", double(s.deviceBytes()) / double(s.numParticles())},
                     {"device_peak_bytes_per_particle", double(s.devicePeakBytes()) / double(s.numParticles())},
                     {"device", where}, {"commit", commit}, {"command", cmdline.str()}};
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
    std::fprintf(stderr, "| %s | %s | %s | pflow %s | %s | %s | %zu | %s | %.3g | `%s` |\n", today().c_str(),
                 commit.c_str(), where.c_str(), execName.c_str(), s.engine().precisionName(), caseName.c_str(),
                 s.numParticles(), onGpu ? "1 GPU" : (std::to_string(usedThreads) + " threads").c_str(), rate,
                 cmdline.str().c_str());
    last = std::move(simPtr);
    }
    auto& s = *last;
    const double rate = rates.front().second;
    // LAMMPS on as many ranks as pflow had threads, or on every core of the host of a GPU run.
    const int usedThreads = s.executorKind() == pflow::compute::ExecutorKind::kCuda
                                ? int(std::thread::hardware_concurrency())
                                : threadsOf(s);

    if (noLammps) continue;
    if (!pflow::bench::findLammps()) {
      std::fprintf(stderr, "lmp not found: LAMMPS comparison skipped\n");
      continue;
    }
    const auto snap = s.snapshot();
    pflow::bench::LammpsBed bed;
    const std::size_t np = snap.n;
    const auto* x = snap.find("position")->as<pflow::Vec3d>();
    const auto* v = snap.find("velocity")->as<pflow::Vec3d>();
    const auto* w = snap.find("angular_velocity")->as<pflow::Vec3d>();
    const auto* r = snap.find("radius")->as<double>();
    bed.position.assign(x, x + np);
    bed.velocity.assign(v, v + np);
    bed.angularVelocity.assign(w, w + np);
    bed.radius.assign(r, r + np);
    const auto& m = cfg.materials[0];
    bed.density = m.density;
    bed.youngsModulus = m.youngsModulus;
    bed.poissonRatio = m.poissonRatio;
    bed.restitution = m.restitution;
    bed.friction = m.friction;
    bed.boxLo = cfg.sim.domain->lo;
    bed.boxHi = cfg.sim.domain->hi;
    bed.gravity = cfg.sim.gravity;
    bed.dt = *cfg.sim.dt;
    bed.skin = cfg.sim.skin;
    bed.steps = steps;
    pflow::bench::LammpsOptions lo;
    lo.ranks = lammpsRanks > 0 ? lammpsRanks : usedThreads;
    auto lr = pflow::bench::runLammps(bed, lo);
    if (!lr) {
      std::fprintf(stderr, "LAMMPS failed: %s\n", lr.status().toString().c_str());
      rc = 2;
      continue;
    }
    const auto& l = lr.value();
    nlohmann::json jl{{"code", "lammps"}, {"version", l.lammpsVersion}, {"ranks", l.ranks}, {"precision", "double"},
                      {"case", caseName}, {"n", l.atoms}, {"steps", l.steps}, {"wall_s", l.loopSeconds},
                      {"particle_steps_per_s", l.particleStepsPerSecond}, {"neighbor_builds", l.neighborBuilds},
                      {"pflow_over_lammps", rate / l.particleStepsPerSecond},
                      {"pflow_precision", rates.front().first}, {"device", device},
                      {"commit", commit}, {"command", l.command}};
    nlohmann::json sections = nlohmann::json::object();
    for (const auto& [name, secs] : l.sections) sections[name] = secs;
    jl["sections_s"] = sections;  // LAMMPS's own timing breakdown (average over ranks)
    std::printf("%s\n", jl.dump().c_str());
    std::fflush(stdout);
    std::fprintf(stderr, "| %s | %s | %s | LAMMPS %s | double | %s | %ld | %d ranks | %.3g | `%s` (ratio pflow/LAMMPS %.2f) |\n",
                 today().c_str(), commit.c_str(), device.c_str(), l.lammpsVersion.c_str(), caseName.c_str(), l.atoms,
                 l.ranks, l.particleStepsPerSecond, cmdline.str().c_str(), rate / l.particleStepsPerSecond);
  }
  return rc;
}
