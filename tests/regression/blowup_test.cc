// A run that goes wrong stops with an error that names the particle, the step and the quantity.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "compute/dem/integrate/VelocityVerlet.h"
#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

// A 4x4x4 block of slightly compressed spheres in a box, stepped at 3 Rayleigh times: the contact
// oscillations grow without bound, and the run must stop with a clear error instead of carrying on.
TEST(Blowup, TimeStepFarTooLargeIsReported) {
  const compute::RunConfig c = compressedBlock(3, 0.9);
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

// A run shorter than the energy detector's interval (10 steps) that gains energy must not end as a success (issue 21:
// 5 steps at 1.5 Rayleigh times quadrupled the kinetic energy and exited 0). The gain sits partly in the contacts,
// under the running detector's bound: the end-of-run balance with the stored elastic energy catches it.
TEST(Blowup, ShortRunThatGainsEnergyFails) {
  compute::RunConfig c = compressedBlock(1.5, 1.0);
  c.sim.duration = 5 * *c.sim.dt;
  for (bool scheduled : {false, true}) {
    auto sim = compute::Simulation::create(c);
    ASSERT_TRUE(sim.isOk()) << sim.status().toString();
    if (scheduled) sim.value()->scheduleOutput(0, c.sim.duration);  // as pflow run and the worker do
    const double e0 = sim.value()->engine().mechanicalEnergy(), el0 = sim.value()->engine().elasticEnergy();
    Status s = sim.value()->runUntil(c.sim.duration);
    const double e1 = sim.value()->engine().mechanicalEnergy(), el1 = sim.value()->engine().elasticEnergy();
    std::printf("mechanical %g -> %g J, elastic %g -> %g J, total %g -> %g J\n", e0, e1, el0, el1, e0 + el0, e1 + el1);
    ASSERT_GT(e1 + el1, 1.2 * (e0 + el0)) << "the scene no longer gains energy in 5 steps";
    if (s.isOk()) s = sim.value()->finishRun();
    ASSERT_FALSE(s.isOk()) << "5 steps took the mechanical energy from " << e0 << " J to " << e1 << " J and ended fine";
    EXPECT_EQ(s.code(), StatusCode::kNumerical) << s.message();
    EXPECT_NE(s.message().find("energy growth"), std::string::npos) << s.message();
  }
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

// The skin test's float accumulator of the displacement since rebuild rounds each sum away from zero:
// it never under-reads, however slowly a particle creeps (a plain float sum stops growing once a step is
// below half a unit in the last place), and it over-reads by at most one unit in the last place per step.
TEST(SkinTest, CreepingParticleIsNeverUnderRead) {
  constexpr Index n = 1;
  Vec3d pos[n] = {{0.5, 0.5, 0.5}}, force[n] = {}, torque[n] = {};
  const double dt = 1e-6, speed = 1.5e-6;  // 1.5e-12 m per step, below half an ulp of 6e-5 m (3.6e-12 m)
  Vec3d vel[n] = {{speed, 0, 0}}, omega[n] = {};
  double radius[n] = {1e-3}, mass[n] = {1e-5};
  Vec3f moved[n] = {};
  compute::Conditions cond;
  const compute::kernels::IntegrateArgs<double> a{pos, vel, omega, force, torque, radius, mass, moved, {0, 0, 0}, dt, &cond};
  const long steps = 60'000'000;  // 9e-5 m in all: the plain float sum stops growing near 6.1e-5 m
  double d2 = 0;
  for (long k = 0; k < steps; ++k) d2 = compute::kernels::IntegrateFirstHalf<double>{a}(0);
  const double truth = speed * dt * double(steps), read = std::sqrt(d2);
  const float f = float(read);
  const double ulp = double(std::nextafter(f, 1.0f)) - double(f);
  std::printf("creeping: read %.6g m, true %.6g m (bound %.6g m)\n", read, truth, truth + double(steps) * ulp);
  EXPECT_GE(read, truth * (1 - 1e-12));
  EXPECT_LE(read, truth + double(steps) * ulp);

  // At a speed where a step moves many units in the last place, the reading is close to the truth.
  moved[0] = {0, 0, 0};
  vel[0] = {0.01, 0, 0};  // 1e-8 m per step
  for (long k = 0; k < 10'000; ++k) d2 = compute::kernels::IntegrateFirstHalf<double>{a}(0);
  std::printf("moving: read %.9g m, true %.9g m\n", std::sqrt(d2), 0.01 * dt * 1e4);
  EXPECT_GE(std::sqrt(d2), 1e-4 * (1 - 1e-12));
  EXPECT_LE(std::sqrt(d2), 1e-4 * (1 + 1e-3));
}

}  // namespace
}  // namespace pflow::test
