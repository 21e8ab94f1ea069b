// Checkpoints on the GPU (labels gpu and fault; skipped where no GPU is visible): a state's arrays are the same
// row-major layout on either executor, so a run resumes on the GPU from a GPU checkpoint bit for bit, and from a
// CPU checkpoint within the executors' own agreement.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>

#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

using namespace pflow;
using namespace pflow::compute;

namespace {

#define SKIP_WITHOUT_GPU() \
  if (compute::cudaDeviceCount() == 0) GTEST_SKIP() << "no CUDA device"

std::unique_ptr<Simulation> make(ExecutorKind kind) {
  SimulationOptions o;
  o.executor = kind;
  o.pairsOnce = false;
  auto sim = Simulation::create(test::pouredHeap(1e-3, 2), o);
  EXPECT_TRUE(sim.isOk()) << sim.status().message();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}

std::map<Gid, Vec3d> vectors(const Simulation& s, const char* field) {
  const ParticleSnapshot snap = s.snapshot();
  std::map<Gid, Vec3d> out;
  for (std::size_t i = 0; i < snap.n; ++i) out[snap.find("id")->as<Gid>()[i]] = snap.find(field)->as<Vec3d>()[i];
  return out;
}

// Bit for bit, particle by particle.
bool identical(const std::map<Gid, Vec3d>& a, const std::map<Gid, Vec3d>& b) {
  if (a.size() != b.size()) return false;
  for (const auto& [id, x] : a) {
    const auto it = b.find(id);
    if (it == b.end() || std::memcmp(&x, &it->second, sizeof x) != 0) return false;
  }
  return true;
}

// Runs `from` to its first rebuild after step 800 and returns the state there.
SimulationState checkpointAfter800(Simulation& from) {
  EXPECT_TRUE(from.runSteps(800).isOk());
  while (!from.justRebuilt()) EXPECT_TRUE(from.runSteps(1).isOk());
  auto s = from.state();
  EXPECT_TRUE(s.isOk()) << s.status().message();
  return s.isOk() ? std::move(s).value() : SimulationState{};
}

// GPU checkpoint, GPU resume, to step 2000: every position and velocity the uninterrupted GPU run's, bit for bit.
TEST(CheckpointGpu, ResumedOnTheGpuIsBitIdentical) {
  SKIP_WITHOUT_GPU();
  auto straight = make(ExecutorKind::kCuda), first = make(ExecutorKind::kCuda), resumed = make(ExecutorKind::kCuda);
  ASSERT_TRUE(straight && first && resumed);
  ASSERT_TRUE(straight->runSteps(2000).isOk());
  ASSERT_TRUE(resumed->resume(checkpointAfter800(*first)).isOk());
  ASSERT_TRUE(resumed->runSteps(2000 - resumed->stepCount()).isOk());
  EXPECT_TRUE(identical(vectors(*straight, "position"), vectors(*resumed, "position")));
  EXPECT_TRUE(identical(vectors(*straight, "velocity"), vectors(*resumed, "velocity")));
}

// CPU checkpoint (slot fields row-major on the host), GPU resume (slot-major on the device), to step 2000: every
// particle within 1e-9 m of the uninterrupted CPU run (the executors' own agreement on this heap: contraction
// differences of 1e-16 grown over 1,200 steps; measured on an H100: 2.2e-15 m).
TEST(CheckpointGpu, CpuCheckpointResumesOnTheGpu) {
  SKIP_WITHOUT_GPU();
  auto straight = make(ExecutorKind::kCpu), first = make(ExecutorKind::kCpu), resumed = make(ExecutorKind::kCuda);
  ASSERT_TRUE(straight && first && resumed);
  ASSERT_TRUE(straight->runSteps(2000).isOk());
  const SimulationState state = checkpointAfter800(*first);
  ASSERT_GT(state.contactSlots, 0);
  ASSERT_TRUE(resumed->resume(state).isOk());
  ASSERT_TRUE(resumed->runSteps(2000 - resumed->stepCount()).isOk());
  const auto a = vectors(*straight, "position"), b = vectors(*resumed, "position");
  double worst = 0;
  for (const auto& [id, x] : a) worst = std::max(worst, norm(x - b.at(id)));
  std::printf("largest CPU-checkpoint GPU-resume position difference after step 2000: %.3g m\n", worst);
  EXPECT_LT(worst, 1e-9);
}

}  // namespace
