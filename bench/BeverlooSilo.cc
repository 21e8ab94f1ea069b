#include "bench/BeverlooSilo.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "compute/dem/Simulation.h"
#include "frontend/SceneLoader.h"

namespace pflow::bench {

std::string beverlooScene(const BeverlooOptions& o, double D) {
  char buf[4096];
  std::snprintf(buf, sizeof buf, R"(materials:
  - {name: glass, youngs_modulus: %.6g, poisson_ratio: 0.25, density: 2500, restitution: %.6g, friction: %.6g, rolling_friction: %.6g}
  - {name: steel, youngs_modulus: 2.0e8, poisson_ratio: 0.3, density: 7800, restitution: 0.5, friction: %.6g}
particles:
  - name: beads
    material: glass
    method: lattice
    region: {cylinder: {base: [0, 0, 0.003], axis: [0, 0, 1], radius: %.6g, height: %.6g}}
    size: {distribution: uniform, min: %.6g, max: %.6g}
    lattice: {spacing: %.6g, jitter: 0.04}
geometry:
  - name: silo
    material: steel
    hopper: {orifice: [0, 0, 0], axis: [0, 0, 1], orifice_radius: %.6g, top_radius: %.6g, cone_height: 0.001,
             cylinder_height: %.6g, resolution: 0.004}
  - name: gate
    material: steel
    box: {min: [%.6g, %.6g, -0.004], max: [%.6g, %.6g, -0.0001], side: outside}
    motion: {velocity: [0.5, 0, 0], start_time: %.6g}
  - name: floor
    material: steel
    plane: {point: [0, 0, -0.3], normal: [0, 0, 1]}
simulation:
  duration: %.6g
  precision: %s
)",
                o.youngs, o.restitution, o.friction, o.rolling, o.friction, o.siloRadius - o.rMax - 0.0005, o.fillHeight,
                o.rMin, o.rMax, o.spacing, D / 2, o.siloRadius, o.fillHeight + 0.01, -D, -D, D, D, o.settle,
                o.settle + o.transient + o.window + 0.1, o.precision.c_str());
  return buf;
}

BeverlooRow runBeverloo(const BeverlooOptions& o, double D, compute::ExecutorKind kind) {
  BeverlooRow r;
  r.D = D;
  auto loaded = frontend::loadSceneFromString(beverlooScene(o, D), "beverloo");
  if (!loaded) {
    r.error = loaded.status().toString();
    return r;
  }
  const compute::RunConfig& c = loaded->config;
  r.particles = c.particles.size();
  double dsum = 0;
  for (double rad : c.particles.radius) dsum += 2 * rad;
  r.meanDiameter = dsum / double(r.particles);
  compute::SimulationOptions so;
  so.executor = kind;
  auto created = compute::Simulation::create(c, so);
  if (!created) {
    r.error = created.status().toString();
    return r;
  }
  compute::Simulation& sim = *created.value();
  const auto t0 = std::chrono::steady_clock::now();
  if (auto s = sim.runUntil(o.settle); !s.isOk()) {
    r.error = s.toString();
    return r;
  }
  // Bulk density of the settled bed's core (the bed's height: the 98th percentile of the centres).
  {
    const auto snap = sim.snapshot({"position", "radius"});
    const Vec3d* x = snap.find("position")->as<Vec3d>();
    std::vector<double> z;
    for (std::size_t i = 0; i < snap.n; ++i) z.push_back(x[i].z);
    std::sort(z.begin(), z.end());
    r.bulkDensity = coreBulkDensity(snap, 0.5 * o.siloRadius, z[std::size_t(0.98 * double(z.size()))], 2500);
  }
  // The mass below the orifice's plane, sampled every 10 ms over the window after the transient; W its slope.
  const Vec3d point{0, 0, -0.001}, normal{0, 0, -1};
  if (auto s = sim.runUntil(o.settle + o.transient); !s.isOk()) {
    r.error = s.toString();
    return r;
  }
  std::vector<double> ts, ms;
  for (double t = o.settle + o.transient; t <= o.settle + o.transient + o.window + 1e-9; t += 0.01) {
    if (auto s = sim.runUntil(t); !s.isOk()) {
      r.error = s.toString();
      return r;
    }
    ts.push_back(sim.time());
    ms.push_back(sim.engine().massPastPlane(point, normal));
  }
  double st = 0, sm = 0, stt = 0, stm = 0;
  const double n = double(ts.size());
  for (std::size_t k = 0; k < ts.size(); ++k) st += ts[k], sm += ms[k], stt += ts[k] * ts[k], stm += ts[k] * ms[k];
  r.W = (n * stm - st * sm) / (n * stt - st * st);
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

double coreBulkDensity(const compute::ParticleSnapshot& s, double coreRadius, double top, double rho) {
  const Vec3d* x = s.find("position")->as<Vec3d>();
  const double* r = s.find("radius")->as<double>();
  const double lo = 0.25 * top, hi = 0.75 * top;
  double vol = 0;
  for (std::size_t i = 0; i < s.n; ++i)
    if (x[i].z > lo && x[i].z < hi && x[i].x * x[i].x + x[i].y * x[i].y < coreRadius * coreRadius)
      vol += 4.0 / 3.0 * std::numbers::pi * r[i] * r[i] * r[i];
  return rho * vol / (std::numbers::pi * coreRadius * coreRadius * (hi - lo));
}

BeverlooFit fitBeverloo(const std::vector<BeverlooRow>& rows) {
  BeverlooFit f;
  if (rows.size() < 2) return f;
  for (const BeverlooRow& r : rows) f.bulkDensity += r.bulkDensity / double(rows.size()), f.meanDiameter += r.meanDiameter / double(rows.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = double(rows.size());
  for (const BeverlooRow& r : rows) {
    const double y = std::pow(r.W, 0.4);
    sx += r.D, sy += y, sxx += r.D * r.D, sxy += r.D * y;
  }
  const double a = (n * sxy - sx * sy) / (n * sxx - sx * sx), b = (sy - a * sx) / n;
  const double g = 9.81;
  f.C = std::pow(a, 2.5) / (f.bulkDensity * std::sqrt(g));
  f.k = -b / (a * f.meanDiameter);
  for (const BeverlooRow& r : rows)
    f.worstResidual = std::max(f.worstResidual, std::fabs(f.C * f.bulkDensity * std::sqrt(g) * std::pow(r.D - f.k * f.meanDiameter, 2.5) / r.W - 1));
  f.ok = std::isfinite(f.C) && std::isfinite(f.k);
  return f;
}

}  // namespace pflow::bench
