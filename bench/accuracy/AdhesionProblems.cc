// The accuracy study's adhesion problems (docs/physics.md, "Adhesion"): JKR's critical sticking velocity of elastic
// spheres (sphere-sphere and sphere-wall) against the energy balance of its hysteresis, and the pull-off force under
// displacement control against (3/2) pi dgamma R. Soft 1 mm spheres, E = 1e7 Pa, dgamma = 0.5 J/m^2 (as
// tests/regression/cohesion_test.cc); the references follow the setting's softened modulus.
#include <cmath>
#include <numbers>

#include "bench/accuracy/ProblemSupport.h"
#include "compute/dem/contact/ContactModels.h"
#include "tests/support/TestScenes.h"

namespace pflow::bench::accuracy {
namespace {

using compute::RunConfig;
namespace cohesion = compute::contact::cohesion;

constexpr double kE = 1e7, kNu = 0.3, kRho = 2500, kR = 1e-3, kGamma = 0.5;

RunConfig adhesiveScene(double e) {
  RunConfig c;
  c.materials = {test::material("powder", kE, kNu, kRho, e, 0.0)};
  compute::MaterialPairConfig pair;
  pair.cohesion = compute::CohesionModel::kJkr;
  pair.workOfAdhesion = kGamma;
  c.pairs = {pair};
  c.sim.gravity = {0, 0, 0};
  return c;
}

compute::ContactParams jkr(double softening) {
  compute::ContactParams p;
  p.effYoung = kE / softening / (2 * (1 - kNu * kNu));
  compute::setCohesion(p, cohesion::kJkr, kGamma);
  return p;
}
double breakDistance(double softening, double effRadius) { return -cohesion::jkrBreakOverlap(jkr(softening).jkrBreak, effRadius); }

// The energy balance: (1/2) m* v_c^2 = Phi(delta_c), what breaking the contact dissipates.
double stickingVelocity(double softening, double effRadius, double effMass) {
  const compute::ContactParams p = jkr(softening);
  const double dc = cohesion::jkrBreakOverlap(p.jkrBreak, effRadius);
  return std::sqrt(2 * cohesion::jkrEnergy(p.effYoung, p.jkrB, effRadius, cohesion::jkrRootRadius(p.jkrB, effRadius, dc)) / effMass);
}

// One head-on impact at relative speed v, run for 40 periods of the adhesive contact: 1 stuck, 0 free, -1 failed
// (o records why).
int sticks(bool wall, double v, const Setting& s, Outcome& o) {
  RunConfig c = adhesiveScene(1.0);
  const double gap = 1e-7;
  if (wall) {
    c.planes = {test::plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
    test::addParticle(c, {0, 0, kR + gap}, kR, 0, {0, 0, -v});
  } else {
    test::addParticle(c, {0, 0, -kR - gap / 2}, kR, 0, {0, 0, v / 2});
    test::addParticle(c, {0, 0, kR + gap / 2}, kR, 0, {0, 0, -v / 2});
  }
  apply(c, s);
  Timed t(c, s);
  if (!t.ok()) {
    failWith(o, t.status());
    return -1;
  }
  const double m = test::sphereMass(kR, kRho);
  const double stiffness = 2 * kE / s.softening / (2 * (1 - kNu * kNu)) * 1e-4;  // 2 E* a, a ~ 0.1 mm
  const double period = 2 * std::numbers::pi * std::sqrt(m / stiffness);
  const auto steps = std::int64_t((gap / v + 40 * period) / *c.sim.dt) + 10;
  for (std::int64_t k = 0; k < steps; ++k)
    if (!t.step()) {
      failWith(o, t.status());
      return -1;
    }
  t.finish(o);
  const auto snap = t.sim().snapshot({"position"});
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  const double separation = wall ? x[0].z - kR : std::fabs(x[1].z - x[0].z) - 2 * kR;
  return separation < breakDistance(s.softening, wall ? kR : kR / 2) ? 1 : 0;
}

Problem sticking(bool wall) {
  Problem p;
  p.family = "adhesion_sticking";
  p.name = wall ? "adhesion_sticking/sphere_wall" : "adhesion_sticking/sphere_sphere";
  p.run = [=](const Setting& s) {
    const double m = test::sphereMass(kR, kRho);
    // The reference is the real material's: softening the modulus changes JKR's sticking velocity (as E*^{-1/3}),
    // which is what the study charts.
    const double ref = wall ? stickingVelocity(1.0, kR, m) : stickingVelocity(1.0, kR / 2, m / 2);
    Outcome o;
    o.quantities = {{"sticking_velocity", ref, kNaN}};
    // Bisection between 0.2 and 20 times the reference (to 0.2 %; a softened material sticks up to E*^{-1/3} times
    // faster): the slowest impact must stick, the fastest not.
    double lo = 0.2 * ref, hi = 20 * ref;
    if (sticks(wall, lo, s, o) != 1 || sticks(wall, hi, s, o) != 0) {
      if (o.status == "ok") o.status = "error", o.detail = "the bracket [0.2, 20] x the reference does not hold";
      return o;
    }
    for (int k = 0; k < 13; ++k) {
      const double mid = std::sqrt(lo * hi);
      const int r = sticks(wall, mid, s, o);
      if (r < 0) return o;
      (r == 1 ? lo : hi) = mid;
    }
    o.quantities[0].value = std::sqrt(lo * hi);
    return o;
  };
  return p;
}

// A sphere held by adhesion between the floor plane and a lid (two triangles) that rises at 0.3 mm/s after 10 ms:
// the most tensile load on the lid (the wall loads of every step) is the pull-off force.
Problem pullOff() {
  Problem p;
  p.family = "adhesion_pull_off";
  p.name = "adhesion_pull_off/sphere_between_walls";
  p.run = [](const Setting& s) {
    RunConfig c = adhesiveScene(0.5);
    const double touch = 1e-9, vLid = 3e-4, settle = 0.01;
    c.planes = {test::plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
    c.planes[0].surface = 0;
    test::addParticle(c, {0, 0, kR - touch}, kR, 0);
    compute::MeshConfig lid;
    lid.name = "lid";
    const double L = 4 * kR, z = 2 * kR - 2 * touch;
    lid.vertices = {{-L, -L, z}, {L, -L, z}, {L, L, z}, {-L, L, z}};
    lid.triangles = {{0, 2, 1}, {0, 3, 2}};
    lid.surface = {1, 1};
    lid.motion.velocity = {0, 0, vLid};
    lid.motion.startTime = settle;
    c.meshes = {lid};
    c.surfaceNames = {"floor", "lid"};
    apply(c, s);
    Outcome o;
    const double fc = 1.5 * std::numbers::pi * kGamma * kR;
    o.quantities = {{"pull_off_force", fc, kNaN}};
    Timed t(c, s);
    if (!t.ok()) {
      failWith(o, t.status());
      return o;
    }
    t.sim().recordWallLoads(false, *c.sim.dt);
    const double until = settle + 8 * breakDistance(s.softening, kR) / vLid;
    double most = 0;
    while (t.sim().time() < until) {
      if (!t.step()) {
        failWith(o, t.status());
        break;
      }
      const std::vector<double> loads = t.sim().wallLoads();
      if (loads.size() >= 12 && t.sim().wallLoadsStep() == t.sim().stepCount()) most = std::min(most, loads[6 + 2]);
    }
    t.finish(o);
    if (o.status == "ok") o.quantities[0].value = -most;
    return o;
  };
  return p;
}

}  // namespace

std::vector<Problem> adhesionProblems() { return {sticking(false), sticking(true), pullOff()}; }

}  // namespace pflow::bench::accuracy
