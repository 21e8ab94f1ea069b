// The step loop's deferred second half kick (SimulationOptions::deferSecondHalf): a step's second half done in one
// pass with the next step's first changes no bit of a run, whoever reads the state between steps, and a check that
// fails in the combined pass names the step it belongs to.
#include <gtest/gtest.h>

#include <cstring>
#include <tuple>

#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::RunConfig;
using compute::Simulation;

std::unique_ptr<Simulation> make(const RunConfig& c, bool defer, compute::ExecutorKind executor = compute::ExecutorKind::kCpu) {
  compute::SimulationOptions o;
  o.executor = executor;
  o.deferSecondHalf = defer;
  auto sim = Simulation::create(c, o);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}

// Every byte of the named fields of both runs' particles.
void expectSameBits(const Simulation& a, const Simulation& b, const char* when) {
  const std::vector<std::string> fields = {"position", "velocity", "angular_velocity", "force"};
  const compute::ParticleSnapshot sa = a.snapshot(fields), sb = b.snapshot(fields);
  ASSERT_EQ(sa.n, sb.n);
  for (const std::string& f : fields) {
    const auto *fa = sa.find(f), *fb = sb.find(f);
    ASSERT_TRUE(fa && fb) << f;
    ASSERT_EQ(fa->data.size(), fb->data.size()) << f;
    EXPECT_EQ(std::memcmp(fa->data.data(), fb->data.data(), fa->data.size()), 0) << f << " differs " << when;
  }
}

// Precision and executor: the CUDA cases skip where no GPU is present (label gpu).
using Case = std::tuple<compute::Precision, compute::ExecutorKind>;
class DeferredHalf : public ::testing::TestWithParam<Case> {};
INSTANTIATE_TEST_SUITE_P(Cases, DeferredHalf,
                         ::testing::Combine(::testing::Values(compute::Precision::kDouble, compute::Precision::kFloat),
                                            ::testing::Values(compute::ExecutorKind::kCpu, compute::ExecutorKind::kCuda)),
                         [](const auto& info) {
                           return std::string(std::get<0>(info.param) == compute::Precision::kDouble ? "Double" : "Float") +
                                  (std::get<1>(info.param) == compute::ExecutorKind::kCuda ? "Cuda" : "Cpu");
                         });

// A heap poured into a box (walls, friction, rolling resistance, rebuilds): runSteps in calls of 250 steps, the
// deferred run reading its state only at each call's end, then runUntil with an observer that reads a snapshot every
// 37 steps (the state settled on demand). Both equal the run whose every step ends with its own second half.
TEST_P(DeferredHalf, ChangesNoBitOfARun) {
  const auto [precision, executor] = GetParam();
  if (executor == compute::ExecutorKind::kCuda && compute::cudaDeviceCount() == 0) GTEST_SKIP() << "no CUDA device";
  RunConfig c = pouredHeap(1e-3);
  c.sim.precision = precision;
  c.sim.precisionGiven = true;
  auto fused = make(c, true, executor), plain = make(c, false, executor);
  ASSERT_TRUE(fused && plain);
  for (int call = 0; call < 3; ++call) {
    ASSERT_TRUE(fused->runSteps(250).isOk());
    ASSERT_TRUE(plain->runSteps(250).isOk());
    expectSameBits(*fused, *plain, ("after runSteps call " + std::to_string(call)).c_str());
  }
  // 9 of every 10 steps but each call's last (the energy detector's steps keep their own).
  EXPECT_GT(fused->fusedHalves(), 600);
  EXPECT_EQ(plain->fusedHalves(), 0);
  int reads = 0;
  auto observer = [&](const Simulation& s) {
    if (s.stepCount() % 37 == 0) ++reads, (void)s.snapshot({"velocity"});
    return Status::ok();
  };
  const double end = fused->time() + 400 * fused->dt();
  ASSERT_TRUE(fused->runUntil(end, observer).isOk());
  ASSERT_TRUE(plain->runUntil(end, observer).isOk());
  EXPECT_GT(reads, 5);
  expectSameBits(*fused, *plain, "after runUntil with an observer");
  EXPECT_GT(fused->rebuilds(), 3);
}

// A particle that leaves the stated domain is caught by the second half's check. When that half was deferred, the
// combined pass of the next step catches it, leaves that particle at the step's end and names the step it belongs to:
// the same report as without deferral.
TEST(DeferredHalf, ACheckInTheCombinedPassNamesItsStep) {
  RunConfig c;
  c.materials = {material("glass", 4.8e10, 0.2, 2800, 0.9)};
  addParticle(c, {0.5, 0.5, 0.5}, 0.01, 0);
  addParticle(c, {0.2, 0.3, 0.5}, 0.01, 0, {3, 0, 0});
  c.sim.gravity = {0, 0, 0};
  c.sim.dt = 1e-4;
  c.sim.duration = 0.5;
  c.sim.domain = compute::Aabb{{0, 0, 0}, {1, 1, 1}};
  auto fused = make(c, true), plain = make(c, false);
  ASSERT_TRUE(fused && plain);
  const Status a = fused->runUntil(c.sim.duration), b = plain->runUntil(c.sim.duration);
  ASSERT_FALSE(a.isOk());
  EXPECT_EQ(a.message(), b.message());  // the particle described at the step's end in both
  EXPECT_GT(fused->fusedHalves(), 2000);
  std::printf("both: %s\n", a.message().c_str());
}

}  // namespace
}  // namespace pflow::test
