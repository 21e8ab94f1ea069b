#include "bench/accuracy/Problems.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <utility>

#include "bench/accuracy/ProblemSupport.h"
#include "compute/dem/TimeStep.h"
#include "tests/support/TestScenes.h"

namespace pflow::bench::accuracy {

using compute::MaterialConfig;
using compute::ParticleSnapshot;
using compute::PlaneConfig;
using compute::RunConfig;
using compute::Simulation;
// The scene builders and Hertz closed forms of the physics tests (one definition for tests and study).
using test::addParticle;
using test::HertzImpact;
using test::hertzImpact;
using test::material;
using test::plane;
using test::rigid;
using test::sphereMass;

namespace {

// The study flags an overlap beyond this fraction of the smaller radius as "excessive overlap" (the engine
// itself stops a run at simulation.max_overlap, 0.5 by default).
constexpr double kOverlapLimit = 0.1;
// A rebound (or realised restitution) this much above the input is energy gain (e = 1) or a damping that no
// longer dissipates what it should (e < 1).
constexpr double kEnergyGainTol = 0.01;
constexpr double kDampingTol = 0.10;

// Particle state indexed by id (snapshots are in cell order after a rebuild).
struct Body {
  Vec3d x, v, f;
  double r = 0;
};
std::vector<Body> bodies(const ParticleSnapshot& s) {
  std::vector<Body> b(s.n);
  const Vec3d* x = s.find("position")->as<Vec3d>();
  const Vec3d* v = s.find("velocity")->as<Vec3d>();
  const Vec3d* f = s.find("force")->as<Vec3d>();
  const double* r = s.find("radius")->as<double>();
  const Gid* id = s.find("id")->as<Gid>();
  for (std::size_t i = 0; i < s.n; ++i) b[id[i]] = {x[i], v[i], f[i], r[i]};
  return b;
}
const std::vector<std::string> kFields = {"position", "velocity", "force", "radius", "id"};

// ---------------------------------------------------------------------------------------------------------
// Normal impacts (sphere-sphere along x, or sphere on the plane z = 0): the peak overlap and force, the
// contact time (zero crossings of the overlap interpolated between steps) and the outgoing velocities.
struct Impact {
  double maxOverlap = 0, maxForce = 0, contactTime = 0;
  Vec3d v0out{}, v1out{};
  bool started = false, ended = false, lost = false, tunnelled = false;
};

Impact runImpact(Timed& t, bool wall, std::int64_t maxSteps) {
  Impact r;
  const double dt = t.sim().dt();
  auto overlapOf = [&](const auto& b) { return wall ? b[0].r - b[0].x.z : b[0].r + b[1].r - norm(b[1].x - b[0].x); };
  // The overlap before the first step (the gap, negative): contact that begins inside the first step is timed from
  // the interpolated crossing like any other, not from the end of that step.
  double prevOverlap = overlapOf(bodies(t.sim().snapshot(kFields, true))), tStart = 0;
  if (prevOverlap > 0) r.started = true, tStart = t.sim().time();  // touching already: the contact began at the start
  for (std::int64_t k = 0; k < maxSteps; ++k) {
    if (!t.step()) break;
    const auto b = bodies(t.sim().snapshot(kFields, true));
    const double overlap = overlapOf(b);
    const double now = t.sim().time();
    if (wall ? b[0].x.z < 0 : b[1].x.x < b[0].x.x) r.tunnelled = true;  // through the wall, or through each other
    if (overlap > 0) {
      if (!r.started) {
        r.started = true;
        tStart = now - dt * overlap / (overlap - prevOverlap);  // the crossing of zero overlap, interpolated
      }
      r.maxOverlap = std::max(r.maxOverlap, overlap);
      const double f = norm(b[0].f);
      r.maxForce = std::max(r.maxForce, f);
      // Touching and closing, yet no force: the contact is not in the neighbour lists. (While the bodies
      // separate, the damped force may be clipped to zero legitimately.)
      const bool closing = wall ? b[0].v.z < 0 : dot(b[1].v - b[0].v, b[1].x - b[0].x) < 0;
      if (f == 0 && closing) r.lost = true;
      if (wall && b[0].x.z < -b[0].r) break;  // fully through the plane
    } else if (r.started) {
      r.ended = true;
      r.contactTime = (now - dt * overlap / (overlap - prevOverlap)) - tStart;
      r.v0out = b[0].v;
      if (!wall) r.v1out = b[1].v;
      break;
    }
    prevOverlap = overlap;
  }
  return r;
}

// The failure of an impact, from its trace: `eIn` the input restitution, `eOut` the realised one.
void classifyImpact(Outcome& o, const Impact& r, double radius, double eIn, double eOut) {
  if (o.status != "ok") return;
  if (r.lost || !r.started) o.status = "lost contacts";
  else if (r.tunnelled) o.status = "tunnelling";
  else if (!r.ended) o.status = "error", o.detail = "the contact did not end within the step budget";
  else if (eOut > 1 + kEnergyGainTol) o.status = "energy gain";
  else if (eIn < 1 && eOut > eIn * (1 + kDampingTol)) o.status = "damping instability";
  else if (r.maxOverlap > kOverlapLimit * radius) o.status = "excessive overlap";
}

// Chung & Ooi (2011) tests 1 (sphere-sphere, R = 10 mm, +-10 m/s) and 2 (sphere on a rigid plane, R = 0.1 m,
// 0.2 m/s), elastic. References: the Hertz closed forms of the unsoftened material (softening distorts the
// peak overlap, force and contact time by design; the rebound speed should survive it).
Problem chungOoi(int test, const std::string& variant, double E, double nu, double rho) {
  Problem p;
  p.family = "chung_ooi_" + std::to_string(test);
  p.name = p.family + "/" + variant;
  p.run = [=](const Setting& s) {
    const bool wall = test == 2;
    const double R = wall ? 0.1 : 0.01, v = wall ? 0.2 : 10.0;
    RunConfig c;
    c.materials = {material(variant, E, nu, rho)};
    if (wall) {
      c.materials.push_back(rigid());
      addParticle(c, {0, 0, R + 1e-6}, R, 0, {0, 0, -v});
      c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 1, "floor"));
    } else {
      addParticle(c, {-R - 1e-5, 0, 0}, R, 0, {v, 0, 0});
      addParticle(c, {R + 1e-5, 0, 0}, R, 0, {-v, 0, 0});
    }
    c.sim.gravity = {0, 0, 0};
    apply(c, s);
    const double Estar = wall ? E / (1 - nu * nu) : E / (2 * (1 - nu * nu));
    const double m = sphereMass(R, rho);
    const HertzImpact ref = wall ? hertzImpact(Estar, R, m, v) : hertzImpact(Estar, R / 2, m / 2, 2 * v);
    const HertzImpact soft = wall ? hertzImpact(Estar / s.softening, R, m, v) : hertzImpact(Estar / s.softening, R / 2, m / 2, 2 * v);
    Outcome o;
    Timed t(c, s);
    if (!t.ok()) {
      failWith(o, t.status());
      return o;
    }
    const auto budget = std::int64_t(10 * (soft.contactTime + 1e-4 / v) / *c.sim.dt) + 1000;
    const Impact r = runImpact(t, wall, budget);
    if (!t.status().isOk()) failWith(o, t.status());
    t.finish(o);
    const double rebound = wall ? r.v0out.z : 0.5 * (r.v1out.x - r.v0out.x);
    const bool have = r.ended;
    o.quantities = {{"delta_max", ref.maxOverlap, r.started ? r.maxOverlap : kNaN},
                    {"f_max", ref.maxForce, r.started ? r.maxForce : kNaN},
                    {"contact_time", ref.contactTime, have ? r.contactTime : kNaN},
                    {"rebound_speed", v, have ? rebound : kNaN}};
    classifyImpact(o, r, R, 1.0, have ? rebound / v : kNaN);
    return o;
  };
  return p;
}

// Chung & Ooi test 3: sphere (R = 2.5 mm) on a rigid plane at 3.9 m/s with restitution e: realised e = e.
Problem restitution(const std::string& variant, double E, double nu, double rho, double e) {
  Problem p;
  p.family = "restitution";
  char buf[64];
  std::snprintf(buf, sizeof buf, "restitution/%s_e%.1f", variant.c_str(), e);
  p.name = buf;
  p.run = [=](const Setting& s) {
    const double R = 2.5e-3, v = 3.9;
    RunConfig c;
    c.materials = {material(variant, E, nu, rho, e), rigid(e)};
    c.pairs.push_back({0, 1, e, std::nullopt, std::nullopt});
    addParticle(c, {0, 0, R + 1e-6}, R, 0, {0, 0, -v});
    c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 1, "floor"));
    c.sim.gravity = {0, 0, 0};
    apply(c, s);
    const HertzImpact soft = hertzImpact(E / (1 - nu * nu) / s.softening, R, sphereMass(R, rho), v);
    Outcome o;
    Timed t(c, s);
    if (!t.ok()) {
      failWith(o, t.status());
      return o;
    }
    const Impact r = runImpact(t, true, std::int64_t(10 * soft.contactTime / *c.sim.dt) + 1000);
    if (!t.status().isOk()) failWith(o, t.status());
    t.finish(o);
    const double eOut = r.ended ? r.v0out.z / v : kNaN;
    o.quantities = {{"restitution", e, eOut}};
    classifyImpact(o, r, R, e, eOut);
    return o;
  };
  return p;
}

// A polymer bead (r = 5 mm) dropped from 20 mm above touching onto a rigid plane with e = 0.7: apex rises
// above touching h_k - r = e^{2k} (h0 - r) for k = 1, 2, 3 (instantaneous impacts; gravity during the
// contact is part of what softening distorts).
Problem bouncingSphere() {
  Problem p;
  p.family = "bouncing_sphere";
  p.name = "bouncing_sphere/e0.7";
  p.run = [](const Setting& s) {
    const double r = 5e-3, rise0 = 0.02, e = 0.7, g = 9.81;
    RunConfig c;
    c.materials = {material("polymer", 1e9, 0.35, 1200, e), rigid(e)};
    c.pairs.push_back({0, 1, e, std::nullopt, std::nullopt});
    addParticle(c, {0, 0, r + rise0}, r, 0);
    c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 1, "floor"));
    c.sim.gravity = {0, 0, -g};
    apply(c, s);
    Outcome o;
    Timed t(c, s);
    if (!t.ok()) {
      failWith(o, t.status());
      return o;
    }
    const double dt = *c.sim.dt;
    // Free flights: the first fall and three bounces, with a margin.
    const double v0 = std::sqrt(2 * g * rise0);
    const double flights = v0 / g * (1 + 2 * (e + e * e + e * e * e)) * 1.5 + 0.01;
    const auto budget = std::int64_t(flights / dt) + 1000;
    double apex[3] = {kNaN, kNaN, kNaN}, top = -1, maxOverlap = 0;
    int bounces = 0, found = 0;
    bool inContact = false, lost = false, tunnelled = false;
    double prevVz = 0;
    for (std::int64_t k = 0; k < budget && found < 3; ++k) {
      if (!t.step()) break;
      const Body b = bodies(t.sim().snapshot(kFields, true))[0];
      const double overlap = r - b.x.z;
      if (b.x.z < 0) tunnelled = true;
      if (b.x.z < -r) break;
      if (overlap > 0) {
        if (!inContact) ++bounces;
        inContact = true;
        maxOverlap = std::max(maxOverlap, overlap);
        if (norm(b.f) == 0 && b.v.z < 0) lost = true;  // closing without a force: not in the lists
      } else {
        if (inContact) top = b.x.z;
        inContact = false;
        if (bounces > found) {
          top = std::max(top, b.x.z);
          if (prevVz > 0 && b.v.z <= 0) apex[found++] = top - r;
        }
      }
      prevVz = b.v.z;
    }
    if (!t.status().isOk()) failWith(o, t.status());
    t.finish(o);
    for (int k = 0; k < 3; ++k)
      o.quantities.push_back({"apex_rise_" + std::to_string(k + 1), std::pow(e, 2.0 * (k + 1)) * rise0, apex[k]});
    if (o.status == "ok") {
      if (lost) o.status = "lost contacts";
      else if (tunnelled) o.status = "tunnelling";
      else {
        double prev = rise0;
        for (int k = 0; k < found; ++k) {
          const double eOut = std::sqrt(apex[k] / prev);
          if (eOut > 1 + kEnergyGainTol) o.status = "energy gain";
          else if (eOut > e * (1 + kDampingTol) && o.status == "ok") o.status = "damping instability";
          prev = apex[k];
        }
        if (o.status != "ok") {
        } else if (maxOverlap > kOverlapLimit * r) o.status = "excessive overlap";
        else if (found < 3) o.status = "error", o.detail = "fewer than three bounces within the step budget";
      }
    }
    return o;
  };
  return p;
}

// ---------------------------------------------------------------------------------------------------------
// Bulk problems: a few hundred polydisperse spheres (radii uniform in [0.8, 1] R0, R0 = 1 mm), E = 1e7 Pa
// (already a softened DEM material, as in pflow-bench's standard bed), rho 2500, nu 0.3, e 0.3, mu 0.5,
// mu_r 0.05; walls of the same material. Sized so that the whole CPU study fits in 15 minutes on 2 cores.
constexpr double kR0 = 1e-3;
MaterialConfig bulkMaterial() { return material("grain", 1e7, 0.3, 2500, 0.3, 0.5, 0.05); }

// Deterministic uniform numbers in [0, 1) (the study must not depend on the platform's <random>).
struct Lcg {
  std::uint64_t s;
  double next() {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return double(s >> 11) * (1.0 / 9007199254740992.0);
  }
};

// Overlapping pairs of a snapshot (contacts now), those missing from the neighbour candidates, and the
// deepest overlap relative to the smaller radius.
struct PairScan {
  std::size_t contacts = 0, missed = 0;
  double maxOverlapRatio = 0;
};
PairScan scanPairs(Simulation& sim, const std::vector<Body>& b, bool checkCandidates) {
  PairScan out;
  std::vector<std::size_t> order(b.size());
  double rmax = 0;
  for (std::size_t i = 0; i < b.size(); ++i) order[i] = i, rmax = std::max(rmax, b[i].r);
  std::sort(order.begin(), order.end(), [&](auto i, auto j) { return b[i].x.x < b[j].x.x; });
  std::vector<std::pair<Gid, Gid>> cand;
  if (checkCandidates) cand = sim.engine().candidatePairs();
  for (std::size_t a = 0; a < order.size(); ++a)
    for (std::size_t c = a + 1; c < order.size(); ++c) {
      const std::size_t i = order[a], j = order[c];
      if (b[j].x.x - b[i].x.x > 2 * rmax) break;
      const double overlap = b[i].r + b[j].r - norm(b[j].x - b[i].x);
      if (overlap <= 0) continue;
      ++out.contacts;
      out.maxOverlapRatio = std::max(out.maxOverlapRatio, overlap / std::min(b[i].r, b[j].r));
      if (checkCandidates && !std::binary_search(cand.begin(), cand.end(), std::pair<Gid, Gid>{Gid(i), Gid(j)}) &&
          !std::binary_search(cand.begin(), cand.end(), std::pair<Gid, Gid>{Gid(j), Gid(i)}))
        ++out.missed;
    }
  return out;
}

// Translational kinetic plus potential energy (above z = 0) of the grains [J].
double mechanicalEnergy(const std::vector<Body>& b, double density, double g) {
  double e = 0;
  for (const auto& p : b) {
    const double m = sphereMass(p.r, density);
    e += 0.5 * m * norm2(p.v) + m * g * p.x.z;
  }
  return e;
}

// Runs a bulk problem (grains of `density` starting at rest under gravity g) until `maxTime` or rest
// (translational energy below `restEnergy` after `minTime`), scanning pairs every 200 steps (every 50 with
// a fixed rebuild interval, where contacts can be missed); returns the final particles (empty when the
// run failed). Energy gain: more mechanical energy than at the start, which a dissipative system never has.
struct BulkTrace {
  std::vector<Body> final;
  bool lost = false, escaped = false, gained = false;
  double maxOverlapRatio = 0;
};
BulkTrace runBulk(Timed& t, double minTime, double maxTime, double restEnergy, const compute::Aabb& box, double density,
                  double g, int rebuildInterval) {
  BulkTrace tr;
  const double dt = t.sim().dt();
  const auto last = std::int64_t(std::ceil(maxTime / dt));
  const int every = rebuildInterval > 0 ? 50 : 200;
  const double e0 = mechanicalEnergy(bodies(t.sim().snapshot(kFields, true)), density, g);
  bool rest = false;
  for (std::int64_t k = 1; k <= last && !rest; ++k) {
    if (!t.step()) return tr;
    if (k % every == 0 || k == last) {
      const auto b = bodies(t.sim().snapshot(kFields, true));
      tr.gained |= mechanicalEnergy(b, density, g) > 1.001 * e0;
      const PairScan ps = scanPairs(t.sim(), b, true);
      tr.lost |= ps.missed > 0;
      tr.maxOverlapRatio = std::max(tr.maxOverlapRatio, ps.maxOverlapRatio);
      for (const auto& p : b)
        if (p.x.x < box.lo.x || p.x.y < box.lo.y || p.x.z < box.lo.z || p.x.x > box.hi.x || p.x.y > box.hi.y ||
            p.x.z > box.hi.z)
          tr.escaped = true;
      if (tr.lost || tr.escaped || tr.gained) return tr;
      const auto st = t.sim().contactStats();
      rest = t.sim().time() >= minTime && st.translationalEnergy < restEnergy;
      if (rest || k == last) tr.final = b;
    }
  }
  return tr;
}

// Missed contacts first: with a fixed rebuild interval they are the cause of what follows (the engine's
// deep-overlap stop among it).
void classifyBulk(Outcome& o, const BulkTrace& tr) {
  if (tr.lost) o.status = "lost contacts";
  else if (o.status != "ok") return;
  else if (tr.escaped) o.status = "tunnelling";
  else if (tr.gained) o.status = "energy gain";
  else if (tr.maxOverlapRatio > kOverlapLimit) o.status = "excessive overlap";
}

// A settled bed: 324 spheres on a jittered lattice (6 x 6 x 9, spacing 1.05 d) fall into a box of five
// planes (12.8 mm square) and settle (0.15 s, or rest after 0.08 s). Solid fraction: the fraction of points
// of a grid (spacing d/10) inside spheres, over the box's interior (1 d from the side walls and the floor,
// 1.5 d below the surface, the 90th percentile of centre heights); coordination: 2 x contacts / N. No closed form: the
// reference is the finest setting in double (filled in by the study).
Problem settledBed() {
  Problem p;
  p.family = "settled_bed";
  p.name = "settled_bed/n324";
  p.bulk = true;
  p.run = [](const Setting& s) {
    const double d = 2 * kR0, a = 1.05 * d, L = 6 * a + 0.1 * d;
    const int nxy = 6, nz = 9;
    RunConfig c;
    c.materials = {bulkMaterial()};
    Lcg rng{12345 + 1000003 * s.seed};
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < nxy; ++j)
        for (int i = 0; i < nxy; ++i) {
          const double r = kR0 * (0.8 + 0.2 * rng.next());
          const Vec3d jit{0.04 * d * (rng.next() - 0.5), 0.04 * d * (rng.next() - 0.5), 0.04 * d * (rng.next() - 0.5)};
          addParticle(c, Vec3d{kR0 + 0.02 * d + i * a, kR0 + 0.02 * d + j * a, kR0 + 0.02 * d + k * a} + jit, r, 0);
        }
    c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor"), plane({0, 0, 0}, {1, 0, 0}, 0, "x0"),
                plane({L, 0, 0}, {-1, 0, 0}, 0, "x1"), plane({0, 0, 0}, {0, 1, 0}, 0, "y0"),
                plane({0, L, 0}, {0, -1, 0}, 0, "y1")};
    const compute::Aabb box{{-kR0, -kR0, -kR0}, {L + kR0, L + kR0, 0.1}};
    apply(c, s);
    double mass = 0;
    for (double r : c.particles.radius) mass += sphereMass(r, 2500);
    Outcome o;
    Timed t(c, s);
    if (!t.ok()) {
      failWith(o, t.status());
      return o;
    }
    const BulkTrace tr = runBulk(t, 0.08, 0.15, 1e-5 * mass * 9.81 * d, box, 2500, 9.81, s.rebuildInterval);
    if (!t.status().isOk()) failWith(o, t.status());
    t.finish(o);
    double phi = kNaN, z = kNaN;
    if (!tr.final.empty()) {
      const auto& b = tr.final;
      std::vector<double> heights;
      for (const auto& q : b) heights.push_back(q.x.z);
      std::sort(heights.begin(), heights.end());
      const double top = heights[std::size_t(0.9 * double(heights.size()))];
      const double lo = d, hiXY = L - d, zlo = d, zhi = top - 1.5 * d;
      const double h = d / 10;
      std::size_t inside = 0, total = 0;
      for (double x = lo + h / 2; x < hiXY; x += h)
        for (double y = lo + h / 2; y < hiXY; y += h)
          for (double zz = zlo + h / 2; zz < zhi; zz += h) {
            ++total;
            const Vec3d q{x, y, zz};
            for (const auto& sp : b)
              if (norm2(q - sp.x) < sp.r * sp.r) {
                ++inside;
                break;
              }
          }
      if (total > 0) phi = double(inside) / double(total);
      z = 2.0 * double(scanPairs(t.sim(), b, false).contacts) / double(b.size());
    }
    o.quantities = {{"solid_fraction", kNaN, phi}, {"coordination_number", kNaN, z}};
    classifyBulk(o, tr);
    return o;
  };
  return p;
}

// A quasi-2D granular column collapse: 8 x 12 spheres (spacing 1.02 d, odd rows shifted by half a spacing,
// a = H/L ~ 1.4) in a channel one
// grain wide (planes 1.2 d apart), against a back wall, released at t = 0 onto a floor of the same material.
// Run-out (L_f - L_i)/L_i with L_f the front of the connected deposit (gaps under 1.5 d). Reference: the
// finest setting in double; docs/accuracy.md compares it with the published scaling.
Problem columnCollapse() {
  Problem p;
  p.family = "column_collapse";
  p.name = "column_collapse/a1.4";
  p.bulk = true;
  p.run = [](const Setting& s) {
    const double d = 2 * kR0, a = 1.02 * d, W = 1.2 * d;
    const int nx = 8, nz = 12;
    RunConfig c;
    c.materials = {bulkMaterial()};
    Lcg rng{777 + 1000003 * s.seed};
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i) {
        const double r = kR0 * (0.8 + 0.2 * rng.next());
        // Odd rows shifted by half a spacing: stacked straight up, the grains would stand as columns.
        const double x = kR0 + 0.01 * d + i * a + (k % 2 ? 0.5 * a : 0.0) + 0.02 * d * (rng.next() - 0.5);
        addParticle(c, {x, W / 2 + 0.05 * d * (rng.next() - 0.5), kR0 + 0.01 * d + k * a}, r, 0);
      }
    const double Li = (nx - 0.5) * a + d, H = (nz - 1) * a + d;
    c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor"), plane({0, 0, 0}, {1, 0, 0}, 0, "back"),
                plane({0, 0, 0}, {0, 1, 0}, 0, "y0"), plane({0, W, 0}, {0, -1, 0}, 0, "y1")};
    // No stated domain: a sphere without rolling resistance may roll along the open channel for as long as the
    // run lasts, and a stated domain would stop the run when it leaves (the "left the domain" detector). The
    // derived domain holds the column; a sphere beyond it sits in a boundary cell, which costs only speed.
    const compute::Aabb box{{-kR0, -kR0, -kR0}, {1.0, W + kR0, H + 5 * d}};
    apply(c, s);
    double mass = 0;
    for (double r : c.particles.radius) mass += sphereMass(r, 2500);
    Outcome o;
    Timed t(c, s);
    if (!t.ok()) {
      failWith(o, t.status());
      return o;
    }
    const BulkTrace tr = runBulk(t, 0.15, 0.5, 1e-5 * mass * 9.81 * d, box, 2500, 9.81, s.rebuildInterval);
    if (!t.status().isOk()) failWith(o, t.status());
    t.finish(o);
    double runout = kNaN;
    if (!tr.final.empty()) {
      auto b = tr.final;
      std::sort(b.begin(), b.end(), [](const Body& u, const Body& v) { return u.x.x < v.x.x; });
      double front = b[0].x.x + b[0].r;
      for (std::size_t i = 1; i < b.size() && b[i].x.x - b[i - 1].x.x < 1.5 * d; ++i) front = std::max(front, b[i].x.x + b[i].r);
      runout = (front - Li) / Li;
    }
    o.quantities = {{"runout", kNaN, runout}};
    classifyBulk(o, tr);
    return o;
  };
  return p;
}

// A bulk problem's value at a setting: the mean over `n` random packings (seeds 0 .. n-1); steps and wall
// time add up over them, the cost is their mean, and the first failure is the run's.
Problem averaged(Problem p, int n) {
  auto one = p.run;
  p.run = [one, n](const Setting& s) {
    Outcome sum;
    double wall = 0;
    for (int k = 0; k < n; ++k) {
      Setting sk = s;
      sk.seed = std::uint64_t(k);
      const Outcome o = one(sk);
      if (k == 0) {
        sum.quantities = o.quantities;
        sum.packings.resize(o.quantities.size());
        for (auto& q : sum.quantities) q.value = 0;
      }
      for (std::size_t i = 0; i < o.quantities.size() && i < sum.quantities.size(); ++i) {
        sum.quantities[i].value += o.quantities[i].value / n;
        sum.packings[i].push_back(o.quantities[i].value);
      }
      sum.steps += o.steps;
      wall += o.wallPerSimSecond / n;
      if (sum.status == "ok" && o.status != "ok") sum.status = o.status, sum.detail = o.detail;
      if (sum.status != "ok") break;  // a failed setting is not averaged further
    }
    if (sum.status != "ok")
      for (auto& q : sum.quantities) q.value = kNaN;
    sum.wallPerSimSecond = wall;
    return sum;
  };
  return p;
}

}  // namespace

std::vector<Problem> allProblems() {
  std::vector<Problem> p;
  p.push_back(chungOoi(1, "glass", 48e9, 0.20, 2800));
  p.push_back(chungOoi(1, "limestone", 20e9, 0.25, 2500));
  p.push_back(chungOoi(2, "aluminium", 70e9, 0.30, 2699));
  p.push_back(chungOoi(2, "magnesium", 40e9, 0.35, 1800));
  for (double e : {0.1, 0.2, 0.4, 0.6, 0.8, 1.0}) p.push_back(restitution("alumina", 380e9, 0.23, 4000, e));
  for (double e : {0.1, 0.2, 0.4, 0.6, 0.8, 1.0}) p.push_back(restitution("cast_iron", 100e9, 0.25, 7000, e));
  p.push_back(bouncingSphere());
  p.push_back(averaged(settledBed(), 3));
  p.push_back(averaged(columnCollapse(), 3));
  for (Problem& a : adhesionProblems()) p.push_back(std::move(a));
  return p;
}

std::string classifyError(const std::string& m) {
  auto has = [&](const char* s) { return m.find(s) != std::string::npos; };
  if (has("energy growth")) return "energy gain";
  if (has("tunnelling")) return "tunnelling";
  if (has("excessive overlap") || has("overlaps a neighbour or wall")) return "excessive overlap";
  if (has("non-finite")) return "non-finite";
  if (has("lost contact")) return "lost contacts";
  return "error";
}

const char* precisionName(compute::Precision p) { return p == compute::Precision::kFloat ? "float" : "double"; }
const char* executorName(compute::ExecutorKind k) { return k == compute::ExecutorKind::kCuda ? "cuda" : "cpu"; }

}  // namespace pflow::bench::accuracy
