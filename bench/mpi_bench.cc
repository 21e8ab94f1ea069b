// pflow-bench-mpi: the settled bed split across MPI ranks (issue 6): weak scaling (--per-rank spheres on
// each rank), strong scaling (--particles in all), the share of each step spent exchanging particles, and
// what overlapping the halo with the interior forces gains. One JSON line per timed run on rank 0's stdout.
//
// Run under mpirun, one rank per GPU (device = local rank modulo the visible devices) or per group of cores:
//   mpirun -np 4 pflow-bench-mpi --executor cuda --per-rank 4000000
// Rank 0 settles a small bed once and every rank builds the large bed from copies of it (BedScene's
// tiledBed), so a size of 10^7 does not need 10^7-sphere settling.
#include <CLI/CLI.hpp>
#include <mpi.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/BedScene.h"
#include "bench/BenchMpi.h"
#include "bench/BenchUtil.h"
#include "common/Log.h"
#include "compute/mpi/MpiDomain.h"
#include "compute/dem/Simulation.h"

namespace {

using pflow::compute::Phase;
using pflow::compute::Simulation;
using pflow::bench::shell;

int fail(const std::string& what) {
  std::fprintf(stderr, "pflow-bench-mpi: %s\n", what.c_str());
  MPI_Abort(MPI_COMM_WORLD, 1);
  return 1;
}

// Rank 0's snapshot arrays broadcast to every rank (the settled base bed).
void broadcast(pflow::compute::ParticleSnapshot& s) {
  unsigned long long n = s.n, arrays = s.arrays.size();
  MPI_Bcast(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
  MPI_Bcast(&arrays, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
  s.n = n;
  s.arrays.resize(arrays);
  for (auto& a : s.arrays) {
    int meta[3] = {int(a.type), a.components, int(a.name.size())};
    MPI_Bcast(meta, 3, MPI_INT, 0, MPI_COMM_WORLD);
    a.type = pflow::compute::ScalarType(meta[0]);
    a.components = meta[1];
    a.name.resize(std::size_t(meta[2]));
    MPI_Bcast(a.name.data(), meta[2], MPI_CHAR, 0, MPI_COMM_WORLD);
    unsigned long long bytes = a.data.size();
    MPI_Bcast(&bytes, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
    a.data.resize(bytes);
    for (unsigned long long at = 0; at < bytes; at += (1ull << 30))
      MPI_Bcast(a.data.data() + at, int(std::min<unsigned long long>(1ull << 30, bytes - at)), MPI_BYTE, 0, MPI_COMM_WORLD);
  }
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);

  CLI::App app{"pflow-bench-mpi: the settled bed across MPI ranks (weak and strong scaling, halo overlap)"};
  long perRank = 0, total = 0, tileFrom = 20000;
  int settleSteps = 20000, resettleSteps = 1000, steps = 2000, threads = 0;
  std::string executor = "cpu", precision = "double", decomposition = "sfc", overlap = "both", costName = "measured";
  std::string device = shell("lscpu | sed -n 's/^Model name: *//p' | head -1");
  std::string commit = shell("git rev-parse --short HEAD 2>/dev/null");
  app.add_option("--per-rank", perRank, "spheres per rank (weak scaling)");
  app.add_option("--particles", total, "spheres in all (strong scaling)");
  app.add_option("--tile-from", tileFrom, "spheres of the small bed settled once and tiled")->capture_default_str();
  app.add_option("--settle-steps", settleSteps, "steps settling the small bed")->capture_default_str();
  app.add_option("--resettle-steps", resettleSteps, "steps the tiled bed settles before timing")->capture_default_str();
  app.add_option("--steps", steps, "timed steps (per overlap setting)")->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads per rank (0: the cores divided by the ranks on the node)");
  app.add_option("--executor", executor, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  std::string settleExecutor;
  app.add_option("--settle-executor", settleExecutor, "executor rank 0 settles the small bed on (default: --executor)")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  app.add_option("--precision", precision)->check(CLI::IsMember({"double", "float"}))->capture_default_str();
  app.add_option("--decomposition", decomposition)->check(CLI::IsMember({"sfc", "multisection"}))->capture_default_str();
  app.add_option("--overlap", overlap, "halo overlapped with the interior forces: on, off, or both (timed in turn)")
      ->check(CLI::IsMember({"on", "off", "both"}))
      ->capture_default_str();
  app.add_option("--cost", costName, "load-balance cost: measured or count")->check(CLI::IsMember({"measured", "count"}))->capture_default_str();
  std::string canonical = "on";
  app.add_option("--canonical", canonical, "candidates in global-id order (bit-for-bit equal to one process)")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app.add_option("--device", device, "device name for the results table");
  app.add_option("--commit", commit, "commit for the results table");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = rank == 0 ? app.exit(e) : 0;
    MPI_Finalize();
    return code;
  }
  pflow::log::init("pflow-bench-mpi", "warn");
  if ((perRank > 0) == (total > 0)) return fail("give exactly one of --per-rank and --particles");
  const long n = perRank > 0 ? perRank * ranks : total;
  std::ostringstream cmdline;
  for (int i = 0; i < argc; ++i) cmdline << (i ? " " : "") << argv[i];

  // Ranks on this node share its cores (CPU) or its GPUs (CUDA).
  const pflow::compute::NodeRanks node = pflow::compute::nodeRanks(MPI_COMM_WORLD);
  const int localRank = node.rank, localSize = node.size;
  pflow::compute::SimulationOptions so;
  so.executor = executor == "cuda" ? pflow::compute::ExecutorKind::kCuda : pflow::compute::ExecutorKind::kCpu;
  if (so.executor == pflow::compute::ExecutorKind::kCuda) {
    const int gpus = pflow::compute::cudaDeviceCount();
    if (gpus == 0) return fail("--executor cuda: no GPU visible");
    so.device = localRank % gpus;
  }
  if (threads == 0) threads = std::max(1, int(std::thread::hardware_concurrency()) / std::max(1, localSize));

  // The small bed, settled once on rank 0 (one process), then every rank's copy of its state.
  auto spec = pflow::bench::bedSpecFor(tileFrom, false);
  spec.threads = threads;
  const pflow::compute::RunConfig base = pflow::bench::bedScene(spec);
  pflow::compute::ParticleSnapshot settled;
  double settleWall = 0;
  if (rank == 0) {
    pflow::compute::SimulationOptions settleOptions = so;
    if (!settleExecutor.empty())
      settleOptions.executor = settleExecutor == "cuda" ? pflow::compute::ExecutorKind::kCuda : pflow::compute::ExecutorKind::kCpu;
    auto sim = Simulation::create(base, settleOptions);
    if (!sim) return fail(sim.status().toString());
    const auto t0 = std::chrono::steady_clock::now();
    if (auto st = sim.value()->runSteps(settleSteps); !st.isOk()) return fail("settling: " + st.toString());
    settleWall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    settled = sim.value()->snapshot();
  }
  broadcast(settled);
  pflow::compute::RunConfig cfg = pflow::bench::tiledBed(base, settled, long(n));
  cfg.sim.precision = precision == "float" ? pflow::compute::Precision::kFloat : pflow::compute::Precision::kDouble;
  cfg.sim.threads = threads;

  pflow::compute::MpiDomainOptions mo;
  mo.strategy = decomposition == "sfc" ? pflow::compute::DecompositionKind::kSfc : pflow::compute::DecompositionKind::kMultiSection;
  mo.cost = costName == "count" ? pflow::compute::MpiDomainOptions::Cost::kCount : pflow::compute::MpiDomainOptions::Cost::kMeasured;
  mo.canonicalOrder = canonical == "on";
  auto domain = std::make_shared<pflow::compute::MpiDomain>(MPI_COMM_WORLD, mo);
  so.domain = domain;
  auto created = Simulation::create(cfg, so);
  if (!created) return fail(created.status().toString());
  std::unique_ptr<Simulation> owner = std::move(created).value();  // released before MPI_Finalize
  Simulation& s = *owner;
  if (auto st = s.runSteps(resettleSteps); !st.isOk()) return fail("resettling: " + st.toString());

  std::vector<bool> settings;
  if (overlap != "off") settings.push_back(true);
  if (overlap != "on") settings.push_back(false);
  for (bool on : settings) {
    s.setOverlapHalo(on);
    s.timers().reset();
    const auto rebuilds0 = s.rebuilds();
    const int rebalances0 = domain->rebalances();
    MPI_Barrier(MPI_COMM_WORLD);
    const auto t0 = std::chrono::steady_clock::now();
    if (auto st = s.runSteps(steps); !st.isOk()) return fail("timed run: " + st.toString());
    MPI_Barrier(MPI_COMM_WORLD);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Per-phase seconds: the mean over ranks and the largest; the boundary share summed over ranks.
    const pflow::bench::PhaseSpread spread = pflow::bench::phaseSpread(s.timers());
    double boundary = double(s.engine().boundaryParticles()) / std::max<double>(1, double(s.numParticles()));
    MPI_Allreduce(MPI_IN_PLACE, &boundary, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    long long ghosts = (long long)s.engine().ghosts(), ghostSum = 0;
    MPI_Reduce(&ghosts, &ghostSum, 1, MPI_LONG_LONG, MPI_SUM, 0, MPI_COMM_WORLD);
    if (rank != 0) continue;
    const nlohmann::json phases = spread.mean(ranks), phasesMax = spread.largest();
    double mean = 0;
    for (double v : spread.sum) mean += v / ranks;
    const double comm = (spread.sum[std::size_t(Phase::kHalo)] + spread.sum[std::size_t(Phase::kMigrate)]) / ranks;
    long long owned = 0, busiest = 0;
    for (long long o : domain->ownedPerRank()) owned += o, busiest = std::max(busiest, o);
    const double rate = double(owned) * steps / wall;
    const std::string where = so.executor == pflow::compute::ExecutorKind::kCuda ? s.executorDescription() : device;
    nlohmann::json j{{"code", "pflow"}, {"executor", executor}, {"executor_description", s.executorDescription()},
                     {"ranks", ranks}, {"threads_per_rank", so.executor == pflow::compute::ExecutorKind::kCuda ? 0 : threads},
                     {"precision", precision}, {"decomposition", domain->strategyName()}, {"overlap", on}, {"canonical_order", mo.canonicalOrder},
                     {"case", "settled_bed_mono"}, {"n", owned}, {"per_rank", double(owned) / ranks},
                     {"busiest_over_mean", double(busiest) * ranks / double(owned)}, {"tiles", cfg.particles.size() / settled.n},
                     {"steps", steps}, {"wall_s", wall}, {"particle_steps_per_s", rate},
                     {"comm_share", mean > 0 ? comm / mean : 0.0}, {"ghosts_per_owned", double(ghostSum) / double(owned)},
                     {"boundary_share_mean", boundary / ranks}, {"rebuilds", s.rebuilds() - rebuilds0},
                     {"rebalances", domain->rebalances() - rebalances0}, {"phases_mean_s", phases},
                     {"phases_max_s", phasesMax}, {"settle_s", settleWall}, {"device", where}, {"commit", commit},
                     {"command", "mpirun -np " + std::to_string(ranks) + " " + cmdline.str()}};
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
    std::fprintf(stderr, "ranks %d %s overlap %s: %.3g particle-steps/s, comm %.1f %%, halo %.3g s, forces %.3g s (mean)\n",
                 ranks, executor.c_str(), on ? "on" : "off", rate, 100 * (mean > 0 ? comm / mean : 0.0),
                 spread.sum[std::size_t(Phase::kHalo)] / ranks, spread.sum[std::size_t(Phase::kForces)] / ranks);
  }
  owner.reset();
  MPI_Finalize();
  return 0;
}
