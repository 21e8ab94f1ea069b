#include "bench/JanssenSilo.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <random>

#include "bench/BeverlooSilo.h"
#include "compute/dem/Simulation.h"

namespace pflow::bench {

namespace {
constexpr double kPi = std::numbers::pi;
constexpr int kSegments = 64;  // around the silo
}  // namespace

JanssenResult runJanssen(const JanssenOptions& o, compute::ExecutorKind kind) {
  JanssenResult res;
  compute::RunConfig c;
  compute::MaterialConfig bead;
  bead.name = "bead";
  bead.youngsModulus = o.youngs, bead.poissonRatio = 0.25, bead.density = 2500, bead.restitution = o.restitution;
  bead.friction = o.friction, bead.rollingFriction = o.rolling;
  compute::MaterialConfig steel = bead;
  steel.name = "steel", steel.youngsModulus = 2e8, steel.poissonRatio = 0.3, steel.density = 7800;
  c.materials = {bead, steel};
  compute::MaterialPairConfig wall;
  wall.a = 0, wall.b = 1, wall.friction = o.wallFriction;
  c.pairs = {wall};
  // Beads on a jittered cubic lattice inside the cylinder.
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> rad(o.rMin, o.rMax), jit(-0.04 * o.spacing, 0.04 * o.spacing);
  const double rIn = o.radius - o.rMax - 0.0005;
  const int n = int(2 * rIn / o.spacing);
  for (double z = 0.003; z < o.fillHeight; z += o.spacing)
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j) {
        const double x = -rIn + i * o.spacing, y = -rIn + j * o.spacing;
        if (x * x + y * y > rIn * rIn) continue;
        c.particles.position.push_back({x + jit(rng), y + jit(rng), z + jit(rng)});
        c.particles.radius.push_back(rad(rng));
        c.particles.material.push_back(0);
      }
  res.particles = c.particles.size();
  // The floor (surface 0): a square plate under the silo that sinks by `floorDrop` after the settling (at 5 mm/s),
  // so that the bed slides down the wall and mobilises its friction, as Janssen's analysis assumes (a bed poured and
  // left at rest carries most of its weight on the floor). The side wall: bands of height h, each in four quadrants
  // centred on +x, +y, -x, -y.
  compute::MeshConfig floor;
  floor.name = "floor";
  floor.material = 1;
  const double L = 1.5 * o.radius;
  floor.vertices = {{-L, -L, 0}, {L, -L, 0}, {L, L, 0}, {-L, L, 0}};
  floor.triangles = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise seen from above
  floor.surface = {0, 0};
  const double sink = 0.005, tSink = o.floorDrop / sink;
  floor.motion.startTime = o.settle;
  floor.motion.profile = {{0.0, {0, 0, -sink}}, {tSink, {0, 0, -sink}}, {tSink + 1e-4, {0, 0, 0}}};
  c.surfaceNames = {"floor"};
  const double wallHeight = o.fillHeight + 0.01;
  const int bands = int(std::ceil(wallHeight / o.bandHeight));
  compute::MeshConfig side;
  side.name = "side";
  side.material = 1;
  for (int b = 0; b <= bands; ++b)
    for (int s = 0; s < kSegments; ++s) {
      const double a = 2 * kPi * (s + 0.5 - kSegments / 8.0) / kSegments;  // segment edges; quadrant 0 spans -45..45 deg
      side.vertices.push_back({o.radius * std::cos(a), o.radius * std::sin(a), b * o.bandHeight});
    }
  for (int b = 0; b < bands; ++b) {
    for (int q = 0; q < 4; ++q) c.surfaceNames.push_back("band" + std::to_string(b) + "/q" + std::to_string(q));
    for (int s = 0; s < kSegments; ++s) {
      const std::uint32_t v0 = std::uint32_t(b * kSegments + s), v1 = std::uint32_t(b * kSegments + (s + 1) % kSegments);
      const std::uint32_t w0 = v0 + kSegments, w1 = v1 + kSegments;
      const int q = s / (kSegments / 4);
      const std::int32_t surface = 1 + 4 * b + q;
      side.triangles.push_back({v0, w1, v1});  // counter-clockwise seen from inside
      side.triangles.push_back({v0, w0, w1});
      side.surface.push_back(surface);
      side.surface.push_back(surface);
    }
  }
  c.meshes = {floor, side};
  c.sim.gravity = {0, 0, -9.81};
  c.sim.duration = o.settle + o.floorDrop / 0.005 + 0.1 + o.average + 0.01;
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
  const double rest = o.settle + tSink + 0.1;  // settled, the floor lowered, and a moment to come to rest again
  if (auto s = sim.runUntil(rest); !s.isOk()) {
    res.error = s.toString();
    return res;
  }
  // Loads averaged over samples every 2 ms.
  sim.recordWallLoads(false, 0.002);
  std::vector<double> sum;
  int samples = 0;
  for (double t = rest + 0.002; t <= rest + o.average + 1e-9; t += 0.002) {
    if (auto s = sim.runUntil(t); !s.isOk()) {
      res.error = s.toString();
      return res;
    }
    if (sim.wallLoadsStep() != sim.stepCount()) continue;
    const std::vector<double> l = sim.wallLoads();
    if (sum.empty()) sum.assign(l.size(), 0.0);
    for (std::size_t k = 0; k < l.size() && k < sum.size(); ++k) sum[k] += l[k];
    ++samples;
  }
  res.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (samples == 0) {
    res.error = "no wall-load sample";
    return res;
  }
  for (double& v : sum) v /= samples;
  // The bed: its surface (the mean height of the top 2 % of centres, plus a radius) and its core's bulk density.
  const auto snap = sim.snapshot({"position", "radius"});
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  const double* r = snap.find("radius")->as<double>();
  std::vector<double> z;
  double mass = 0;
  for (std::size_t i = 0; i < snap.n; ++i) {
    z.push_back(x[i].z);
    mass += 2500 * 4.0 / 3.0 * kPi * std::pow(r[i], 3);
  }
  std::sort(z.begin(), z.end());
  double top = 0;
  const std::size_t first = std::size_t(0.98 * double(z.size()));
  for (std::size_t k = first; k < z.size(); ++k) top += z[k] / double(z.size() - first);
  res.surface = top + 0.5 * (o.rMin + o.rMax);
  res.bulkDensity = coreBulkDensity(snap, 0.5 * o.radius, res.surface, 2500);
  res.weight = mass * 9.81;
  res.floorLoad = -sum[2];  // the floor's force along -z is the particles' push down
  const double R = o.radius, h = o.bandHeight, floorZ = -o.floorDrop;  // bands below the lowered floor carry nothing
  for (int b = 0; b < bands; ++b) {
    const double mid = (b + 0.5) * h;
    double normal = 0, shear = 0;
    for (int q = 0; q < 4; ++q) {
      const double* l = sum.data() + 6 * std::size_t(1 + 4 * b + q);
      const double ux = q == 0 ? 1 : q == 2 ? -1 : 0, uy = q == 1 ? 1 : q == 3 ? -1 : 0;  // the quadrant's outward middle
      normal += (l[0] * ux + l[1] * uy) / (std::sqrt(2.0) * R * h) / 4;
      shear += -l[2] / (0.5 * kPi * R * h) / 4;
      res.wallShearLoad += -l[2];
    }
    if (b * h + h <= res.surface && b * h >= -floorZ) res.bands.push_back({res.surface - mid, normal, shear});
  }
  std::reverse(res.bands.begin(), res.bands.end());  // shallowest first
  // Fit sigma = s_inf (1 - exp(-z / lambda)): lambda on a fine logarithmic grid, s_inf by linear least squares.
  double best = 1e300;
  for (int k = 0; k <= 2000; ++k) {
    const double lambda = 1e-3 * std::pow(1e3, k / 2000.0);
    double num = 0, den = 0;
    for (const auto& b : res.bands) {
      const double f = 1 - std::exp(-b.depth / lambda);
      num += f * b.normal, den += f * f;
    }
    const double sInf = num / den;
    double ss = 0;
    for (const auto& b : res.bands) ss += std::pow(b.normal - sInf * (1 - std::exp(-b.depth / lambda)), 2);
    if (ss < best) best = ss, res.lambda = lambda, res.sigmaInf = sInf;
  }
  res.fitResidual = std::sqrt(best / double(res.bands.size())) / res.sigmaInf;
  double mu = 0;
  int deep = 0;
  for (const auto& b : res.bands)
    if (b.depth > res.lambda && b.normal > 0) mu += b.shear / b.normal, ++deep;
  res.mobilised = deep ? mu / deep : 0;
  const double D = 2 * o.radius;
  res.janssenInf = res.mobilised > 0 ? res.bulkDensity * 9.81 * D / (4 * res.mobilised) : 0;
  res.K = res.mobilised > 0 ? D / (4 * res.mobilised * res.lambda) : 0;
  return res;
}

}  // namespace pflow::bench
