// Walls: a triangle-mesh floor behaves exactly like a plane (equilibrium overlap, rolling across
// edges and vertices without spurious forces), and prescribed mesh motion.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "compute/dem/geometry/MeshKernels.h"
#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

constexpr double kR = 5e-3, kE = 1e8, kNu = 0.3, kRho = 2500, kG = 9.81;

// A flat square floor at z = 0 of n x n cells of side a, each split into two triangles, normal +z.
compute::MeshConfig meshFloor(double lo, double a, int n, int material) {
  compute::MeshConfig m;
  m.name = "floor";
  m.material = material;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.push_back({lo + i * a, lo + j * a, 0});
  auto v = [n](int i, int j) { return std::uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.triangles.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
      m.triangles.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  return m;
}

double equilibriumOverlap(double Estar) {
  const double m = sphereMass(kR, kRho);
  return std::pow(3 * m * kG / (4 * Estar * std::sqrt(kR)), 2.0 / 3.0);
}

RunConfig floorScene(bool mesh, Vec3d x0, Vec3d v0, Vec3d w0, double e, double mu) {
  RunConfig c;
  c.materials = {material("ball", kE, kNu, kRho, e, mu), rigid(e, mu)};
  addParticle(c, x0, kR, 0, v0, w0);
  if (mesh) c.meshes.push_back(meshFloor(-0.05, 2e-3, 50, 1));
  else c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 1, "floor"));
  c.sim.gravity = {0, 0, -kG};
  c.sim.duration = 1;
  return c;
}

// Sphere released just touching the floor, damped to rest: the final overlap equals the Hertz
// equilibrium (3 m g / (4 E* sqrt R))^{2/3} and does not depend on whether the floor is a plane or
// a mesh, nor on where over the mesh (face, edge, vertex) it rests.
TEST(MeshFloor, RestingOverlapEqualsPlaneAndHertz) {
  const double Estar = kE / (1 - kNu * kNu);
  const double dEq = equilibriumOverlap(Estar);
  auto settle = [&](bool mesh, double x, double y) {
    auto sim = Simulation::create(floorScene(mesh, {x, y, kR}, {0, 0, 0}, {0, 0, 0}, 0.1, 0.5));
    EXPECT_TRUE(sim.isOk()) << sim.status().toString();
    EXPECT_TRUE(sim.value()->runUntil(0.05).isOk());
    return kR - sim.value()->snapshot().find("position")->as<Vec3d>()[0].z;
  };
  const double plane = settle(false, 0.0011, 0.0007);
  EXPECT_NEAR(plane, dEq, 1e-3 * dEq);
  EXPECT_NEAR(settle(true, 0.0011, 0.0007), plane, 1e-9);  // inside a face
  EXPECT_NEAR(settle(true, 0.001, 0.0013), plane, 1e-9);   // on an edge between two cells
  EXPECT_NEAR(settle(true, 0.001, 0.001), plane, 1e-9);    // on a diagonal edge
  EXPECT_NEAR(settle(true, 0.002, 0.002), plane, 1e-9);    // on a vertex shared by six triangles
}

// A sphere rolling across many triangle edges and vertices feels the same force, step by step, as
// on a plane: no bump at an edge, and the tangential spring carries over from triangle to triangle.
TEST(MeshFloor, RollingAcrossEdgesHasNoSpuriousForce) {
  const double Estar = kE / (1 - kNu * kNu);
  const double dEq = equilibriumOverlap(Estar);
  const double u = 0.2;
  const Vec3d x0{0.0003, 0.0004, kR - dEq}, v0{u, 0.6 * u, 0};
  const double lever = kR - 0.5 * dEq;
  const Vec3d w0{-v0.y / lever, v0.x / lever, 0};  // rolling: v + w x (-lever z) = 0
  auto plane = Simulation::create(floorScene(false, x0, v0, w0, 0.3, 0.5));
  auto mesh = Simulation::create(floorScene(true, x0, v0, w0, 0.3, 0.5));
  ASSERT_TRUE(plane.isOk() && mesh.isOk());
  const double mg = sphereMass(kR, kRho) * kG;
  double maxDiff = 0, maxTangential = 0;
  int steps = 0;
  while (plane.value()->time() < 0.04) {  // 8 mm by 4.8 mm: crosses a dozen edges and several vertices
    ASSERT_TRUE(plane.value()->step().isOk());
    ASSERT_TRUE(mesh.value()->step().isOk());
    const Vec3d fp = plane.value()->snapshot().find("force")->as<Vec3d>()[0];
    const Vec3d fm = mesh.value()->snapshot().find("force")->as<Vec3d>()[0];
    maxDiff = std::max(maxDiff, norm(fp - fm));
    maxTangential = std::max(maxTangential, std::hypot(fm.x, fm.y));
    ++steps;
  }
  EXPECT_GT(steps, 100);
  EXPECT_LT(maxDiff, 1e-6 * mg) << "largest force difference mesh vs plane";
  const Vec3d xp = plane.value()->snapshot().find("position")->as<Vec3d>()[0];
  const Vec3d xm = mesh.value()->snapshot().find("position")->as<Vec3d>()[0];
  EXPECT_NEAR(xm.x, xp.x, 1e-9);
  EXPECT_NEAR(xm.y, xp.y, 1e-9);
  EXPECT_GT(xp.x - x0.x, 0.007);
}

TEST(MeshMotion, TransformAndVelocityAgree) {
  compute::MeshMotionParams m{{0.1, 0, 0}, {1, 0, 0}, {0, 0, 1}, 2.0, 0.5};
  // Before the start nothing moves.
  EXPECT_EQ(norm(m.transform({2, 0, 0}, 0.3) - Vec3d{2, 0, 0}), 0.0);
  EXPECT_EQ(norm(m.velocityAt({2, 0, 0}, 0.3)), 0.0);
  // A quarter turn about z through the (moving) axis point.
  const double t = 0.5 + std::numbers::pi / 4;
  const Vec3d x = m.transform({2, 0, 0}, t);
  EXPECT_NEAR(x.x, 1 + 0.1 * (t - 0.5), 1e-12);
  EXPECT_NEAR(x.y, 1, 1e-12);
  // Velocity is the time derivative of the transform.
  const double h = 1e-6;
  const Vec3d fd = (1.0 / (2 * h)) * (m.transform({2, 0, 0}, t + h) - m.transform({2, 0, 0}, t - h));
  const Vec3d v = m.velocityAt(x, t);
  EXPECT_NEAR(v.x, fd.x, 1e-8);
  EXPECT_NEAR(v.y, fd.y, 1e-8);
}

// A floor mesh rising at constant speed carries a resting sphere with it.
TEST(MeshMotion, RisingFloorLiftsSphere) {
  RunConfig c = floorScene(true, {0.0011, 0.0007, kR}, {0, 0, 0}, {0, 0, 0}, 0.1, 0.5);
  c.meshes[0].motion.velocity = {0, 0, 0.05};
  c.meshes[0].motion.startTime = 0.01;
  auto sim = Simulation::create(c);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  ASSERT_TRUE(sim.value()->runUntil(0.06).isOk());
  const auto s = sim.value()->snapshot();
  EXPECT_NEAR(s.find("velocity")->as<Vec3d>()[0].z, 0.05, 1e-3);
  const double dEq = equilibriumOverlap(kE / (1 - kNu * kNu));
  EXPECT_NEAR(s.find("position")->as<Vec3d>()[0].z, kR - dEq + 0.05 * 0.05, 2e-5);
}

// A vibration on top of the translation and rotation: the transform is the closed form (the axis point carried by
// velocity t + A (sin(w t + phase) - sin phase)), and the velocity is its time derivative.
TEST(MeshMotion, VibrationFollowsItsClosedForm) {
  const double w = 2 * std::numbers::pi * 20, phase = 0.3;
  compute::MeshMotionParams m{{0.1, 0, 0}, {1, 0, 0}, {0, 0, 1}, 2.0, 0.5, {0, 0.002, 0.001}, w, phase};
  EXPECT_EQ(norm(m.transform({2, 0, 0}, 0.5) - Vec3d{2, 0, 0}), 0.0) << "at the start, where it was";
  const double t = 0.5 + 0.0123, tau = t - 0.5;
  const Vec3d x = m.transform({2, 0, 0}, t);
  const double s = std::sin(w * tau + phase) - std::sin(phase);
  const Vec3d axis{1 + 0.1 * tau, 0.002 * s, 0.001 * s};
  EXPECT_NEAR(x.x, axis.x + std::cos(2.0 * tau), 1e-12);
  EXPECT_NEAR(x.y, axis.y + std::sin(2.0 * tau), 1e-12);
  EXPECT_NEAR(x.z, axis.z, 1e-12);
  const double h = 1e-7;
  const Vec3d fd = (1.0 / (2 * h)) * (m.transform({2, 0, 0}, t + h) - m.transform({2, 0, 0}, t - h));
  const Vec3d v = m.velocityAt(x, t);
  EXPECT_NEAR(v.x, fd.x, 1e-7);
  EXPECT_NEAR(v.y, fd.y, 1e-7);
  EXPECT_NEAR(v.z, fd.z, 1e-7);
}

// A sphere on a floor mesh shaken vertically at amplitude A and angular frequency w: below the relative acceleration
// Gamma = A w^2 / g = 1 it rides the floor and never leaves it; above, it takes off (the shaker's closed form: the
// floor's downward acceleration exceeds g in part of each cycle).
TEST(MeshMotion, ShakenFloorCarriesASphereBelowOneGAndThrowsItAbove) {
  const double A = 1e-3;
  auto largestGap = [&](double gamma) {
    RunConfig c = floorScene(true, {0.0011, 0.0007, kR}, {0, 0, 0}, {0, 0, 0}, 0.1, 0.5);
    const double w = std::sqrt(gamma * kG / A);
    c.meshes[0].motion.vibration = {0, 0, A};
    c.meshes[0].motion.frequency = w / (2 * std::numbers::pi);
    c.meshes[0].motion.startTime = 0.1;  // after it settled
    auto sim = Simulation::create(c);
    EXPECT_TRUE(sim.isOk()) << sim.status().toString();
    double gap = -1;
    EXPECT_TRUE(sim.value()->runUntil(0.5, [&](const Simulation& s) {
      if (s.time() < 0.15) return Status::ok();
      const double z = s.snapshot({"position"}).find("position")->as<Vec3d>()[0].z;
      const double floor = A * std::sin(w * (s.time() - 0.1));
      gap = std::max(gap, z - kR - floor);
      return Status::ok();
    }).isOk());
    return gap;
  };
  const double gentle = largestGap(0.5), strong = largestGap(3.0);
  std::printf("largest gap under the sphere: %.3g m at Gamma 0.5, %.3g m at Gamma 3\n", gentle, strong);
  EXPECT_LT(gentle, 0.0) << "it left a floor accelerating downwards at half g";
  EXPECT_GT(strong, 1e-4) << "it stayed on a floor accelerating downwards at 3 g";
}

// A piecewise-linear velocity profile: the displacement is the profile's exact integral (trapezoids), constant
// velocity before the first point and after the last, and the velocity its derivative.
TEST(MeshMotion, VelocityProfileIntegratesExactly) {
  compute::MeshMotionParams m{{0, 0, 0}, {0, 0, 0}, {0, 0, 1}, 0.0, 0.1, {0, 0, 0}, 0.0, 0.0, 3, {0.0, 0.2, 0.5},
                              {Vec3d{0, 0, 0}, Vec3d{0, 0, 0.4}, Vec3d{0.3, 0, 0.4}}};
  auto z = [&](double t) { return m.transform({0, 0, 0}, t); };
  EXPECT_EQ(norm(z(0.1)), 0.0);
  EXPECT_NEAR(z(0.1 + 0.2).z, 0.5 * 0.2 * 0.4, 1e-15);                       // the ramp: a triangle
  EXPECT_NEAR(z(0.1 + 0.35).z, 0.04 + 0.15 * 0.4, 1e-15);                    // then constant 0.4 in z
  EXPECT_NEAR(z(0.1 + 0.35).x, 0.5 * 0.15 * (0.3 * 0.15 / 0.3), 1e-15);      // x ramps from 0.2 s
  EXPECT_NEAR(z(0.1 + 1.0).x, 0.5 * 0.3 * 0.3 + 0.5 * 0.3, 1e-14);           // after the last point: 0.3 m/s
  const double h = 1e-7;
  for (double t : {0.15, 0.33, 0.52, 0.9}) {
    const Vec3d fd = (1.0 / (2 * h)) * (z(t + h) - z(t - h));
    const Vec3d v = m.velocityAt(z(t), t);
    EXPECT_NEAR(v.x, fd.x, 1e-7) << t;
    EXPECT_NEAR(v.z, fd.z, 1e-7) << t;
  }
}

// A floor lifted by a velocity profile (accelerate, cruise, stop: never faster than g downwards) carries a resting
// sphere along its closed-form path: at the end the sphere is up by the profile's integral.
TEST(MeshMotion, ProfiledLiftCarriesSphere) {
  RunConfig c = floorScene(true, {0.0011, 0.0007, kR}, {0, 0, 0}, {0, 0, 0}, 0.1, 0.5);
  c.meshes[0].motion.startTime = 0.05;
  c.meshes[0].motion.profile = {{0.0, {0, 0, 0}}, {0.1, {0, 0, 0.05}}, {0.2, {0, 0, 0.05}}, {0.3, {0, 0, 0}}};
  auto sim = Simulation::create(c);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  const double before = [&] {
    EXPECT_TRUE(sim.value()->runUntil(0.05).isOk());
    return sim.value()->snapshot({"position"}).find("position")->as<Vec3d>()[0].z;
  }();
  ASSERT_TRUE(sim.value()->runUntil(0.45).isOk());
  const double after = sim.value()->snapshot({"position"}).find("position")->as<Vec3d>()[0].z;
  const double lift = 0.5 * 0.1 * 0.05 + 0.1 * 0.05 + 0.5 * 0.1 * 0.05;  // 0.01 m
  EXPECT_NEAR(after - before, lift, 1e-6) << "lifted " << after - before << " m";
}

}  // namespace
}  // namespace pflow::test
