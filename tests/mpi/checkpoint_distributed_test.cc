// Checkpoints of distributed runs (issue 18, labels mpi and fault), at whatever rank count mpirun gives (ctest runs
// 1, 2 and 4): a state taken from the ranks (gathered to rank 0 in id order) and resumed by a new run of the same
// scene on the same ranks (rank 0 alone holding the state) goes on bit for bit as the uninterrupted run; resumed by one process instead (another rank
// count) it goes on bit for bit too, since distributed runs sum in global-id order and the one-process run is asked
// to (canonicalOrder). Both solvers; the CPU executor (PFLOW_TEST_EXECUTOR=cuda: the GPUs).
#include <gtest/gtest.h>
#include <mpi.h>

#include <memory>

#include "compute/dem/Simulation.h"
#include "compute/mpi/MpiDomain.h"
#include "compute/sph/SphSimulation.h"
#include "tests/support/CheckpointTest.h"
#include "tests/support/MpiTest.h"
#include "tests/support/SphScenes.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::ParticleSnapshot;

int worldRank() {
  int r;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

std::shared_ptr<compute::MpiDomain> domain() {
  compute::MpiDomainOptions split;
  split.cost = compute::MpiDomainOptions::Cost::kCount;  // deterministic
  return std::make_shared<compute::MpiDomain>(MPI_COMM_WORLD, split);
}

// SPH: the 2D dam break (velocity Verlet and the symplectic scheme), checkpointed at the first cell sort after
// step 300, resumed, both taken to step 900.
TEST(CheckpointDistributed, SphResumedOnTheRanksAndInOneProcess) {
  for (auto integrator : {compute::sph::Integrator::kSymplectic, compute::sph::Integrator::kVelocityVerlet}) {
    SCOPED_TRACE(compute::sph::integratorName(integrator));
    compute::RunConfig c = damBreak2D(0.01, 1.0);
    c.sph.integrator = integrator;
    auto make = [&](bool distributed) {
      compute::sph::SphOptions o;
      o.executor = testExecutor();
      if (o.executor == compute::ExecutorKind::kCuda) o.device = testDevice();
      o.canonicalOrder = true;
      if (distributed) o.domain = domain();
      auto sim = compute::sph::SphSimulation::create(c, o);
      EXPECT_TRUE(sim.isOk()) << sim.status().message();
      return sim.isOk() ? std::move(sim).value() : nullptr;
    };
    auto straight = make(true), first = make(true), resumed = make(true);
    ASSERT_TRUE(straight && first && resumed);
    ASSERT_TRUE(straight->runSteps(900).isOk());
    const auto state = checkpointAfter(*first, 300);
    ASSERT_TRUE(state);
    // Only rank 0 holds the state (as a caller reading the checkpoint file on rank 0 only would): resume() takes
    // its scalars and particles from there.
    ASSERT_TRUE(resumeTo(*resumed, worldRank() == 0 ? *state : compute::SimulationState{}, 900));
    const std::vector<std::string> fields = {"id", "position", "velocity", "density", "pressure"};
    const ParticleSnapshot a = straight->snapshot(fields), b = resumed->snapshot(fields);
    if (worldRank() == 0) {
      expectSameArrays(a, b, {"position", "velocity", "density", "pressure"}, "resumed on the ranks");
      // Another rank count: one process resumes rank 0's state.
      auto one = make(false);
      ASSERT_TRUE(one && resumeTo(*one, *state, 900));
      expectSameArrays(a, one->snapshot(fields), {"position", "velocity", "density", "pressure"}, "resumed in one process");
      std::printf("SPH %s: checkpoint at step %lld of %zu particles, resumed to step 900\n", compute::sph::integratorName(integrator),
                  (long long)state->step, state->particles.n);
    }
  }
}

// DEM: the pouring heap (frictional, rolling resistance: contact histories travel with partner ids), checkpointed
// at the first rebuild after step 800, resumed, both taken to step 2000.
TEST(CheckpointDistributed, DemResumedOnTheRanksAndInOneProcess) {
  const compute::RunConfig c = pouredHeap(1e-3, 1);
  auto make = [&](bool distributed) {
    compute::SimulationOptions o;
    o.executor = testExecutor();
    if (o.executor == compute::ExecutorKind::kCuda) o.device = testDevice();
    o.canonicalOrder = true;
    if (distributed) o.domain = domain();
    auto sim = compute::Simulation::create(c, o);
    EXPECT_TRUE(sim.isOk()) << sim.status().message();
    return sim.isOk() ? std::move(sim).value() : nullptr;
  };
  auto straight = make(true), first = make(true), resumed = make(true);
  ASSERT_TRUE(straight && first && resumed);
  ASSERT_TRUE(straight->runSteps(2000).isOk());
  const auto state = checkpointAfter(*first, 800);
  ASSERT_TRUE(state);
  ASSERT_TRUE(resumeTo(*resumed, worldRank() == 0 ? *state : compute::SimulationState{}, 2000));
  const ParticleSnapshot a = straight->snapshot(), b = resumed->snapshot();
  if (worldRank() == 0) {
    EXPECT_GT(state->contactSlots, 0);
    expectSameArrays(a, b, {"position", "velocity", "angular_velocity", "force"}, "resumed on the ranks");
    auto one = make(false);
    ASSERT_TRUE(one && resumeTo(*one, *state, 2000));
    expectSameArrays(a, one->snapshot(), {"position", "velocity", "angular_velocity", "force"}, "resumed in one process");
    std::printf("DEM: checkpoint at step %lld of %zu particles (%d history slots), resumed to step 2000\n", (long long)state->step,
                state->particles.n, state->contactSlots);
  }
}

}  // namespace
}  // namespace pflow::test
