// Checkpoints (issue 18, label fault): a run resumed from a checkpoint goes on exactly as the run it came from,
// bit for bit, on the CPU (the state arrays are the executor's own; docs/operations.md, "Checkpoints").
#include <gtest/gtest.h>

#include <string>

#include <cstring>
#include <map>

#include "compute/dem/Simulation.h"
#include "compute/sph/SphSimulation.h"
#include "tests/support/CheckpointTest.h"
#include "tests/support/SphScenes.h"
#include "tests/support/TestScenes.h"

using namespace pflow;
using namespace pflow::compute;

namespace {

void expectSameState(const Simulation& a, const Simulation& b) {
  EXPECT_EQ(a.stepCount(), b.stepCount());
  EXPECT_EQ(a.time(), b.time());
  test::expectSameArrays(a.snapshot(), b.snapshot(), {"position", "velocity", "angular_velocity", "force"});
}

std::unique_ptr<Simulation> make(const RunConfig& c, SimulationOptions o = {}) {
  auto sim = Simulation::create(c, o);
  EXPECT_TRUE(sim.isOk()) << sim.status().message();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}

// The pouring heap (600 frictional spheres with rolling resistance: contacts start, slide and end, particles
// cross cells): checkpointed at the first rebuild after step 800, resumed in a new run of the same scene, both
// taken to step 2000: every position, velocity, angular velocity and force is the uninterrupted run's, bit for bit,
// with the CPU's pairs-once sums (the default) and with the canonical order.
TEST(Checkpoint, ResumedDemRunIsBitIdentical) {
  for (bool canonical : {false, true}) {
    SCOPED_TRACE(canonical ? "canonical order" : "pairs once");
    SimulationOptions o;
    o.canonicalOrder = canonical;
    const RunConfig c = test::pouredHeap(1e-3, 2);
    auto straight = make(c, o), first = make(c, o), resumed = make(c, o);
    ASSERT_TRUE(straight && first && resumed);
    ASSERT_TRUE(straight->runSteps(2000).isOk());
    const auto state = test::checkpointAfter(*first, 800);
    ASSERT_TRUE(state);
    EXPECT_GT(state->step, 800);
    EXPECT_GT(state->contactSlots, 0);
    ASSERT_TRUE(test::resumeTo(*resumed, *state, 2000));
    expectSameState(*straight, *resumed);
    EXPECT_EQ(straight->rebuilds(), resumed->rebuilds());
    std::printf("checkpoint at step %lld; to step 2000 (t = %.3g s): %lld rebuilds, %zu histories\n", (long long)state->step,
                straight->time(), (long long)straight->rebuilds(), straight->contactStats().historyEntries);
  }
}

// A state is taken just after a rebuild only: elsewhere state() says why.
TEST(Checkpoint, StateOnlyJustAfterARebuild) {
  auto sim = make(test::pouredHeap(1e-3, 1));
  ASSERT_TRUE(sim);
  ASSERT_TRUE(sim->runSteps(1).isOk());
  while (sim->justRebuilt()) ASSERT_TRUE(sim->runSteps(1).isOk());
  auto s = sim->state();
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.status().message().find("just after a neighbour rebuild"), std::string::npos) << s.status().message();
}

// The 2D dam break (20 x 40, each integrator): checkpointed at the first cell sort after step 300, resumed in a new
// run of the same scene, both taken to step 900: every position, velocity, density and pressure is the
// uninterrupted run's, bit for bit.
// With hit masks (sph::SphConfig::hitMasks) in the interrupted and resumed runs, against the straight run's walk: the
// resumed run walks until its first sort after the resume's (its positions are no longer those of that sort).
TEST(Checkpoint, ResumedSphRunIsBitIdentical) {
  for (bool masks : {false, true})
  for (auto integrator : {sph::Integrator::kSymplectic, sph::Integrator::kVerlet, sph::Integrator::kVelocityVerlet}) {
    SCOPED_TRACE(std::string(sph::integratorName(integrator)) + (masks ? ", hit masks" : ""));
    RunConfig c = test::damBreak2D(0.01, 1.0);
    c.sph.integrator = integrator;
    auto make = [&](bool withMasks) {
      c.sph.hitMasks = withMasks;
      auto sim = sph::SphSimulation::create(c);
      EXPECT_TRUE(sim.isOk()) << sim.status().message();
      return sim.isOk() ? std::move(sim).value() : nullptr;
    };
    auto straight = make(false), first = make(masks), resumed = make(masks);
    ASSERT_TRUE(straight && first && resumed);
    ASSERT_TRUE(straight->runSteps(900).isOk());
    const auto state = test::checkpointAfter(*first, 300);
    ASSERT_TRUE(state);
    ASSERT_LT(state->step, 900);
    ASSERT_TRUE(test::resumeTo(*resumed, *state, 900));
    EXPECT_EQ(straight->time(), resumed->time());
    EXPECT_EQ(straight->rebuilds(), resumed->rebuilds());
    test::expectSameArrays(straight->snapshot(), resumed->snapshot(), {"position", "velocity", "density", "pressure"});
    std::printf("SPH checkpoint at step %lld, to step 900 (t = %.4g s): %lld cell sorts\n", (long long)state->step,
                straight->time(), (long long)straight->rebuilds());
  }
}

}  // namespace
