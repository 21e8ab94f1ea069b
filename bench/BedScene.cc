#include "bench/BedScene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <random>

#include "backend/store/SnapshotFile.h"

namespace pflow::bench {

compute::RunConfig bedScene(const BedSpec& s) {
  compute::RunConfig c;
  compute::MaterialConfig m;
  m.name = "bead";
  m.youngsModulus = 1e7;
  m.poissonRatio = 0.3;
  m.density = 2500;
  m.restitution = 0.5;
  m.friction = 0.5;
  m.rollingFriction = 0.0;
  c.materials = {m};
  const double a = s.spacing * s.diameter;
  std::mt19937_64 rng(s.seed);
  std::uniform_real_distribution<double> jit(-s.jitter * s.diameter, s.jitter * s.diameter);
  std::uniform_real_distribution<double> rad(s.diameter / 4, s.diameter / 2);
  const std::size_t n = std::size_t(s.nx) * s.ny * s.nz;
  c.particles.position.reserve(n);
  c.particles.radius.reserve(n);
  for (int k = 0; k < s.nz; ++k)
    for (int j = 0; j < s.ny; ++j)
      for (int i = 0; i < s.nx; ++i) {
        c.particles.position.push_back({(i + 0.5) * a + jit(rng), (j + 0.5) * a + jit(rng), (k + 0.5) * a + jit(rng)});
        c.particles.radius.push_back(s.polydisperse ? rad(rng) : s.diameter / 2);
      }
  c.particles.material.assign(n, 0);
  const double lx = s.nx * a, ly = s.ny * a;
  auto plane = [&](const char* name, Vec3d p, Vec3d nrm) {
    compute::PlaneConfig pl;
    pl.name = name;
    pl.point = p;
    pl.normal = nrm;
    pl.material = 0;
    c.planes.push_back(pl);
  };
  plane("floor", {0, 0, 0}, {0, 0, 1});
  plane("x_lo", {0, 0, 0}, {1, 0, 0});
  plane("x_hi", {lx, 0, 0}, {-1, 0, 0});
  plane("y_lo", {0, 0, 0}, {0, 1, 0});
  plane("y_hi", {0, ly, 0}, {0, -1, 0});
  c.sim.gravity = {0, 0, -9.81};
  c.sim.dt = s.dt;
  c.sim.skin = s.skin * s.diameter;
  c.sim.duration = 1.0;
  c.sim.threads = s.threads;
  c.sim.historySlots = s.polydisperse ? 16 : 8;
  // The bed only sinks: a domain from the floor to the top of the lattice.
  c.sim.domain = compute::Aabb{{0, 0, 0}, {lx, ly, s.nz * a + s.diameter}};
  return c;
}

compute::RunConfig tiledBed(const compute::RunConfig& bed, const compute::ParticleSnapshot& settled, int tx, int ty) {
  compute::RunConfig c = bed;
  const Vec3d lo = bed.sim.domain->lo, hi = bed.sim.domain->hi;
  const double lx = hi.x - lo.x, ly = hi.y - lo.y;
  const std::size_t n = settled.n;
  const auto* x = settled.find("position")->as<Vec3d>();
  const auto* v = settled.find("velocity")->as<Vec3d>();
  const auto* w = settled.find("angular_velocity")->as<Vec3d>();
  const auto* r = settled.find("radius")->as<double>();
  auto& p = c.particles;
  p = {};
  const std::size_t total = n * std::size_t(tx) * std::size_t(ty);
  p.position.reserve(total);
  p.velocity.reserve(total);
  p.angularVelocity.reserve(total);
  p.radius.reserve(total);
  for (int b = 0; b < ty; ++b)
    for (int a = 0; a < tx; ++a)
      for (std::size_t k = 0; k < n; ++k) {
        p.position.push_back(x[k] + Vec3d{a * lx, b * ly, 0});
        p.velocity.push_back(v[k]);
        p.angularVelocity.push_back(w[k]);
        p.radius.push_back(r[k]);
      }
  p.material.assign(total, 0);
  for (auto& pl : c.planes) {
    if (pl.name == "x_hi") pl.point.x = lo.x + tx * lx;
    if (pl.name == "y_hi") pl.point.y = lo.y + ty * ly;
  }
  c.sim.domain = compute::Aabb{lo, {lo.x + tx * lx, lo.y + ty * ly, hi.z}};
  return c;
}

std::vector<std::pair<std::string, double>> compulsoryTraffic(int realBytes, double candidates, double contacts) {
  const double R = realBytes, pos = 24;  // positions are double at both precisions
  // integrate1: read x, v, w, F, T, m, r and the float displacement since rebuild; write x, v, w and it.
  const double integrate1 = 2 * pos + 3 * R * 4 + 2 * R + 2 * 12 + 3 * R * 2;
  // forces: own x, v, w, r, m, material, row start (the row's end is the next row's start); per candidate an index
  // and a slot byte; per contact its history read and written; F and T written; the wall kernel's plane mask (the
  // bed has planes alone: no triangle candidates to count).
  const double forces = pos + 8 * R + 4 + 4 + 5 * candidates + 6 * R * contacts + 6 * R + 4;
  // integrate2: read x (finite check), v, w, F, T, m, r; write v, w.
  const double integrate2 = pos + 3 * R * 4 + 2 * R + 3 * R * 2;
  return {{"integrate1", integrate1}, {"forces", forces}, {"integrate2", integrate2}};
}

BedSpec bedSpecFor(std::int64_t n, bool polydisperse) {
  BedSpec s;
  s.polydisperse = polydisperse;
  const int side = std::max(1, int(std::lround(std::sqrt(double(n) / s.nz))));
  s.nx = s.ny = side;
  return s;
}

compute::RunConfig tiledBed(const compute::RunConfig& bed, const compute::ParticleSnapshot& settled, long n) {
  const double copies = std::max(1.0, double(n) / double(std::max<std::size_t>(settled.n, 1)));
  int tx = 1, ty = 1;
  double best = 1e300;
  for (int a = 1; a <= int(std::ceil(std::sqrt(copies))) + 1; ++a) {
    const int b = std::max(1, int(std::lround(copies / a)));
    const double miss = std::fabs(double(a) * b - copies) + 1e-3 * std::abs(a - b);
    if (miss < best) best = miss, tx = std::max(a, b), ty = std::min(a, b);
  }
  return tiledBed(bed, settled, tx, ty);
}

compute::RunConfig withState(compute::RunConfig cfg, const compute::ParticleSnapshot& state) {
  const auto* x = state.find("position")->as<Vec3d>();
  const auto* v = state.find("velocity")->as<Vec3d>();
  const auto* w = state.find("angular_velocity")->as<Vec3d>();
  const auto* id = state.find("id")->as<Gid>();
  cfg.particles.velocity.resize(cfg.particles.size());
  cfg.particles.angularVelocity.resize(cfg.particles.size());
  for (std::size_t k = 0; k < state.n; ++k) {
    cfg.particles.position[id[k]] = x[k];
    cfg.particles.velocity[id[k]] = v[k];
    cfg.particles.angularVelocity[id[k]] = w[k];
  }
  return cfg;
}

std::string settledBedPath(const std::string& dir, long size, bool polydisperse, int settleSteps, const std::string& executor) {
  return dir + "/settled-" + std::to_string(size) + (polydisperse ? "-poly-" : "-mono-") + std::to_string(settleSteps) +
         "-" + executor + ".h5";
}

Status saveSettledBed(const std::string& path, const compute::ParticleSnapshot& state) {
  auto writer = backend::SnapshotWriter::create(path);
  if (!writer) return writer.status();
  return writer.value()->writeSnapshot(state);
}

bool loadSettledBed(const std::string& path, compute::ParticleSnapshot& out) {
  if (!std::filesystem::exists(path)) return false;
  auto reader = backend::SnapshotReader::open(path);
  if (!reader || reader.value()->steps().empty()) return false;
  auto state = reader.value()->read(reader.value()->steps().back());
  if (!state) return false;
  out = std::move(state).value();
  return true;
}

}  // namespace pflow::bench
