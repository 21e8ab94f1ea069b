// Mirror walls (sph.boundary: mirror; docs/sph.md, "Mirror walls"): the images' geometry, a tank at rest, the dam
// break against Martin & Moyce with the same tolerances as the dynamic boundary particles', and a particle that
// would cross a wall being put back.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/SphExpect.h"

using namespace pflow;
using namespace pflow::compute;
using namespace pflow::compute::sph;

namespace {

MirrorWalls box2D(bool noSlip) {
  MirrorWalls m;
  m.any = true;
  m.noSlip = noSlip;
  m.reach = 0.03;
  m.lo[0] = m.hi[0] = true;
  m.lo[2] = true;  // open top
  m.loAt[0] = 0, m.hiAt[0] = 1, m.loAt[2] = 0, m.hiAt[2] = 1.2;
  return m;
}

// Which walls a point is near, its images and their velocities.
TEST(SphMirror, ImagesOfAPointNearACornerAndTheirVelocities) {
  const MirrorWalls m = box2D(true);
  EXPECT_EQ(m.near({0.5, 0, 0.5}), 0);
  EXPECT_EQ(m.near({0.01, 0, 0.5}), 1);         // the left wall
  EXPECT_EQ(m.near({0.99, 0, 0.5}), 8);         // the right wall
  EXPECT_EQ(m.near({0.5, 0, 1.19}), 0);         // an open top is no wall
  const int corner = m.near({0.01, 0, 0.02});   // the left wall and the floor
  EXPECT_EQ(corner, 1 | 4);
  int images = 0;
  for (int s = corner; s != 0; s = (s - 1) & corner) ++images;
  EXPECT_EQ(images, 3);  // across each wall and across both
  const Vec3d both = m.reflect({0.01, 0, 0.02}, corner);
  EXPECT_DOUBLE_EQ(both.x, -0.01);
  EXPECT_DOUBLE_EQ(both.z, -0.02);
  const Vec3<double> v{1, 0, -2};
  const auto noSlip = m.imageVelocity(v, 1, true), twice = m.imageVelocity(v, corner, true), slip = m.imageVelocity(v, 4, false);
  EXPECT_EQ(noSlip.x, -1);  // reversed across one wall
  EXPECT_EQ(noSlip.z, 2);
  EXPECT_EQ(twice.x, 1);    // and back across two
  EXPECT_EQ(slip.x, 1);     // free slip across the floor: only the normal part
  EXPECT_EQ(slip.z, 2);
  // A particle past a wall is put back, its normal velocity turned inward.
  Vec3d x{-0.001, 0, 0.5};
  Vec3<double> u{-3, 0, 1};
  EXPECT_TRUE(m.keepInside(x, u));
  EXPECT_DOUBLE_EQ(x.x, 0.001);
  EXPECT_EQ(u.x, 3);
  EXPECT_EQ(u.z, 1);
  EXPECT_FALSE(m.keepInside(x, u));
}

// The tank at rest of SphHydrostatic with mirror walls: the same bounds (pressure in layers within 2 % of
// rho g H of rho g (H - z), max speed under 1 % of sqrt(g H)); with no wall particles there is no gap, so the
// surface stays at the initial depth within half a spacing.
TEST(SphMirror, TankAtRestKeepsThePressureProfileAndStaysStill) {
  const double dp = 0.01, depth = 0.2;
  RunConfig c = test::withMirrorWalls(test::hydrostaticTank(dp, 0.2, depth, 2.0));
  auto created = SphSimulation::create(c, {});
  ASSERT_TRUE(created.isOk()) << created.status().message();
  SphSimulation& sim = *created.value();
  ASSERT_TRUE(sim.runUntil(2.0).isOk());
  const test::TankAtRest r = test::expectTankAtRest(sim.snapshot(), dp, sim.derived().h, depth, 14);
  EXPECT_NEAR(r.surface, depth, 0.5 * dp);
  EXPECT_GT(r.lowest, 0.0);
  EXPECT_GT(r.leftmost, 0.0);
  std::printf("mirror tank after 2 s: surface %.4f m (initial %.4f), lowest %.4f m, max speed %.2e m/s\n", r.surface, depth, r.lowest,
              r.maxSpeed);
}

// The dam break of SphDamBreak.SurgeFrontFollowsMartinMoyce (40 x 80, the same parameters) with mirror walls:
// the same tolerances (times within 8 % after the gate's 0.175, speed within 5 %), and the front reaches the far
// wall (at about 0.4 s) without passing it, through the impact and the first 0.15 s of the run-up (until
// 2026-11-29 to 0.8 s, which took two thirds of the test's 65 s on two cores).
TEST(SphMirror, DamBreakFollowsMartinMoyce) {
  const double dp = 0.005;
  RunConfig c = test::withMirrorWalls(test::damBreak2D(dp));
  auto sim = SphSimulation::create(c, {});
  ASSERT_TRUE(sim.isOk()) << sim.status().message();
  test::expectFrontFollowsMartinMoyce(*sim.value(), dp, "mirror ");
  ASSERT_TRUE(sim.value()->runUntil(0.55).isOk());
  EXPECT_LE(sim.value()->fluidReach({1, 0, 0}), 1.0);  // at the far wall, not through it
  EXPECT_GT(sim.value()->fluidReach({1, 0, 0}), 0.98);
  std::printf("mirror reach at 0.55 s: %.4f m\n", sim.value()->fluidReach({1, 0, 0}));
}

}  // namespace
