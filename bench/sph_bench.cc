// pflow-sph-bench: SPH throughput (docs/sph.md, "Performance"): a scene file (default SPHERIC test 2,
// examples/dam_break_3d.yaml) at the spacings asked for, on either executor and precision. Each size: the
// scene built, `--warmup` steps, then `--steps` timed steps; one JSON line per size with N, ms per step,
// particle-steps/s, the phase times, device bytes per particle and the compulsory bytes per particle-step
// against --copy-bandwidth (pflow-gpu-bandwidth's figure). Under mpirun the scene is split across the ranks
// (compute/mpi's MpiDomain, particle-count balance), with the halo overlapped with the interior rates or in
// sequence (--overlap on|off: seed 003's boundary/centre overlap); rank 0 prints. bench/RESULTS.md records the rows.
// --variants walk,masks,twophase,walk_once,twophase_once times the rates passes one after another from the same flow (a line each); without it
// the engine's own choice is timed (--not-reproducible: the pairs once on one GPU, as simulation.reproducible: false); --split-steps
// times that many more steps one at a time, the rates pass after a sort (the marking pass) apart from the others.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "bench/BenchMpi.h"
#include "bench/BenchUtil.h"
#include "common/Log.h"
#include "compute/mpi/MpiDomain.h"
#include "compute/sph/SphSimulation.h"
#include "bench/SphSceneAt.h"

using namespace pflow;

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  struct Finalize {
    ~Finalize() { MPI_Finalize(); }
  } finalize;
  CLI::App app{"pflow-sph-bench: SPH particle-steps per second on a scene at several resolutions"};
  std::string scene = "examples/dam_break_3d.yaml", executor = "cuda", precision = "float", device, commit;
  std::vector<double> spacings = {0.02};
  int warmup = 20, steps = 100, threads = 0;
  double bandwidth = 0;
  std::string overlap = "on", integrator = "scene";
  double advance = 0;
  std::optional<double> skin;
  bool masks = false, notReproducible = false;
  int splitSteps = 0;
  std::vector<std::string> variants;
  std::string decomposition = "scene";
  app.add_option("--scene", scene, "an SPH scene file")->capture_default_str();
  app.add_option("--spacing", spacings, "particle spacings dp [m], one run each (the scene's sph.spacing replaced)")->delimiter(',');
  app.add_option("--executor", executor, "cpu | cuda")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.add_option("--precision", precision, "float | double")->check(CLI::IsMember({"float", "double"}))->capture_default_str();
  app.add_option("--warmup", warmup, "steps before timing")->capture_default_str();
  app.add_option("--steps", steps, "timed steps")->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads (0: all)");
  app.add_option("--copy-bandwidth", bandwidth, "measured device copy bandwidth [GB/s] (pflow-gpu-bandwidth)");
  app.add_option("--device", device, "device name for the record");
  app.add_option("--commit", commit, "commit for the record");
  app.add_option("--overlap", overlap, "distributed runs: the halo overlapped with the interior rates (on) or not")
      ->check(CLI::IsMember({"on", "off"}))->capture_default_str();
  app.add_option("--integrator", integrator, "the scene's time integration, or symplectic | verlet | velocity_verlet instead")
      ->check(CLI::IsMember({"scene", "symplectic", "verlet", "velocity_verlet"}))->capture_default_str();
  app.add_option("--advance", advance, "simulated seconds run before the warm-up (time the flow, not the start at rest)")
      ->capture_default_str();
  app.add_option("--decomposition", decomposition, "distributed runs: the scene's simulation.decomposition, or sfc | multisection")
      ->check(CLI::IsMember({"scene", "sfc", "multisection"}))->capture_default_str();
  app.add_option("--skin", skin, "the neighbour skin as a fraction of h instead of the scene's sph.skin");
  app.add_option("--split-steps", splitSteps,
                 "after the timed steps, this many more one at a time: the rates pass's time in the steps that sorted "
                 "(and marked hit masks) apart from the others")->capture_default_str();
  app.add_option("--variants", variants,
                 "rates passes timed one after another from the same flow, a JSON line each: walk (in one phase) | masks "
                 "(instead of --masks) | twophase (the walk's tests, then its pairs in one loop: the GPU's default in float) | "
                 "walk_once, twophase_once (either walk with each pair evaluated once, as --not-reproducible)")
      ->delimiter(',')->check(CLI::IsMember({"walk", "masks", "twophase", "walk_once", "twophase_once"}));
  app.add_flag("--not-reproducible", notReproducible,
               "simulation.reproducible: false (one GPU: each pair evaluated once, the partner's share by atomic adds)");
  app.add_flag("--masks", masks, "the rates pass reads hit masks built at each sort (SphConfig::hitMasks)");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);
  const compute::NodeRanks node = compute::nodeRanks(MPI_COMM_WORLD);
  const int gpus = executor == "cuda" ? compute::cudaDeviceCount() : 0;
  for (double dp : spacings) {
    auto loaded = bench::loadSphSceneAt(scene, dp);
    if (!loaded) {
      std::fprintf(stderr, "%s\n", loaded.status().message().c_str());
      return 1;
    }
    compute::RunConfig cfg = loaded.value();
    cfg.sim.precision = precision == "float" ? compute::Precision::kFloat : compute::Precision::kDouble;
    cfg.sim.threads = threads;
    if (integrator != "scene")
      for (auto i : {compute::sph::Integrator::kSymplectic, compute::sph::Integrator::kVerlet, compute::sph::Integrator::kVelocityVerlet})
        if (integrator == compute::sph::integratorName(i)) cfg.sph.integrator = i;
    const bool verlet = cfg.sph.integrator == compute::sph::Integrator::kVerlet;
    const bool kdk = cfg.sph.integrator == compute::sph::Integrator::kVelocityVerlet;
    if (skin) cfg.sph.skin = *skin;
    cfg.sph.hitMasks = masks;
    if (notReproducible) cfg.sim.reproducible = false;
    const compute::DecompositionKind strategy = decomposition == "scene" ? cfg.sim.decomposition
                                                : decomposition == "sfc"  ? compute::DecompositionKind::kSfc
                                                                          : compute::DecompositionKind::kMultiSection;
    compute::sph::SphOptions so;
    so.executor = executor == "cuda" ? compute::ExecutorKind::kCuda : compute::ExecutorKind::kCpu;
    if (so.executor == compute::ExecutorKind::kCuda) {  // one GPU a rank: the rank's index on its node
      if (gpus == 0) {
        std::fprintf(stderr, "--executor cuda: no GPU visible\n");
        return 1;
      }
      so.device = node.rank % gpus;
    }
    if (ranks > 1) {
      compute::MpiDomainOptions split;
      split.cost = compute::MpiDomainOptions::Cost::kCount;
      split.strategy = strategy;
      so.domain = std::make_shared<compute::MpiDomain>(MPI_COMM_WORLD, split);
    }
    so.overlapHalo = overlap == "on";
    auto created = compute::sph::SphSimulation::create(cfg, so);
    if (!created) {
      std::fprintf(stderr, "%s\n", created.status().message().c_str());
      return 1;
    }
    auto& sim = *created.value();
    MPI_Barrier(MPI_COMM_WORLD);
    if (advance > 0)
      if (Status s = sim.runUntil(advance); !s.isOk()) {
        std::fprintf(stderr, "%s\n", s.message().c_str());
        return 3;
      }
    const bool chosen = variants.empty();  // the engine's own passes, as a run of the scene takes them
    if (chosen) variants.push_back(masks ? "masks" : "default");
    for (const std::string& variant : variants) {
      if (!chosen)
        sim.engine().setRatePasses(variant == "masks", variant.rfind("twophase", 0) == 0, variant.find("_once") != std::string::npos);
      if (Status s = sim.runSteps(warmup); !s.isOk()) {
        std::fprintf(stderr, "%s\n", s.message().c_str());
        return 3;
      }
      sim.engine().fence();
      MPI_Barrier(MPI_COMM_WORLD);
      sim.timers().reset();
      const std::int64_t sortsBefore = sim.rebuilds();
      const auto start = std::chrono::steady_clock::now();
      if (Status s = sim.runSteps(steps); !s.isOk()) {
        std::fprintf(stderr, "%s\n", s.message().c_str());
        return 3;
      }
      sim.engine().fence();
      MPI_Barrier(MPI_COMM_WORLD);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const double n = double(sim.totalParticles());
      // Compulsory traffic of one step, in bytes of the field table at the run's precision. Symplectic: two rate
      // passes (each reads position, velocity, density, pressure, mass, kind and writes acceleration, density rate,
      // viscous rate) and the two halves (each reads and writes the state and its copy at the start). Verlet: one
      // pass and one update (reads the state, the one before and the rates; writes both states and the pressure).
      const double r = precision == "float" ? 4 : 8;
      const double pass = 8 * 3 + 3 * r + r + r + r + 4 + (3 * r + r + r);
      const double halves = 2 * (2 * (24 + 3 * r + r) + 3 * r + r + r + 4);
      const double update = (24 + 6 * r + 2 * r + 3 * r + r + 4) + (24 + 6 * r + 2 * r + r);
      // Velocity Verlet: one pass, the kick and drift (reads x, v, a, rho, drho, kind, the sort's x; writes x, v, the
      // half-step v and rho, rho, p) and the second kick (reads the half-step v and rho, the rates, kind, x, the sort's
      // x; writes x, v, rho, p).
      const double kickDrift = (24 + 3 * r + 3 * r + r + r + 4 + 24) + (24 + 3 * r + 3 * r + r + r + r);
      const double kick = (r + r + 3 * r + 3 * r + 4 + 24 + 24) + (24 + 3 * r + r + r);
      // Each pair once: the pass writes the viscous rate only (not acceleration and density rate: 4 r less) and adds
      // into 16-byte rows of sums (each read and written at least once: 8 r), which FinishRates reads with the kind,
      // writes into the rates and zeroes, once per evaluation.
      const double finish = sim.engine().pairsOnce() ? (-4 * r + 8 * r) + (4 * r + 4 + 3 * r + r + 4 * r) : 0;
      const double evaluations = verlet || kdk ? 1 : 2;
      const double bytesPerStep = (verlet ? pass + update : kdk ? pass + kickDrift + kick : 2 * pass + halves) + evaluations * finish;
      nlohmann::json j{{"solver", "sph"},
                       {"case", scene},
                       {"executor", executor},
                       {"precision", precision},
                       {"integrator", compute::sph::integratorName(cfg.sph.integrator)},
                       {"spacing", dp},
                       {"n", sim.totalParticles()},
                       {"ranks", ranks},
                       {"gpus", executor == "cuda" ? std::min(ranks, gpus) : 0},
                       {"threads", threads},
                       {"overlap", overlap},
                       {"decomposition", strategy == compute::DecompositionKind::kSfc ? "sfc" : "multisection"},
                       {"fluid", sim.fluidParticles()},
                       {"steps", steps},
                       {"ms_per_step", 1e3 * wall / steps},
                       {"particle_steps_per_s", n * steps / wall},
                       {"sim_time", sim.time()},
                       {"dt", sim.dt()},
                       {"cell_sorts", sim.rebuilds() - sortsBefore},
                       {"advance_s", advance},
                       {"skin", cfg.sph.skin},
                       {"hit_masks", variant == "masks"},
                       {"rate_pass", variant},
                       {"pairs_once", sim.engine().pairsOnce()},
                       {"rate_pass_taken", sim.engine().lastRatePass()},
                       {"reproducible", cfg.sim.reproducible},
                       {"device_bytes_per_particle", double(sim.deviceBytes()) / n},
                       {"compulsory_bytes_per_particle_step", bytesPerStep},
                       {"device", device},
                       {"commit", commit.empty() ? std::string("unknown") : commit},
                       {"date", bench::today()}};
      if (bandwidth > 0) j["fraction_of_copy_bandwidth"] = bytesPerStep * n * steps / wall / (bandwidth * 1e9);
      nlohmann::json phases;
      for (int p = 0; p < int(compute::Phase::kCount); ++p)
        if (sim.timers().seconds(compute::Phase(p)) > 0) phases[compute::kPhaseNames[p]] = sim.timers().seconds(compute::Phase(p));
      j["phases_s"] = phases;  // rank 0's
      if (splitSteps > 0) {
        // The forces phase (the rates pass; fenced) of each step, summed apart for the steps whose rates followed a
        // sort (with --masks, the marking pass) and the others (the masks read, or the walk).
        double sorted = 0, plain = 0;
        int nSorted = 0, nPlain = 0;
        for (int i = 0; i < splitSteps; ++i) {
          const double before = sim.timers().seconds(compute::Phase::kForces);
          const std::int64_t sorts = sim.rebuilds();
          if (Status s = sim.runSteps(1); !s.isOk()) {
            std::fprintf(stderr, "%s\n", s.message().c_str());
            return 3;
          }
          const double t = sim.timers().seconds(compute::Phase::kForces) - before;
          if (sim.rebuilds() != sorts) sorted += t, ++nSorted;
          else plain += t, ++nPlain;
        }
        j["split"] = {{"steps", splitSteps},
                      {"after_sort", nSorted},
                      {"forces_ms_after_sort", nSorted ? 1e3 * sorted / nSorted : 0.0},
                      {"between_sorts", nPlain},
                      {"forces_ms_between_sorts", nPlain ? 1e3 * plain / nPlain : 0.0}};
      }
      if (ranks > 1) {  // each phase's largest over the ranks (the busiest rank sets the pace)
        const auto& domain = static_cast<const compute::MpiDomain&>(*so.domain);
        j["phases_max_s"] = bench::phaseSpread(sim.timers()).largest();
        j["owned_per_rank"] = domain.ownedPerRank();  // at the last rebuild (or the scene's partition)
        // Rank 0's rebuilds, where their time went (MpiDomain::rebuildTimes), and its ghosts.
        const auto& t = domain.rebuildTimes();
        j["rebuild_s"] = {{"rebuilds", t.rebuilds}, {"positions", t.positions}, {"weights", t.weights}, {"balance", t.balance},
                          {"owners", t.owners}, {"migration", t.migration}, {"halo_rows", t.haloRows}, {"ghosts", t.ghosts}};
        j["rebalances"] = domain.rebalances();
        j["ghosts"] = sim.engine().ghosts();
      }
      if (rank == 0) {
        std::printf("%s\n", j.dump().c_str());
        std::fflush(stdout);
      }
    }  // variants
  }
  return 0;
}
