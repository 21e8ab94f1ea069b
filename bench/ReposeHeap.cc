#include "bench/ReposeHeap.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "compute/dem/Simulation.h"

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

ReposeResult runRepose(const ReposeOptions& o, compute::ExecutorKind kind) {
  ReposeResult res;
  compute::RunConfig c;
  compute::MaterialConfig bead;
  bead.name = "glass";
  bead.youngsModulus = o.youngs, bead.poissonRatio = o.poisson, bead.density = o.density;
  bead.restitution = o.restitution, bead.friction = o.friction, bead.rollingFriction = o.rolling;
  compute::MaterialConfig plate = bead;
  plate.name = "plate", plate.youngsModulus = 2e8, plate.poissonRatio = 0.3, plate.density = 7800;
  c.materials = {bead, plate};
  compute::MaterialPairConfig wall;
  wall.a = 0, wall.b = 1, wall.restitution = o.wallRestitution, wall.friction = o.wallFriction, wall.rollingFriction = o.wallRolling;
  c.pairs = {wall};
  fillCylinder(o, c.particles);
  res.particles = c.particles.size();
  double top = 0;
  for (const Vec3d& x : c.particles.position) top = std::max(top, x.z);
  // The plate (surface 0), wide enough for the heap's foot; the cylinder (surface 1), lifted after the settling.
  compute::MeshConfig floor;
  floor.name = "plate";
  floor.material = 1;
  const double L = 6 * o.cylinderRadius;  // the collapse spreads to about 3 cylinder radii (docs/accuracy.md)
  if (o.roughness <= 0) {
    floor.vertices = {{-L, -L, 0}, {L, -L, 0}, {L, L, 0}, {-L, L, 0}};
    floor.triangles = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise seen from above
  } else {  // a height field on a grid of 1.5 mean diameters, its heights in [0, roughness]
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
  floor.surface.assign(floor.triangles.size(), 0);
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
  c.meshes = {floor, side};
  c.sim.gravity = {0, 0, -9.81};
  c.sim.duration = o.settle + tLift + o.rest + 0.01;
  c.sim.precision = o.precision == "float" ? compute::Precision::kFloat : compute::Precision::kDouble;
  c.sim.precisionGiven = true;
  compute::SimulationOptions so;
  so.executor = kind;
  auto created = compute::Simulation::create(c, so);
  if (!created) {
    res.error = created.status().toString();
    return res;
  }
  compute::Simulation& sim = *created.value();
  const auto t0 = std::chrono::steady_clock::now();
  if (auto s = sim.runUntil(o.settle + tLift + o.rest); !s.isOk()) {
    res.error = s.toString();
    return res;
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
  res.spread = hi - lo;
  return res;
}

}  // namespace pflow::bench
