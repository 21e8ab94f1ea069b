#include "bench/accuracy/SphStudy.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "common/Log.h"
#include "compute/sph/SphSimulation.h"
#include "tests/support/SphScenes.h"

namespace pflow::bench::accuracy {
namespace {

namespace fs = std::filesystem;
using compute::sph::SphSimulation;

struct Run {
  std::string sweep;  // resolution | dt
  std::string resolution;
  double dp = 0, dt = 0;  // dt 0: the CFL step
  std::string status = "ok", detail;
  std::size_t particles = 0;
  std::int64_t steps = 0;
  double simTime = 0, wall = 0;
  std::vector<double> T;                       // per kFrontZ (NaN: not reached)
  std::vector<std::pair<double, double>> curve;  // (T, Z)
};

std::string resolutionName(double dp) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%dx%d", int(std::lround(0.2 / dp)), int(std::lround(0.4 / dp)));
  return buf;
}

// The dam break to Z = 4 (or t = 0.6 s): the front every step (one device reduction), its crossing times of
// kFrontZ, the curve sampled every 0.02 in T, the wall time of the stepping alone.
Run runOne(const SphStudyOptions& o, const std::string& sweep, double dp, double dt, bool mirror = false) {
  Run r;
  r.sweep = sweep;
  r.resolution = resolutionName(dp);
  r.dp = dp;
  r.dt = dt;
  r.T.assign(test::kFrontZ.size(), std::nan(""));
  compute::RunConfig c = test::damBreak2D(dp, 0.6);
  if (mirror) c = test::withMirrorWalls(c);
  c.sim.precision = o.precision;
  c.sim.threads = o.threads;
  if (dt > 0) c.sph.dt = dt;
  compute::sph::SphOptions so;
  so.executor = o.executor;
  auto created = SphSimulation::create(c, so);
  if (!created) {
    r.status = "error";
    r.detail = created.status().message();
    return r;
  }
  SphSimulation& sim = *created.value();
  r.particles = sim.numParticles();
  const double a = 0.2, scale = std::sqrt(2 * 9.81 / a);
  double lastT = 0, lastZ = (sim.fluidReach({1, 0, 0}) + 0.5 * dp) / a, nextSample = 0;
  std::size_t next = 0;
  r.curve.emplace_back(0.0, lastZ);
  const auto start = std::chrono::steady_clock::now();
  Status s = sim.runUntil(0.6, [&](const SphSimulation& run) -> Status {
    const double T = run.time() * scale, Z = (run.fluidReach({1, 0, 0}) + 0.5 * dp) / a;
    while (next < test::kFrontZ.size() && Z >= test::kFrontZ[next]) {
      const double f = Z > lastZ ? (test::kFrontZ[next] - lastZ) / (Z - lastZ) : 1.0;
      r.T[next] = lastT + f * (T - lastT);
      ++next;
    }
    if (T >= nextSample) {
      r.curve.emplace_back(T, Z);
      nextSample = T + 0.02;
    }
    lastT = T;
    lastZ = Z;
    return Z >= 4.0 ? Status(StatusCode::kCancelled, "front at Z = 4") : Status::ok();
  });
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.steps = sim.stepCount();
  r.simTime = sim.time();
  if (!s.isOk() && s.code() != StatusCode::kCancelled) {
    r.detail = s.message();
    r.status = s.message().rfind("density out of range", 0) == 0 ? "density out of range"
               : s.message().rfind("non-finite", 0) == 0     ? "non-finite"
               : s.message().rfind("leak", 0) == 0           ? "leak"
                                                             : "error";
  }
  return r;
}

double rmsRelativeError(const Run& r) {
  double sum = 0;
  int n = 0;
  for (std::size_t k = 0; k < r.T.size(); ++k) {
    if (!std::isfinite(r.T[k])) return std::nan("");
    const double e = r.T[k] / test::kMartinMoyceT[k] - 1;
    sum += e * e;
    ++n;
  }
  return n ? std::sqrt(sum / n) : std::nan("");
}

// Keeps the rows of `file` that this run does not replace: another executor's (column 4), or a sweep (column 0)
// not run now. Header excluded.
std::vector<std::string> otherRows(const fs::path& file, const std::string& executor, const std::set<std::string>& sweeps) {
  std::vector<std::string> keep;
  std::ifstream in(file);
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (header) {
      header = false;
      continue;
    }
    std::stringstream ss(line);
    std::vector<std::string> cells;
    for (std::string cell; cells.size() < 5 && std::getline(ss, cell, ',');) cells.push_back(cell);
    if (cells.size() < 5 || cells[4] != executor || !sweeps.count(cells[0])) keep.push_back(line);
  }
  return keep;
}

}  // namespace

int runSphStudy(const SphStudyOptions& o) {
  const std::string executor = o.executor == compute::ExecutorKind::kCuda ? "cuda" : "cpu";
  const std::string precision = o.precision == compute::Precision::kFloat ? "float" : "double";
  std::vector<Run> runs;
  // The resolution ladder at the CFL step, every other parameter as in examples/dam_break_2d.yaml.
  std::vector<double> ladder = {0.01, 0.005, 0.004, 0.002, 0.001};
  if (o.quick) ladder = {0.01, 0.005};
  auto wanted = [&](const std::string& sweep) { return o.only.empty() || o.only == sweep; };
  std::set<std::string> sweeps;
  if (wanted("resolution"))
    for (double dp : ladder) runs.push_back(runOne(o, "resolution", dp, 0)), sweeps.insert("resolution");
  // The same ladder with the tank's walls as mirrors (sph.boundary: mirror).
  if (wanted("mirror"))
    for (double dp : ladder) runs.push_back(runOne(o, "mirror", dp, 0, true)), sweeps.insert("mirror");
  // Seed 002's sweeps: dt at 20 x 40, and the particle count at dt = 1e-5 s.
  if (!o.quick) {
    // The seed's four steps, then larger ones until the run fails (the CFL limit at 20 x 40 is 7.6e-5 s).
    if (wanted("dt"))
      for (double dt : {5e-4, 4e-4, 3e-4, 2e-4, 1.5e-4, 1e-4, 5e-5, 1e-5, 5e-6}) runs.push_back(runOne(o, "dt", 0.01, dt)), sweeps.insert("dt");
    if (wanted("particles_at_1e-5"))
      for (double dp : {0.01, 0.005, 0.004, 0.002, 0.001})
        runs.push_back(runOne(o, "particles_at_1e-5", dp, 1e-5)), sweeps.insert("particles_at_1e-5");
  }
  fs::create_directories(o.out);
  const fs::path conv = fs::path(o.out) / "convergence.csv";
  std::vector<std::string> keep = otherRows(conv, executor, sweeps);
  {
    std::ofstream f(conv);
    f << "sweep,resolution,dp,dt,executor,precision,status,particles,steps,sim_time,wall_s,wall_per_sim_s";
    for (double z : test::kFrontZ) f << ",T_" << z;
    f << ",rms_rel_err\n";
    for (const auto& line : keep) f << line << "\n";
    for (const Run& r : runs) {
      char buf[512];
      std::snprintf(buf, sizeof buf, "%s,%s,%.6g,%.6g,%s,%s,%s,%zu,%lld,%.6g,%.6g,%.6g", r.sweep.c_str(), r.resolution.c_str(), r.dp,
                    r.dt, executor.c_str(), precision.c_str(), r.status.c_str(), r.particles, (long long)r.steps, r.simTime, r.wall,
                    r.simTime > 0 ? r.wall / r.simTime : 0.0);
      f << buf;
      for (double t : r.T) f << "," << t;
      f << "," << rmsRelativeError(r) << "\n";
    }
  }
  // The front curves of each ladder run now: dam_break_2d.csv (boundary particles), dam_break_2d_mirror.csv.
  for (const std::string sweep : {"resolution", "mirror"}) {
    if (!sweeps.count(sweep)) continue;
    std::ofstream f(fs::path(o.out) / (sweep == "mirror" ? "dam_break_2d_mirror.csv" : "dam_break_2d.csv"));
    f << "resolution,T,Z\n";
    for (const Run& r : runs)
      if (r.sweep == sweep)
        for (const auto& [T, Z] : r.curve) f << r.resolution << "," << T << "," << Z << "\n";
  }
  std::printf("%-18s %-9s %-9s %-8s %9s %8s %9s", "sweep", "res", "dt", "status", "particles", "steps", "wall/sim");
  for (double z : test::kFrontZ) std::printf("  T(Z=%.1f)", z);
  std::printf("  rms\n");
  for (const Run& r : runs) {
    std::printf("%-18s %-9s %-9.3g %-8s %9zu %8lld %9.4g", r.sweep.c_str(), r.resolution.c_str(), r.dt, r.status.c_str(), r.particles,
                (long long)r.steps, r.simTime > 0 ? r.wall / r.simTime : 0.0);
    for (std::size_t k = 0; k < r.T.size(); ++k) std::printf("  %5.3f %+5.1f%%", r.T[k], 100 * (r.T[k] / test::kMartinMoyceT[k] - 1));
    std::printf("  %.3f\n", rmsRelativeError(r));
    if (!r.detail.empty()) std::printf("    %s\n", r.detail.c_str());
  }
  std::printf("experiment (Martin & Moyce 1952, a = 2.25 in):");
  for (double t : test::kMartinMoyceT) std::printf(" %.3f", t);
  std::printf("\nwrote %s and the front curves in %s\n", conv.c_str(), o.out.c_str());
  return 0;
}

}  // namespace pflow::bench::accuracy
