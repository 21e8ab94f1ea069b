// A bed of 20 000 polydisperse spheres (radius ratio 2) settles under gravity in a box of planes:
// no overlap above 1 % of the smaller radius, kinetic energy decays to rest, no slot overflow.
#include <gtest/gtest.h>

#include "bench/BedScene.h"
#include "compute/dem/Simulation.h"

namespace pflow::test {
namespace {

TEST(SettledBed, PolydisperseBedComesToRest) {
  bench::BedSpec spec;
  spec.nx = 50;
  spec.ny = 20;  // the height (nz) sets the time to rest: 50 x 20 (was 50 x 40) halves the test's cost
  spec.nz = 10;
  spec.polydisperse = true;
  spec.dt = 5e-6;  // 0.23 of the Rayleigh time of the smallest sphere (d/4)
  auto cfg = bench::bedScene(spec);
  // A lossier bed with some rolling resistance comes to rest within the test's time; without rolling
  // resistance spheres on the free surface roll on for a long time (no dissipation in pure rolling).
  cfg.materials[0].restitution = 0.3;
  cfg.materials[0].rollingFriction = 0.05;
  ASSERT_EQ(cfg.particles.size(), 10000u);
  auto sim = compute::Simulation::create(cfg);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  const int slots0 = sim.value()->engine().historySlots();

  // Energy scale: the bed's weight times one diameter.
  double weight = 0;
  for (std::size_t i = 0; i < cfg.particles.size(); ++i) {
    const double r = cfg.particles.radius[i];
    weight += 2500 * 4.0 / 3.0 * 3.141592653589793 * r * r * r * 9.81;
  }
  const double scale = weight * spec.diameter;

  double peakKe = 0;
  for (int block = 0; block < 40; ++block) {  // 0.2 s
    ASSERT_TRUE(sim.value()->runSteps(1000).isOk());
    const auto st = sim.value()->contactStats();
    peakKe = std::max(peakKe, st.kineticEnergy);
    std::printf("t = %.3f s  KE/scale = %.3g (translational %.3g), max speed %.3g m/s\n", sim.value()->time(),
                st.kineticEnergy / scale, st.translationalEnergy / scale, st.maxSpeed);
  }
  const auto st = sim.value()->contactStats();
  RecordProperty("coordination", std::to_string(st.coordinationNumber));
  EXPECT_GT(peakKe, 1e-3 * scale);                 // it really fell
  // Came to rest: translational kinetic energy below 1e-5 M g d (rms speed under 0.45 mm/s) and the
  // total three orders of magnitude below its peak. (A few rattlers keep moving in their cages at a
  // few cm/s, and may spin freely: nothing resists a free spin. The max speed is printed, not held.)
  EXPECT_LT(st.translationalEnergy, 1e-5 * scale);
  EXPECT_LT(st.kineticEnergy, 1e-3 * peakKe);
  EXPECT_LT(st.maxOverlapRatio, 0.01);             // no overlap above 1 % of the smaller radius
  EXPECT_GT(st.coordinationNumber, 3.5);           // a dense, connected bed
  EXPECT_EQ(sim.value()->engine().historySlots(), slots0);  // no slot overflow
  std::printf("settled bed: t = %.3f s, KE/scale = %.3g, max speed %.3g m/s, coordination %.2f, max overlap/r %.4f, slots %d\n%s\n",
              sim.value()->time(), st.kineticEnergy / scale, st.maxSpeed, st.coordinationNumber, st.maxOverlapRatio,
              sim.value()->engine().historySlots(), sim.value()->timers().report().c_str());
}

}  // namespace
}  // namespace pflow::test
