#include "bench/ReposeHeap.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "compute/dem/Simulation.h"
#include "frontend/SceneLoader.h"

namespace pflow::bench {

namespace {
constexpr double kPi = std::numbers::pi;
constexpr int kSegments = 64;  // around the cylinder

// The beads on a jittered lattice inside the cylinder, lowest layers first, until `count` are placed.
void fillCylinder(const ReposeOptions& o, compute::ParticleInit& p) {
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> rad(o.rMin, o.rMax), jit(-0.04 * o.spacing, 0.04 * o.spacing);
  const double rIn = o.cylinderRadius - o.rMax - 0.0005;
  const int n = int(2 * rIn / o.spacing);
  for (double z = o.roughness + o.rMax + 0.0002; p.size() < o.particles; z += o.spacing)
    for (int i = 0; i <= n && p.size() < o.particles; ++i)
      for (int j = 0; j <= n && p.size() < o.particles; ++j) {
        const double x = -rIn + i * o.spacing, y = -rIn + j * o.spacing;
        if (x * x + y * y > rIn * rIn) continue;
        p.position.push_back({x + jit(rng), y + jit(rng), z + jit(rng)});
        p.radius.push_back(rad(rng));
        p.material.push_back(0);
      }
}
}  // namespace

ReposeProfile reposeProfile(const compute::ParticleSnapshot& s, double bin, int quadrant) {
  ReposeProfile p;
  p.bin = bin;
  const Vec3d* x = s.find("position")->as<Vec3d>();
  const double* r = s.find("radius")->as<double>();
  for (std::size_t i = 0; i < s.n; ++i) {
    if (quadrant >= 0) {  // quadrant q spans -45..45 degrees about +x, +y, -x, -y
      const double a = std::atan2(x[i].y, x[i].x) + kPi / 4;
      if (int(std::floor((a < 0 ? a + 2 * kPi : a) / (kPi / 2))) % 4 != quadrant) continue;
    }
    const std::size_t k = std::size_t(std::hypot(x[i].x, x[i].y) / bin);
    if (k >= p.height.size()) p.height.resize(k + 1, std::numeric_limits<double>::quiet_NaN());
    const double top = x[i].z + r[i];
    if (!(p.height[k] >= top)) p.height[k] = top;  // NaN compares false: the first bead of a ring sets it
  }
  for (std::size_t k = 0; k < p.height.size(); ++k) p.radius.push_back((double(k) + 0.5) * bin);
  return p;
}

double reposeAngle(const ReposeProfile& p, double meanDiameter, double* from, double* to, double* heapRadius, double* heapHeight) {
  // The heap's radius: the first ring (from the axis) whose top is below 1.5 diameters.
  double radius = 0, height = 0;
  for (std::size_t k = 0; k < p.height.size(); ++k) {
    if (std::isnan(p.height[k]) || p.height[k] < 1.5 * meanDiameter) break;
    radius = p.radius[k] + 0.5 * p.bin;
    height = std::max(height, p.height[k]);
  }
  const double lo = 0.25 * radius, hi = 0.75 * radius;
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < p.height.size(); ++k) {
    if (std::isnan(p.height[k]) || p.radius[k] < lo || p.radius[k] > hi) continue;
    n += 1, sx += p.radius[k], sy += p.height[k], sxx += p.radius[k] * p.radius[k], sxy += p.radius[k] * p.height[k];
  }
  if (from) *from = lo;
  if (to) *to = hi;
  if (heapRadius) *heapRadius = radius;
  if (heapHeight) *heapHeight = height;
  if (n < 3) return std::numeric_limits<double>::quiet_NaN();
  const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  return std::atan(-slope) * 180 / kPi;
}

namespace {

// The plate (surface `surface`): flat, or a height field on a grid of 1.5 mean diameters with heights in
// [0, roughness]; a square of half-width L.
compute::MeshConfig plate(const ReposeOptions& o, double L, int material, int surface) {
  compute::MeshConfig floor;
  floor.name = "plate";
  floor.material = material;
  if (o.roughness <= 0) {
    floor.vertices = {{-L, -L, 0}, {L, -L, 0}, {L, L, 0}, {-L, L, 0}};
    floor.triangles = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise seen from above
  } else {
    std::mt19937_64 rng(o.seed + 1);
    std::uniform_real_distribution<double> bump(0, o.roughness);
    const int m = int(std::ceil(2 * L / (1.5 * (o.rMin + o.rMax))));
    const double g = 2 * L / m;
    for (int j = 0; j <= m; ++j)
      for (int i = 0; i <= m; ++i) floor.vertices.push_back({-L + i * g, -L + j * g, bump(rng)});
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i) {
        const std::uint32_t a = std::uint32_t(j * (m + 1) + i), b = a + 1, c = a + std::uint32_t(m + 1), d = c + 1;
        floor.triangles.push_back({a, b, d});
        floor.triangles.push_back({a, d, c});
      }
  }
  floor.surface.assign(floor.triangles.size(), surface);
  return floor;
}

// The poured pile's scene: the beads on a lattice in a funnel (a cone from the orifice up, then a cylinder of the
// lifted cylinder's radius), its orifice closed by a gate that slides away after the settling; the plate below.
Result<compute::RunConfig> pourScene(const ReposeOptions& o) {
  const double R = o.cylinderRadius, rIn = R - o.rMax - 0.0005, cone = R - o.orifice / 2, z0 = o.pourHeight;
  const double perLayer = kPi * rIn * rIn / (o.spacing * o.spacing), fill = double(o.particles) / perLayer * o.spacing;
  const double D = o.orifice;
  char buf[4096];
  std::snprintf(buf, sizeof buf, R"(materials:
  - {name: glass, youngs_modulus: %.6g, poisson_ratio: %.6g, density: %.6g, restitution: %.6g, friction: %.6g, rolling_friction: %.6g}
  - {name: plate, youngs_modulus: 2.0e8, poisson_ratio: 0.3, density: 7800, restitution: %.6g, friction: %.6g, rolling_friction: %.6g}
pairs:
  - {materials: [glass, plate], restitution: %.6g, friction: %.6g, rolling_friction: %.6g}
particles:
  - name: beads
    material: glass
    method: lattice
    region: {cylinder: {base: [0, 0, %.6g], axis: [0, 0, 1], radius: %.6g, height: %.6g}}
    size: {distribution: uniform, min: %.6g, max: %.6g}
    lattice: {spacing: %.6g, jitter: 0.04}
geometry:
  - name: funnel
    material: plate
    hopper: {orifice: [0, 0, %.6g], axis: [0, 0, 1], orifice_radius: %.6g, top_radius: %.6g, cone_height: %.6g,
             cylinder_height: %.6g}
  - name: gate
    material: plate
    box: {min: [%.6g, %.6g, %.6g], max: [%.6g, %.6g, %.6g], side: outside}
    motion: {velocity: [0.5, 0, 0], start_time: %.6g}
simulation:
  duration: %.6g
  precision: %s
)",
                o.youngs, o.poisson, o.density, o.restitution, o.friction, o.rolling, o.wallRestitution, o.wallFriction,
                o.wallRolling, o.wallRestitution, o.wallFriction, o.wallRolling, z0 + cone + 0.001, rIn, fill, o.rMin, o.rMax,
                o.spacing, z0, D / 2, R, cone, fill + 0.01, -D, -D, z0 - 0.004, D, D, z0 - 0.0001, o.settle,
                o.settle + o.pour + o.rest + 0.01, o.precision.c_str());
  auto loaded = frontend::loadSceneFromString(buf, "repose-pour");
  if (!loaded) return loaded.status();
  compute::RunConfig c = loaded->config;
  const int surface = int(c.surfaceNames.size());
  c.surfaceNames.push_back("plate");
  c.meshes.push_back(plate(o, 6 * R, 1, surface));
  return c;
}

// The lifted cylinder's scene: the beads on a lattice in a cylinder standing on the plate, lifted after the
// settling at liftSpeed by `lift`.
compute::RunConfig liftScene(const ReposeOptions& o) {
  compute::RunConfig c;
  compute::MaterialConfig bead;
  bead.name = "glass";
  bead.youngsModulus = o.youngs, bead.poissonRatio = o.poisson, bead.density = o.density;
  bead.restitution = o.restitution, bead.friction = o.friction, bead.rollingFriction = o.rolling;
  compute::MaterialConfig steel = bead;
  steel.name = "plate", steel.youngsModulus = 2e8, steel.poissonRatio = 0.3, steel.density = 7800;
  c.materials = {bead, steel};
  compute::MaterialPairConfig wall;
  wall.a = 0, wall.b = 1, wall.restitution = o.wallRestitution, wall.friction = o.wallFriction, wall.rollingFriction = o.wallRolling;
  c.pairs = {wall};
  fillCylinder(o, c.particles);
  double top = 0;
  for (const Vec3d& x : c.particles.position) top = std::max(top, x.z);
  compute::MeshConfig side;
  side.name = "cylinder";
  side.material = 1;
  const double height = top + o.rMax + 0.005;
  for (int b = 0; b <= 1; ++b)
    for (int s = 0; s < kSegments; ++s) {
      const double a = 2 * kPi * s / kSegments;
      side.vertices.push_back({o.cylinderRadius * std::cos(a), o.cylinderRadius * std::sin(a), b * height});
    }
  for (int s = 0; s < kSegments; ++s) {
    const std::uint32_t v0 = std::uint32_t(s), v1 = std::uint32_t((s + 1) % kSegments), w0 = v0 + kSegments, w1 = v1 + kSegments;
    side.triangles.push_back({v0, w1, v1});  // counter-clockwise seen from inside
    side.triangles.push_back({v0, w0, w1});
  }
  side.surface.assign(side.triangles.size(), 1);
  const double tLift = o.lift / o.liftSpeed;
  side.motion.startTime = o.settle;
  side.motion.profile = {{0.0, {0, 0, o.liftSpeed}}, {tLift, {0, 0, o.liftSpeed}}, {tLift + 1e-4, {0, 0, 0}}};
  c.surfaceNames = {"plate", "cylinder"};
  // The collapse spreads to about 3 cylinder radii (docs/accuracy.md, "Angle of repose").
  c.meshes = {plate(o, 6 * o.cylinderRadius, 1, 0), side};
  c.sim.gravity = {0, 0, -9.81};
  c.sim.duration = o.settle + tLift + o.rest + 0.01;
  c.sim.precision = o.precision == "float" ? compute::Precision::kFloat : compute::Precision::kDouble;
  c.sim.precisionGiven = true;
  return c;
}

}  // namespace

ReposeResult runRepose(const ReposeOptions& o, compute::ExecutorKind kind) {
  ReposeResult res;
  compute::RunConfig c;
  if (o.method == "pour") {
    auto scene = pourScene(o);
    if (!scene) {
      res.error = scene.status().toString();
      return res;
    }
    c = std::move(scene.value());
  } else {
    c = liftScene(o);
  }
  res.particles = c.particles.size();
  compute::SimulationOptions so;
  so.executor = kind;
  auto created = compute::Simulation::create(c, so);
  if (!created) {
    res.error = created.status().toString();
    return res;
  }
  compute::Simulation& sim = *created.value();
  const auto t0 = std::chrono::steady_clock::now();
  const double end = o.method == "pour" ? o.settle + o.pour + o.rest : o.settle + o.lift / o.liftSpeed + o.rest;
  for (double t = std::min(0.1, end);; t = std::min(t + 0.1, end)) {
    if (auto s = sim.runUntil(t); !s.isOk()) {
      res.error = s.toString();
      return res;
    }
    if (o.onProgress) o.onProgress(sim.time(), sim.stepCount(), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (t >= end) break;
  }
  res.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto snap = sim.snapshot({"position", "radius", "velocity"});
  const Vec3d* v = snap.find("velocity")->as<Vec3d>();
  const double* r = snap.find("radius")->as<double>();
  double dSum = 0;
  for (std::size_t i = 0; i < snap.n; ++i) {
    res.kineticEnergy += 0.5 * o.density * 4.0 / 3.0 * kPi * r[i] * r[i] * r[i] * norm2(v[i]);
    dSum += 2 * r[i];
  }
  const double d = dSum / double(snap.n), bin = 2 * d;
  res.profile = reposeProfile(snap, bin);
  res.angle = reposeAngle(res.profile, d, &res.fitFrom, &res.fitTo, &res.heapRadius, &res.heapHeight);
  double lo = 90, hi = 0;
  for (int q = 0; q < 4; ++q) {
    res.quadrant[std::size_t(q)] = reposeAngle(reposeProfile(snap, bin, q), d);
    lo = std::min(lo, res.quadrant[std::size_t(q)]), hi = std::max(hi, res.quadrant[std::size_t(q)]);
  }
  res.spread = hi >= lo ? hi - lo : std::numeric_limits<double>::quiet_NaN();  // NaN where a quadrant has no slope
  return res;
}

}  // namespace pflow::bench
