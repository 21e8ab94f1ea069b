// Adhesion in the engine against JKR's theory (docs/physics.md, "Adhesion"): the pull-off force under displacement
// control within 2 %, the critical sticking velocity of elastic spheres (sphere-sphere and sphere-wall) within 5 % of
// the energy balance of JKR's hysteresis, the resting overlap of an adhesive sphere under its weight (JKR and the
// constant DMT model), and an adhesive clump that snaps together without tripping the energy detector.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "backend/store/DemSeries.h"
#include "compute/dem/Simulation.h"
#include "compute/dem/contact/ContactModels.h"
#include "compute/sim/Domain.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::CohesionModel;
using compute::RunConfig;
using compute::Simulation;
namespace cohesion = compute::contact::cohesion;
constexpr double kPi = std::numbers::pi;

// Soft 1 mm spheres (the restitution material) with a work of adhesion of 0.5 J/m^2 among themselves and
// with the walls (material 0 for both). Bond number F_c / m g = 23: adhesion dominates gravity.
constexpr double kE = 1e7, kNu = 0.3, kRho = 2500, kR = 1e-3, kGamma = 0.5;

RunConfig adhesiveScene(CohesionModel model, double e, double gamma = kGamma) {
  RunConfig c;
  c.materials = {material("powder", kE, kNu, kRho, e, 0.0)};
  compute::MaterialPairConfig pair;
  pair.cohesion = model;
  pair.workOfAdhesion = gamma;
  c.pairs = {pair};
  c.sim.gravity = {0, 0, 0};
  return c;
}
double effYoung() { return 1.0 / (2 * (1 - kNu * kNu) / kE); }

// The contact's JKR constants (they do not depend on the radius).
compute::ContactParams jkrParams() {
  compute::ContactParams p;
  p.effYoung = effYoung();
  compute::setCohesion(p, int(CohesionModel::kJkr), kGamma);
  return p;
}
// JKR's critical sticking velocity of an elastic contact: the energy its break dissipates, Phi(delta_c) =
// (1/2) m* v_c^2.
double stickingVelocity(double effRadius, double effMass) {
  const compute::ContactParams p = jkrParams();
  const double dc = cohesion::jkrBreakOverlap(p.jkrBreak, effRadius);
  const double w = cohesion::jkrEnergy(p.effYoung, p.jkrB, effRadius, cohesion::jkrRootRadius(p.jkrB, effRadius, dc));
  return std::sqrt(2 * w / effMass);
}

// A head-on impact at relative speed v: true if the spheres (or the sphere and the floor) still hold together after
// 40 periods of the adhesive contact.
bool sticks(bool wall, double v, double dtScale) {
  RunConfig c = adhesiveScene(CohesionModel::kJkr, 1.0);
  const double gap = 1e-7;
  if (wall) {
    c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
    addParticle(c, {0, 0, kR + gap}, kR, 0, {0, 0, -v});
  } else {
    addParticle(c, {0, 0, -kR - gap / 2}, kR, 0, {0, 0, v / 2});
    addParticle(c, {0, 0, kR + gap / 2}, kR, 0, {0, 0, -v / 2});
  }
  c.sim.duration = 1;
  if (dtScale != 1) c.sim.dt = dtScale * 0.2 * compute::rayleighTime(kR, kRho, kE, kNu);
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  if (!sim.isOk()) return false;
  const double dt = sim.value()->dt();
  const double m = sphereMass(kR, kRho), period = 2 * kPi * std::sqrt(m / (2 * effYoung() * 1e-4));  // ~ 0.6 ms
  const auto steps = std::int64_t((gap / v + 40 * period) / dt);
  EXPECT_TRUE(sim.value()->runSteps(steps).isOk());
  const auto snap = sim.value()->snapshot({"position"});
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  const double separation = wall ? x[0].z - kR : std::fabs(x[1].z - x[0].z) - 2 * kR;
  const compute::ContactParams p = jkrParams();
  return separation < -cohesion::jkrBreakOverlap(p.jkrBreak, wall ? kR : kR / 2);
}

// Bisects the sticking velocity between 0.3 and 3 times the theory's.
double measuredStickingVelocity(bool wall, double theory, double dtScale) {
  double lo = 0.3 * theory, hi = 3 * theory;
  EXPECT_TRUE(sticks(wall, lo, dtScale));
  EXPECT_FALSE(sticks(wall, hi, dtScale));
  for (int k = 0; k < 11; ++k) {
    const double mid = std::sqrt(lo * hi);
    (sticks(wall, mid, dtScale) ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
}

TEST(Adhesion, CriticalStickingVelocityOfElasticSpheresIsJkrs) {
  const double m = sphereMass(kR, kRho);
  for (bool wall : {false, true}) {
    const double theory = wall ? stickingVelocity(kR, m) : stickingVelocity(kR / 2, m / 2);
    // At pflow's default step (0.2 Rayleigh times) and at a quarter of it: the residual is the step's (the contact
    // forms and breaks at a step's end, not at the crossing), and shrinks with it.
    for (double dtScale : {1.0, 0.25}) {
      const double measured = measuredStickingVelocity(wall, theory, dtScale);
      std::printf("%s, dt = %.2f x default: sticking velocity %.5g m/s, JKR's energy balance %.5g m/s (%+.2f %%)\n",
                  wall ? "sphere-wall" : "sphere-sphere", dtScale, measured, theory, 100 * (measured / theory - 1));
      EXPECT_NEAR(measured / theory, 1.0, dtScale == 1 ? 0.05 : 0.015) << (wall ? "sphere-wall" : "sphere-sphere");
    }
  }
}

// A sphere held between the floor and a lid by adhesion to both; the lid then rises at 0.3 mm/s, slowly against the
// contacts' response (|delta_c| omega is 30 mm/s). The most tensile load on the lid is JKR's pull-off force
// (3/2) pi dgamma R (a wall contact: R* = R).
TEST(Adhesion, PullOffForceUnderDisplacementControl) {
  RunConfig c = adhesiveScene(CohesionModel::kJkr, 0.5);
  const double touch = 1e-9, vLid = 3e-4, settle = 0.01;
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
  c.planes[0].surface = 0;
  addParticle(c, {0, 0, kR - touch}, kR, 0);
  compute::MeshConfig lid;
  lid.name = "lid";
  const double L = 4 * kR, z = 2 * kR - 2 * touch;
  lid.vertices = {{-L, -L, z}, {L, -L, z}, {L, L, z}, {-L, L, z}};
  lid.triangles = {{0, 2, 1}, {0, 3, 2}};  // counter-clockwise seen from below
  lid.surface = {1, 1};
  lid.motion.velocity = {0, 0, vLid};
  lid.motion.startTime = settle;
  c.meshes = {lid};
  c.surfaceNames = {"floor", "lid"};
  c.sim.duration = 1;
  auto created = Simulation::create(c);
  ASSERT_TRUE(created.isOk()) << created.status().toString();
  Simulation& sim = *created.value();
  compute::Domain single;
  compute::SeriesConfig series;
  series.interval = sim.dt();
  backend::DemSeriesRecorder recorder(sim, single, series, c.surfaceNames);
  const double fc = 1.5 * kPi * kGamma * kR;
  const double until = settle + 8 * -cohesion::jkrBreakOverlap(jkrParams().jkrBreak, kR) / vLid;
  ASSERT_TRUE(sim.runUntil(until, [&](const Simulation& s) {
    recorder.sample(s, single);
    return Status::ok();
  }).isOk());
  const backend::ProbeSeries& s = recorder.series();
  std::size_t k = 0;
  while (k < s.names.size() && s.names[k] != "force_z:lid") ++k;
  ASSERT_LT(k, s.names.size());
  double most = 0, last = 0;
  for (double f : s.values[k])
    if (std::isfinite(f)) most = std::min(most, f), last = f;
  std::printf("lid: most tensile load %.5g N, JKR pull-off %.5g N (%+.2f %%); at the end %.3g N\n", most, fc,
              100 * (-most / fc - 1), last);
  EXPECT_NEAR(-most / fc, 1.0, 0.02);
  EXPECT_EQ(last, 0.0) << "a contact broke: the lid carries nothing at the end";
}

// A sphere at rest on the floor under gravity 100 g (a weight of 4.4 F_c, pressing it down): JKR's overlap for that load, and the
// constant model's (Hertz carrying the weight plus 2 pi dgamma R), within 1 %.
TEST(Adhesion, RestingOverlapUnderLoad) {
  const double g = 981, m = sphereMass(kR, kRho), w = m * g;
  for (CohesionModel model : {CohesionModel::kJkr, CohesionModel::kConstant}) {
    RunConfig c = adhesiveScene(model, 0.3);
    c.sim.gravity = {0, 0, -g};
    c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor")};
    addParticle(c, {0, 0, kR - 1e-9}, kR, 0);
    c.sim.duration = 1;
    auto sim = Simulation::create(c);
    ASSERT_TRUE(sim.isOk()) << sim.status().toString();
    ASSERT_TRUE(sim.value()->runUntil(0.2).isOk());
    const double overlap = kR - sim.value()->snapshot({"position"}).find("position")->as<Vec3d>()[0].z;
    const compute::ContactParams p = jkrParams();
    double expected = 0;
    if (model == CohesionModel::kJkr) {  // F_JKR(s) = w on the stable branch: bisect on s
      double lo = std::cbrt(0.25 * p.jkrB * kR), hi = 1.0;
      for (int k = 0; k < 200; ++k) {
        const double mid = 0.5 * (lo + hi);
        (cohesion::jkrForce(p.effYoung, p.jkrB, kR, mid) < w ? lo : hi) = mid;
      }
      expected = lo * lo * lo * lo / kR - p.jkrB * lo;
    } else {  // (4/3) E* sqrt(R) delta^{3/2} = w + 2 pi dgamma R
      expected = std::pow((w + 2 * kPi * kGamma * kR) / (4.0 / 3.0 * p.effYoung * std::sqrt(kR)), 2.0 / 3.0);
    }
    std::printf("%s: resting overlap %.6g m, theory %.6g m\n", model == CohesionModel::kJkr ? "JKR" : "constant", overlap,
                expected);
    EXPECT_NEAR(overlap / expected, 1.0, 0.01);
  }
}

// 27 adhesive spheres, each 1 um from its neighbours, pulled together: the contacts snap in and release kinetic
// energy, which the energy detector must not take for a blow-up; the clump holds together.
TEST(Adhesion, ClumpSnapsTogetherWithoutTrippingTheEnergyDetector) {
  RunConfig c = adhesiveScene(CohesionModel::kJkr, 0.5);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) addParticle(c, {2.001 * kR * i, 2.001 * kR * j, 2.001 * kR * k}, kR, 0,
                    {-1e-2 * (i - 1), -1e-2 * (j - 1), -1e-2 * (k - 1)});
  c.sim.duration = 0.05;
  auto sim = Simulation::create(c);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  ASSERT_TRUE(sim.value()->runUntil(0.05).isOk());
  const auto snap = sim.value()->snapshot({"position"});
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  double spread = 0;
  for (std::size_t i = 0; i < snap.n; ++i) spread = std::max(spread, norm(x[i] - x[13]));
  EXPECT_LT(spread, 3.5 * 2 * kR) << "the clump held together";
}

}  // namespace
}  // namespace pflow::test
