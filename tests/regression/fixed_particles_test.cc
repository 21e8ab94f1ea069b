// Fixed particles (a material with `fixed: true`: beads glued into a rough floor or wall). They do not move, whatever
// hits them, and a free sphere's impact on one is damped as an impact on a wall: the contact's effective mass is the
// free sphere's own, so the requested restitution comes back as it does off a plane. With the effective mass of two
// free spheres (half the mass) the dashpot would be 1/sqrt(2) too weak and the rebound too fast.
#include <gtest/gtest.h>

#include <cmath>

#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

compute::MaterialConfig glued(compute::MaterialConfig m) {
  m.name += "_glued";
  m.fixed = true;
  return m;
}

// A sphere at speed v head-on onto a fixed sphere (or, `onPlane`, a plane of a rigid material): its speed after
// over before.
double rebound(double e, double v, bool onPlane) {
  const double r = 1e-3;
  RunConfig c;
  const compute::MaterialConfig glass = material("glass", 1e7, 0.3, 2500, e, 0.3);
  if (onPlane) {
    c.materials = {glass, rigid(e, 0.3)};
    c.planes = {plane({0, 0, 0}, {0, 0, 1}, 1, "floor")};
    addParticle(c, {0, 0, r + 1e-7}, r, 0, {0, 0, -v});
  } else {
    c.materials = {glass, glued(glass)};  // the same elastic constants: E* is the pair's, not a rigid wall's
    addParticle(c, {0, 0, -r}, r, 1);
    addParticle(c, {0, 0, r + 1e-7}, r, 0, {0, 0, -v});
  }
  c.sim.gravity = {0, 0, 0};
  c.sim.duration = 1;
  auto sim = Simulation::create(c);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  if (!sim.isOk()) return 0;
  const double tc = hertzImpact(1e7 / (1 - 0.09) / (onPlane ? 1 : 2), onPlane ? r : r / 2, sphereMass(r, 2500), v).contactTime;
  EXPECT_TRUE(sim.value()->runUntil(3 * tc).isOk());
  const auto snap = sim.value()->snapshot({"velocity", "position", "id"});
  const Vec3d* vel = snap.find("velocity")->as<Vec3d>();
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  const Gid* id = snap.find("id")->as<Gid>();
  double out = 0;
  for (std::size_t k = 0; k < snap.n; ++k) {
    if (!onPlane && id[k] == 0) {  // the fixed sphere: where it was, at rest
      EXPECT_EQ(x[k].z, -r);
      EXPECT_EQ(x[k].x, 0.0);
      EXPECT_EQ(norm(vel[k]), 0.0);
    } else {
      out = vel[k].z / v;
    }
  }
  return out;
}

// The requested restitution off a fixed sphere, as off a plane, within the 1 % that the default step holds it to
// (restitution_step_test), at e = 0.3 and 0.8 and at 0.1 and 1 m/s.
TEST(FixedParticles, AFreeSphereReboundsAsOffAWall) {
  for (double e : {0.3, 0.8})
    for (double v : {0.1, 1.0}) {
      const double fixed = rebound(e, v, false), wall = rebound(e, v, true);
      std::printf("e %.2f v %.2f m/s: off a fixed sphere %.4f, off a plane %.4f\n", e, v, fixed, wall);
      EXPECT_NEAR(fixed, e, 0.01 * e) << "e " << e << " v " << v;
      EXPECT_NEAR(fixed, wall, 0.01 * e) << "e " << e << " v " << v;
    }
}

// A floor of glued beads carries a heap of free ones dropped onto it with friction and rolling resistance: the glued
// beads stay exactly where they were, with no velocity or spin, and the free beads come to rest on top of them.
TEST(FixedParticles, AGluedFloorCarriesAHeapAndStaysPut) {
  const double r = 1e-3;
  RunConfig c;
  const compute::MaterialConfig glass = material("glass", 1e7, 0.3, 2500, 0.5, 0.5, 0.05);
  c.materials = {glass, glued(glass)};
  const int n = 8;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) addParticle(c, {(2 * i + (j % 2)) * r, j * std::sqrt(3.0) * r, 0}, r, 1);
  for (int k = 0; k < 40; ++k) addParticle(c, {(2 + k % 4) * 2.2 * r, (1 + (k / 4) % 4) * 2.2 * r, 3 * r + 2.2 * r * (k / 16)}, 0.9 * r, 0);
  c.sim.gravity = {0, 0, -9.81};
  c.sim.duration = 1;
  auto sim = Simulation::create(c);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  ASSERT_TRUE(sim.value()->runUntil(0.4).isOk());
  const auto snap = sim.value()->snapshot({"position", "velocity", "angular_velocity", "id"});
  const Vec3d* x = snap.find("position")->as<Vec3d>();
  const Vec3d* v = snap.find("velocity")->as<Vec3d>();
  const Vec3d* w = snap.find("angular_velocity")->as<Vec3d>();
  const Gid* id = snap.find("id")->as<Gid>();
  double fastest = 0;
  int onTop = 0;
  for (std::size_t k = 0; k < snap.n; ++k) {
    const std::size_t g = std::size_t(id[k]);
    if (g < std::size_t(n * n)) {
      EXPECT_EQ(x[k].x, c.particles.position[g].x);
      EXPECT_EQ(x[k].y, c.particles.position[g].y);
      EXPECT_EQ(x[k].z, c.particles.position[g].z);
      EXPECT_EQ(norm(v[k]) + norm(w[k]), 0.0);
    } else {
      fastest = std::max(fastest, norm(v[k]));
      onTop += x[k].z > r;  // above the glued layer's centres (the ones that stayed on the floor)
    }
  }
  std::printf("free beads above the glued layer: %d of 40, fastest %.3g m/s\n", onTop, fastest);
  EXPECT_GE(onTop, 30);  // some roll off the floor's edge and fall
}

}  // namespace
}  // namespace pflow::test
