// The modified dynamic boundary (sph.boundary_density: mdbc, SphMdbc.h): ghost nodes across the interface, the
// first-order interpolation that recovers a linear field exactly, walls that carry the fluid's hydrostatic pressure,
// and a tank at rest that stays so (docs/sph.md section 6).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "compute/sph/SphMdbc.h"
#include "tests/support/SphExpect.h"

using namespace pflow;
using namespace pflow::compute;
using namespace pflow::compute::sph;

namespace {

// A tank's inside [0, 1] x [0, 0.5] x [0, 1] and a box [0.4, 0.6] x [0.1, 0.3] x [0, 0.2] standing on its floor.
MdbcGeometry tankAndBox() {
  MdbcGeometry m;
  m.on = true;
  m.tank = true;
  m.tankLo = {0, 0, 0};
  m.tankHi = {1, 0.5, 1};
  m.obstacles = 1;
  m.obLo[0] = {0.4, 0.1, 0};
  m.obHi[0] = {0.6, 0.3, 0.2};
  m.wetLo[0] = 0b011;  // x and y faces; the bottom stands on the floor
  m.wetHi[0] = 0b111;
  m.tie = 1e-9;
  return m;
}

void expectNear3(Vec3d a, Vec3d b) {
  EXPECT_NEAR(a.x, b.x, 1e-12);
  EXPECT_NEAR(a.y, b.y, 1e-12);
  EXPECT_NEAR(a.z, b.z, 1e-12);
}

}  // namespace

// The geometry as built from a scene (mdbcGeometry): the interfaces at whole spacings from each box's low corner; a
// face standing on the floor, or against another obstacle it overlaps across, does not meet the fluid.
TEST(SphMdbc, GeometryFromTheScene) {
  RunConfig c = test::damBreak3D(0.02, 0.1);
  c.sph.mdbc = true;
  compute::sph::addObstacle(c.sph, "low", {0.3, 0.02, 0}, {0.41, 0.1, 0.1});  // 0.11: filled 0.10 along x
  compute::sph::addObstacle(c.sph, "high", {0.3, 0.02, 0.1}, {0.4, 0.1, 0.2});
  const MdbcGeometry m = mdbcGeometry(c.sph);
  ASSERT_EQ(m.obstacles, 2);
  EXPECT_TRUE(m.tank);
  EXPECT_TRUE(m.openTop);  // addTank's default
  expectNear3(m.obHi[0], {0.4, 0.1, 0.1});
  expectNear3(m.tankHi, {0.5, 0.12, 0.4});
  EXPECT_EQ(m.wetLo[0], 0b011);  // the floor under it
  EXPECT_EQ(m.wetHi[0], 0b011);  // the upper box on it
  EXPECT_EQ(m.wetLo[1], 0b011);  // on the lower box
  EXPECT_EQ(m.wetHi[1], 0b111);
}

// Overlapping obstacles are refused under mdbc, each pair named; an obstacle thinner than twice the kernel's support
// with fluid on both sides is named as a warning (mdbcThinObstacles), not refused.
TEST(SphMdbc, OverlapsAreRefusedThinBoxesNamed) {
  RunConfig c = test::damBreak3D(0.02, 0.1);
  c.sph.mdbc = true;
  compute::sph::addObstacle(c.sph, "a", {0.26, 0.0, 0}, {0.4, 0.12, 0.2});
  compute::sph::addObstacle(c.sph, "b", {0.3, 0.0, 0}, {0.44, 0.12, 0.2});
  compute::sph::addObstacle(c.sph, "baffle", {0.22, 0.0, 0.1}, {0.24, 0.12, 0.3});
  const std::string m = c.sph.validate(c.sim).toStatus("").message();
  EXPECT_NE(m.find("b overlaps a"), std::string::npos) << m;
  EXPECT_EQ(m.find("baffle"), std::string::npos) << m;
  const std::vector<std::string> thin = mdbcThinObstacles(c.sph);
  ASSERT_EQ(thin.size(), 1u);
  EXPECT_NE(thin[0].find("baffle is 0.02 m thick along x, under twice the kernel's support (0.12 m)"), std::string::npos) << thin[0];
}

// A wall particle's ghost is its mirror image across the tank's inside (a corner particle's through the corner); an
// obstacle particle's across the nearest face that meets the fluid (both where two tie: the box's diagonal), never
// across the face it stands on; a particle in neither has none.
TEST(SphMdbc, GhostNodesMirrorAcrossTheInterface) {
  const MdbcGeometry m = tankAndBox();
  Vec3d g;
  ASSERT_TRUE(m.ghost({0.5, 0.25, -0.015}, g));  // under the floor
  expectNear3(g, {0.5, 0.25, 0.015});
  ASSERT_TRUE(m.ghost({-0.005, 0.25, -0.025}, g));  // the edge of the floor and the wall x = 0
  expectNear3(g, {0.005, 0.25, 0.025});
  ASSERT_TRUE(m.ghost({1.01, 0.51, 0.5}, g));  // the edge of two side walls
  expectNear3(g, {0.99, 0.49, 0.5});
  ASSERT_TRUE(m.ghost({0.59, 0.2, 0.05}, g));  // in the box, 0.01 behind its face x = 0.6
  expectNear3(g, {0.61, 0.2, 0.05});
  ASSERT_TRUE(m.ghost({0.45, 0.2, 0.02}, g));  // just above the floor: not across the bottom (it stands on the floor)
  expectNear3(g, {0.35, 0.2, 0.02});
  ASSERT_TRUE(m.ghost({0.5, 0.2, 0.15}, g));  // nearest to the top
  expectNear3(g, {0.5, 0.2, 0.25});
  ASSERT_TRUE(m.ghost({0.5, 0.2, 0.05}, g));  // at the box's centre line: the four side faces tie, one a side of each axis
  expectNear3(g, {0.3, 0.0, 0.05});
  ASSERT_TRUE(m.ghost({0.595, 0.2, 0.195}, g));  // on the diagonal of the face x = 0.6 and the top
  expectNear3(g, {0.605, 0.2, 0.205});
  EXPECT_FALSE(m.ghost({0.2, 0.25, 0.5}, g));  // in the fluid
  MdbcGeometry open = m;  // an open top, and a pillar standing above it: its particles there get its own ghosts
  open.openTop = true;
  open.obstacles = 2;
  open.obLo[1] = {0.8, 0.1, 0};
  open.obHi[1] = {0.9, 0.3, 1.5};
  open.wetLo[1] = 0b011;
  open.wetHi[1] = 0b011;
  ASSERT_TRUE(open.ghost({0.805, 0.2, 1.2}, g));
  expectNear3(g, {0.795, 0.2, 1.2});
  EXPECT_FALSE(open.ghost({0.5, 0.25, 1.01}, g));  // above an open top: no wall
  MdbcGeometry planar = m;
  planar.planar = true;  // a 2D run: y is no axis
  ASSERT_TRUE(planar.ghost({1.01, 0.9, 0.5}, g));
  expectNear3(g, {0.99, 0.9, 0.5});
}

// The interpolation is first-order consistent: on a lattice of fluid filling only the half-space z > 0 (a wall's
// ghost node sees a truncated kernel), a linear density field is recovered exactly at the ghost node and extrapolated
// exactly to the boundary particle, in 3D and 2D, with either kernel.
TEST(SphMdbc, ExtrapolationRecoversALinearField) {
  for (int dim : {2, 3})
    for (KernelKind kind : {KernelKind::kWendlandC2, KernelKind::kCubicSpline}) {
      const double dp = 0.01, h = 2 * dp;
      const Kernel<double> w = Kernel<double>::make(kind, dim, h);
      const Vec3d g{0.0013, 0.0007, 0.014};  // 1.4 dp above the interface z = 0, off the lattice
      const Vec3d xb{g.x, g.y, -g.z};
      auto rhoAt = [](Vec3d x) { return 1000.0 + 30.0 * x.x - 12.0 * x.y + 250.0 * x.z; };
      MdbcMoments<double> mom;
      const int n = 6;
      for (int k = 0; k < n; ++k)
        for (int j = (dim == 2 ? 0 : -n); j <= (dim == 2 ? 0 : n); ++j)
          for (int i = -n; i <= n; ++i) {
            const Vec3d x{i * dp, dim == 2 ? g.y : j * dp, (k + 0.5) * dp};
            const Vec3d d = x - g;
            const double r = norm(d);
            if (r >= w.support()) continue;
            const double volume = dim == 2 ? dp * dp : dp * dp * dp;
            mom.add((1 / h) * d, w.w(r), (-h * w.f(r)) * d, volume, dim == 2 ? rhoAt({x.x, g.y, x.z}) : rhoAt(x));
          }
      double u[4];
      ASSERT_TRUE(mdbcSolve(mom, dim == 2, 1e-3, u)) << dim << "D";
      EXPECT_NEAR(u[0], rhoAt(g), 1e-9 * 1000) << dim << "D";
      EXPECT_NEAR(u[1] / h, 30.0, 1e-6) << dim << "D";
      EXPECT_NEAR(u[3] / h, 250.0, 1e-6) << dim << "D";
      if (dim == 3) EXPECT_NEAR(u[2] / h, -12.0, 1e-6);
      else EXPECT_EQ(u[2], 0.0);
      const Vec3d s = (1 / h) * (xb - g);
      EXPECT_NEAR(u[0] + u[1] * s.x + u[2] * s.y + u[3] * s.z, rhoAt(xb), 1e-9 * 1000) << dim << "D";
    }
  MdbcMoments<double> none;  // no fluid: no solution
  double u[4];
  EXPECT_FALSE(mdbcSolve(none, false, 1e-3, u));
}

namespace {

RunConfig mdbcTank(double dp, double depth, double duration) {
  RunConfig c = test::hydrostaticTank(dp, 0.2, depth, duration);
  c.sph.mdbc = true;
  c.sph.integrator = Integrator::kVelocityVerlet;
  return c;
}

}  // namespace

// After one evaluation of the rates, the walls carry the pressure the fluid's hydrostatic profile extrapolates to
// them (within 2 % of rho g H): the floor under the fluid, which the start sets hydrostatic for either boundary, and
// the side walls beside it, which start at rho0 (p = 0) and only mDBC lifts to rho g (H - z). No wall particle reads
// below zero (half a spacing above the surface the outer layers' extrapolation gives -49 Pa: held at rho0), and those
// h/2 to 2h above it, whose ghost nodes see too little fluid, read rho0. In double
// and in float (the moments in the run's precision).
class SphMdbcWalls : public ::testing::TestWithParam<Precision> {};

TEST_P(SphMdbcWalls, CarryTheFluidsHydrostaticPressure) {
  const double dp = 0.01, depth = 0.2, g = 9.81, rho = 1000, width = 0.2;
  RunConfig c = mdbcTank(dp, depth, 1.0);
  c.sim.precision = GetParam();
  auto created = SphSimulation::create(c, {});
  ASSERT_TRUE(created.isOk()) << created.status().message();
  SphSimulation& sim = *created.value();
  ASSERT_TRUE(sim.step().isOk());
  const double h = sim.derived().h;
  const ParticleSnapshot s = sim.snapshot();
  const auto* x = s.find("position")->as<Vec3d>();
  const auto* p = s.find("pressure")->as<double>();
  const auto* kind = s.find("kind")->as<std::int32_t>();
  int floor = 0, side = 0, above = 0;
  for (std::size_t i = 0; i < s.n; ++i) {
    if (kind[i] == 0) continue;
    const double z = x[i].z;
    EXPECT_GE(p[i], 0.0) << "a wall pulling the fluid at x = " << x[i].x << ", z = " << z;  // the floor at rho0
    const bool inSide = x[i].x < 0 || x[i].x > width;
    if (z < 0 && !inSide) {
      ++floor;
      EXPECT_NEAR(p[i], rho * g * (depth - z), 0.02 * rho * g * depth) << "floor particle at z = " << z;
    } else if (inSide && z > 2 * h && z < depth - 2 * h) {
      ++side;
      EXPECT_NEAR(p[i], rho * g * (depth - z), 0.02 * rho * g * depth) << "side wall particle at z = " << z;
    } else if (inSide && z > depth + 0.5 * h && z < depth + 2 * h) {
      ++above;
      EXPECT_EQ(p[i], 0.0) << "wall particle just above the surface at z = " << z;
    }
  }
  EXPECT_GT(floor, 40);
  EXPECT_GT(side, 40);
  EXPECT_GT(above, 6);
}

INSTANTIATE_TEST_SUITE_P(Precisions, SphMdbcWalls, ::testing::Values(Precision::kDouble, Precision::kFloat),
                         [](const auto& info) { return std::string(info.param == Precision::kFloat ? "Float" : "Double"); });

// 20 x 20 particles of water, 0.2 m deep, at rest for 2 s with the modified boundary (each integrator): as the dynamic boundary's
// test (sph_flow_test), the pressure in layers within 2 % of rho g (H - z) and the fluid still (max speed < 1 % of
// sqrt(g H)); and no gap: the free surface stays within a tenth of a spacing of the column's initial top, where the
// dynamic boundary's keeps the fluid about an h off the walls.
class SphMdbcTank : public ::testing::TestWithParam<Integrator> {};

TEST_P(SphMdbcTank, AtRestKeepsThePressureProfileAndStaysStill) {
  const double dp = 0.01, depth = 0.2;
  RunConfig c = mdbcTank(dp, depth, 2.0);
  c.sph.integrator = GetParam();
  auto created = SphSimulation::create(c, {});
  ASSERT_TRUE(created.isOk()) << created.status().message();
  SphSimulation& sim = *created.value();
  ASSERT_TRUE(sim.runUntil(2.0).isOk());
  const test::TankAtRest r = test::expectTankAtRest(sim.snapshot(), dp, sim.derived().h, depth, 10);
  EXPECT_NEAR(r.surface, depth, 0.1 * dp) << "the settled surface";
}

INSTANTIATE_TEST_SUITE_P(Integrators, SphMdbcTank, ::testing::Values(Integrator::kSymplectic, Integrator::kVerlet, Integrator::kVelocityVerlet),
                         test::integratorTestName);

// The 2D dam break at 40 x 80 with the modified boundary, the example's other parameters unchanged: the surge front
// follows Martin & Moyce (1952) with the same two checks and tolerances as the dynamic boundary's
// (SphDamBreak.SurgeFrontFollowsMartinMoyce: the speed within 5 %, the times within 8 % with the gate's 0.175).
TEST(SphMdbc, DamBreakFrontFollowsMartinMoyce) {
  const double dp = 0.005;
  RunConfig c = test::damBreak2D(dp);
  c.sph.mdbc = true;
  auto sim = SphSimulation::create(c, {});
  ASSERT_TRUE(sim.isOk()) << sim.status().message();
  test::expectFrontFollowsMartinMoyce(*sim.value(), dp, "mdbc: ");
}

// The 3D dam break of the GPU comparison (SphCudaVsCpu.ModifiedBoundaryDamBreakAgrees) on the CPU: a box across the
// tank in the front's path; by 0.1 s the front has hit it and the box's particles facing the flow carry pressure.
TEST(SphMdbc, BoxInA3DDamBreakTakesTheImpact) {
  RunConfig c = test::damBreak3D(0.02, 0.1);
  compute::sph::addObstacle(c.sph, "box", {0.3, 0.0, 0}, {0.44, 0.12, 0.08});
  c.sph.mdbc = true;
  c.sph.integrator = Integrator::kVelocityVerlet;
  auto created = SphSimulation::create(c, {});
  ASSERT_TRUE(created.isOk()) << created.status().message();
  ASSERT_TRUE(created.value()->runUntil(0.1).isOk());
  const ParticleSnapshot s = created.value()->snapshot();
  const auto* x = s.find("position")->as<Vec3d>();
  const auto* p = s.find("pressure")->as<double>();
  const auto* kind = s.find("kind")->as<std::int32_t>();
  double face = 0;
  for (std::size_t i = 0; i < s.n; ++i)
    if (kind[i] != 0 && x[i].x > 0.3 && x[i].x < 0.34 && x[i].z > 0 && x[i].z < 0.08) face = std::max(face, p[i]);
  EXPECT_GT(face, 100.0) << "the largest pressure on the box's face [Pa]";
  std::printf("largest pressure on the box's face at 0.1 s: %.0f Pa\n", face);
}
