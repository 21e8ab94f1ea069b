#include "bench/ReposeHeap.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>

#include "backend/store/CheckpointFile.h"
#include "compute/dem/Simulation.h"
#include "frontend/SceneLoader.h"

namespace pflow::bench {

namespace {
constexpr double kPi = std::numbers::pi;
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

double reposeAngle(const ReposeProfile& p, double meanDiameter, double* from, double* to, double* heapRadius, double* heapHeight,
                   double floorLevel) {
  // The heap's radius: the first ring (from the axis) whose top is below 1.5 diameters above the floor.
  double radius = 0, height = 0;
  for (std::size_t k = 0; k < p.height.size(); ++k) {
    if (std::isnan(p.height[k]) || p.height[k] < floorLevel + 1.5 * meanDiameter) break;
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
  if (o.roughness <= 0 || o.floor == "beads") {
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

// A scene and its signature: its YAML with the plate's parameters, which a checkpoint carries (a run refuses one
// taken with other options).
struct Scene {
  compute::RunConfig config;
  std::string signature;
};

// The height of a lattice region of radius rIn holding `particles` beads, with room to spare (count: takes them).
double fillHeight(const ReposeOptions& o, double rIn) {
  const double perLayer = kPi * rIn * rIn / (o.spacing * o.spacing);
  return 1.15 * double(o.particles) / perLayer * o.spacing + 2 * o.spacing;
}

// Both scenes' materials, pair and beads (a lattice cylinder of radius rIn and height `fill` from `base`); the walls
// are of material `plate`.
std::string beadsYaml(const ReposeOptions& o, double base, double rIn, double fill) {
  char buf[2048];
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
    count: %zu
)",
                o.youngs, o.poisson, o.density, o.restitution, o.friction, o.rolling, o.wallRestitution, o.wallFriction,
                o.wallRolling, o.wallRestitution, o.wallFriction, o.wallRolling, base, rIn, fill, o.rMin, o.rMax, o.spacing,
                o.particles);
  return buf;
}

// The scene loaded from its YAML, with the plate (half-width L) added as the last surface.
Result<Scene> withPlate(const std::string& yaml, const char* name, const ReposeOptions& o, double L) {
  auto loaded = frontend::loadSceneFromString(yaml, name);
  if (!loaded) return loaded.status();
  Scene s{loaded->config, yaml};
  const int surface = int(s.config.surfaceNames.size());
  s.config.surfaceNames.push_back("plate");
  s.config.meshes.push_back(plate(o, L, 1, surface));
  char p[200];
  std::snprintf(p, sizeof p, "plate: {half_width: %.6g, roughness: %.6g, seed: %llu, floor: %s}\n", L, o.roughness,
                (unsigned long long)o.seed, o.floor.c_str());
  s.signature += p;
  if (o.floor == "beads") {  // glued beads of the pile's sizes resting on the flat plate, over the inscribed disc
    compute::MaterialConfig glued = s.config.materials[0];
    glued.name = "glued";
    glued.fixed = true;
    const int material = int(s.config.materials.size());
    s.config.materials.push_back(glued);
    compute::ParticleInit& pi = s.config.particles;
    if (pi.velocity.empty()) pi.velocity.assign(pi.size(), Vec3d{0, 0, 0});
    if (pi.angularVelocity.empty()) pi.angularVelocity.assign(pi.size(), Vec3d{0, 0, 0});
    std::mt19937_64 rng(o.seed + 2);
    std::uniform_real_distribution<double> size(o.rMin, o.rMax);
    const double a = 2 * o.rMax, row = a * std::sqrt(3.0) / 2, R = L - o.rMax;
    for (int j = -int(R / row); j <= int(R / row); ++j)
      for (int i = -int(R / a) - 1; i <= int(R / a) + 1; ++i) {
        const double x = (i + 0.5 * (j & 1)) * a, y = j * row;
        if (x * x + y * y > R * R) continue;
        const double r = size(rng);
        pi.position.push_back({x, y, r});
        pi.radius.push_back(r);
        pi.material.push_back(material);
        pi.velocity.push_back({0, 0, 0});
        pi.angularVelocity.push_back({0, 0, 0});
      }
  }
  return s;
}

// The poured pile's scene: the beads on a lattice in a funnel (a cone from the orifice up, then a cylinder of the
// lifted cylinder's radius), its orifice closed by a gate that slides away after the settling (100 mm, past the
// plate's edge, where it stops); the plate below, and 20 mm under it a tray that catches the beads rolling off the
// plate's edge: falling on without it, ever faster, they made the neighbour lists be rebuilt every two steps by the
// end of a run (600 161 rebuilds in 1.32·10⁶ steps, 56 % of the run's time; one in 24 steps before any falls).
Result<Scene> pourScene(const ReposeOptions& o) {
  const double R = o.cylinderRadius, rIn = R - o.rMax - 0.0005, cone = R - o.orifice / 2, z0 = o.pourHeight;
  const double fill = fillHeight(o, rIn), D = o.orifice;
  char buf[2048];
  std::snprintf(buf, sizeof buf, R"(geometry:
  - name: funnel
    material: plate
    hopper: {orifice: [0, 0, %.6g], axis: [0, 0, 1], orifice_radius: %.6g, top_radius: %.6g, cone_height: %.6g,
             cylinder_height: %.6g}
  - name: gate
    material: plate
    box: {min: [%.6g, %.6g, %.6g], max: [%.6g, %.6g, %.6g], side: outside}
    motion: {velocity_profile: [[0, 0.5, 0, 0], [0.2, 0.5, 0, 0], [0.2001, 0, 0, 0]], start_time: %.6g}
  - name: tray
    material: plate
    plane: {point: [0, 0, -0.02], normal: [0, 0, 1]}
simulation:
  duration: %.6g
  precision: %s
)",
                z0, D / 2, R, cone, fill + 0.01, -D, -D, z0 - 0.004, D, D, z0 - 0.0001, o.settle,
                o.settle + o.pour + o.rest + 0.01, o.precision.c_str());
  return withPlate(beadsYaml(o, z0 + cone + 0.001, rIn, fill) + buf, "repose-pour", o, plateHalfWidth(o));
}

// The lifted cylinder's scene: the beads on a lattice in a cylinder (open at both ends) standing on the plate,
// lifted after the settling at liftSpeed by `lift`. The collapse spreads to about 3 cylinder radii (docs/accuracy.md,
// "Angle of repose"): a plate of 6.
Result<Scene> liftScene(const ReposeOptions& o) {
  const double R = o.cylinderRadius, rIn = R - o.rMax - 0.0005, fill = fillHeight(o, rIn);
  const double base = o.roughness + o.rMax + 0.0002, tLift = o.lift / o.liftSpeed, v = o.liftSpeed;
  char buf[2048];
  std::snprintf(buf, sizeof buf, R"(geometry:
  - name: cylinder
    material: plate
    cylinder: {base: [0, 0, 0], axis: [0, 0, 1], radius: %.6g, height: %.6g, open: [bottom, top], segments: 64}
    motion: {velocity_profile: [[0, 0, 0, %.6g], [%.6g, 0, 0, %.6g], [%.6g, 0, 0, 0]], start_time: %.6g}
simulation:
  duration: %.6g
  precision: %s
)",
                R, base + fill + o.rMax + 0.005, v, tLift, v, tLift + 1e-4, o.settle, o.settle + tLift + o.rest + 0.01,
                o.precision.c_str());
  return withPlate(beadsYaml(o, base, rIn, fill) + buf, "repose-lift", o, plateHalfWidth(o));
}

}  // namespace

ReposeResult runRepose(const ReposeOptions& o, compute::ExecutorKind kind) {
  ReposeResult res;
  res.plateHalfWidth = plateHalfWidth(o);
  auto scene = o.method == "pour" ? pourScene(o) : liftScene(o);
  if (!scene) {
    res.error = scene.status().toString();
    return res;
  }
  const compute::RunConfig& c = scene->config;
  res.particles = o.particles;  // the pile's beads: ids below (glued floor beads follow them)
  res.floorBeads = c.particles.size() - std::min(c.particles.size(), o.particles);
  for (const compute::MeshConfig& m : c.meshes) res.triangles += m.triangles.size();
  compute::SimulationOptions so;
  so.executor = kind;
  auto created = compute::Simulation::create(c, so);
  if (!created) {
    res.error = created.status().toString();
    return res;
  }
  compute::Simulation& sim = *created.value();
  const char* precision = c.sim.precision == compute::Precision::kFloat ? "float" : "double";
  if (!o.checkpoint.empty() && std::filesystem::exists(o.checkpoint)) {
    auto data = backend::readCheckpoint(o.checkpoint);
    if (!data) {
      res.error = data.status().toString();
      return res;
    }
    if (data->precision != precision || data->sceneText != scene->signature) {
      res.error = "the checkpoint '" + o.checkpoint + "' is another run's (its scene, plate or precision differ)";
      return res;
    }
    if (auto s = sim.resume(data->state); !s.isOk()) {
      res.error = s.toString();
      return res;
    }
  }
  const std::int64_t step0 = sim.stepCount();
  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  // Past the wall limit, the run stops at the next rebuild (where a state may be taken) and writes it.
  const auto stopAtRebuild = [&](const compute::Simulation& s) {
    return o.wallLimit > 0 && elapsed() > o.wallLimit && s.justRebuilt() ? Status(StatusCode::kCancelled, "wall limit")
                                                                          : Status();
  };
  // What every sitting reports, finished or not.
  const auto finish = [&](ReposeResult& r) {
    r.wall = elapsed(), r.time = sim.time(), r.steps = sim.stepCount() - step0, r.rebuilds = sim.rebuilds();
    r.phases = sim.timers().report(), r.cellSize = sim.grid().cellSize;
    r.contactSlots = sim.engine().historySlots(), r.wallSlots = sim.engine().wallHistorySlots();
  };
  const double end = o.method == "pour" ? o.settle + o.pour + o.rest : o.settle + o.lift / o.liftSpeed + o.rest;
  for (double t = std::min(std::floor(sim.time() / 0.1 + 1e-9) * 0.1 + 0.1, end);; t = std::min(t + 0.1, end)) {
    if (auto s = sim.runUntil(t, stopAtRebuild); !s.isOk()) {
      if (s.code() != StatusCode::kCancelled || o.checkpoint.empty()) {
        res.error = s.toString();
        return res;
      }
      auto state = sim.state();
      backend::CheckpointData data;
      data.solver = "dem", data.precision = precision, data.sceneFile = "pflow-repose", data.sceneText = scene->signature;
      if (state) data.state = std::move(state).value();
      const Status w = state ? backend::writeCheckpoint(o.checkpoint, data) : state.status();
      res.error = w.isOk() ? "" : w.toString();
      res.unfinished = w.isOk();
      finish(res);
      return res;
    }
    if (o.onProgress) o.onProgress(sim.time(), sim.stepCount(), elapsed());
    if (t >= end) break;
  }
  finish(res);
  const auto snap = sim.snapshot({"position", "radius", "velocity", "id"});
  const Vec3d* v = snap.find("velocity")->as<Vec3d>();
  const double* r = snap.find("radius")->as<double>();
  const Gid* id = snap.find("id")->as<Gid>();
  double dSum = 0;
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  std::size_t counted = 0;
  for (std::size_t i = 0; i < snap.n; ++i) {
    if (std::size_t(id[i]) >= o.particles) continue;  // a glued floor bead (below the pile's surface: not measured)
    ++counted;
    if (x[i].z > -0.001) ++res.onPlate;
    res.lowest = counted == 1 ? x[i].z : std::min(res.lowest, x[i].z);
    res.kineticEnergy += 0.5 * o.density * 4.0 / 3.0 * kPi * r[i] * r[i] * r[i] * norm2(v[i]);
    dSum += 2 * r[i];
  }
  const double d = dSum / double(std::max<std::size_t>(counted, 1)), bin = 2 * d;
  res.profile = reposeProfile(snap, bin);
  // A bead floor's level: its glued beads' mean top (each rests on the plate: its top is its diameter).
  const double floorLevel = o.floor == "beads" ? o.rMin + o.rMax : 0.0;
  res.angle = reposeAngle(res.profile, d, &res.fitFrom, &res.fitTo, &res.heapRadius, &res.heapHeight, floorLevel);
  // The spread over the quadrants; NaN when any quadrant has no slope (std::min/max would pass over a NaN).
  double lo = 90, hi = 0;
  bool all = true;
  for (int q = 0; q < 4; ++q) {
    const double a = reposeAngle(reposeProfile(snap, bin, q), d, nullptr, nullptr, nullptr, nullptr, floorLevel);
    res.quadrant[std::size_t(q)] = a;
    if (std::isnan(a)) all = false;
    else lo = std::min(lo, a), hi = std::max(hi, a);
  }
  res.spread = all ? hi - lo : std::numeric_limits<double>::quiet_NaN();
  return res;
}

}  // namespace pflow::bench
