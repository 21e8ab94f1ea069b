// A run that goes wrong stops with an error that names the particle, the step and the quantity.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "compute/integrate/VelocityVerlet.h"
#include "compute/sim/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

// A 4x4x4 block of slightly compressed spheres in a box, stepped at 3 Rayleigh times: the contact
// oscillations grow without bound, and the run must stop with a clear error instead of carrying on.
TEST(Blowup, TimeStepFarTooLargeIsReported) {
  compute::RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, 0.9, 0.3)};
  const double r = 0.01, a = 2 * r * 0.995;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) addParticle(c, {r + i * a, r + j * a, r + k * a}, r, 0);
  const double side = r + 3 * a + r;
  c.planes = {plane({0, 0, 0}, {0, 0, 1}, 0, "floor"), plane({0, 0, 0}, {1, 0, 0}, 0, "x0"),
              plane({side, 0, 0}, {-1, 0, 0}, 0, "x1"), plane({0, 0, 0}, {0, 1, 0}, 0, "y0"),
              plane({0, side, 0}, {0, -1, 0}, 0, "y1")};
  c.sim.dt = 3 * compute::rayleighTime(r, 2800, 4.8e10, 0.2);
  c.sim.duration = 2000 * *c.sim.dt;
  auto sim = compute::Simulation::create(c);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  EXPECT_FALSE(sim.value()->timeStep().warnings.empty());  // the user was warned up front
  const Status s = sim.value()->runUntil(c.sim.duration);
  ASSERT_FALSE(s.isOk()) << "ran " << sim.value()->stepCount() << " steps without noticing";
  EXPECT_EQ(s.code(), StatusCode::kNumerical);
  std::printf("reported: %s\n", s.message().c_str());
  EXPECT_NE(s.message().find("particle "), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("at step "), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("time step too large"), std::string::npos) << s.message();
}

// The integrator's check flags the lowest particle with a non-finite value.
TEST(Blowup, NonFiniteValuesAreFlagged) {
  const int n = 4;
  Vec3d pos[n] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}}, vel[n] = {}, omega[n] = {}, force[n] = {},
        torque[n] = {};
  Vec3f moved[n] = {};
  double radius[n] = {1, 1, 1, 1}, mass[n] = {1, 1, 1, 1};
  force[2].y = std::numeric_limits<double>::quiet_NaN();
  torque[3].z = std::numeric_limits<double>::infinity();
  compute::Conditions cond;
  const compute::kernels::IntegrateArgs<double> a{pos, vel, omega, force, torque, radius, mass, moved, {0, 0, 0}, 1e-3, &cond};
  for (Index i = 0; i < n; ++i) compute::kernels::IntegrateSecondHalf<double>{a}(i);
  EXPECT_TRUE(cond.flags & compute::kNonFinite);
  EXPECT_EQ(cond.badParticle, 2u);
}

}  // namespace
}  // namespace pflow::test
