// The SPH engine on the CUDA executor against the OpenMP one (label gpu; skipped where no GPU is visible):
// the same kernels in the same cell order, so the runs differ only in floating-point contraction on the GPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "tests/support/SphScenes.h"

using namespace pflow;
using namespace pflow::compute;
using namespace pflow::compute::sph;

namespace {

#define SKIP_WITHOUT_GPU() \
  if (compute::cudaDeviceCount() == 0) GTEST_SKIP() << "no CUDA device"

std::unique_ptr<SphSimulation> make(const RunConfig& c, ExecutorKind kind) {
  SphOptions o;
  o.executor = kind;
  auto sim = SphSimulation::create(c, o);
  EXPECT_TRUE(sim.isOk()) << sim.status().message();
  return sim.isOk() ? std::move(sim).value() : nullptr;
}

// Positions by particle id.
std::map<Gid, Vec3d> positions(const ParticleSnapshot& s) {
  std::map<Gid, Vec3d> out;
  const auto* id = s.find("id")->as<Gid>();
  const auto* x = s.find("position")->as<Vec3d>();
  for (std::size_t i = 0; i < s.n; ++i) out[id[i]] = x[i];
  return out;
}

// The largest distance between a particle's positions in two snapshots (by id; 1e300 for a particle missing in b).
double largestDifference(const std::map<Gid, Vec3d>& a, const std::map<Gid, Vec3d>& b) {
  EXPECT_EQ(a.size(), b.size());
  double worst = 0;
  for (const auto& [id, x] : a) worst = std::max(worst, b.count(id) ? norm(x - b.at(id)) : 1e300);
  return worst;
}

// Runs `c` to 0.1 s on both executors and returns the largest distance between a particle's CPU and GPU
// positions (and expects the same step count).
double largestCpuGpuDifference(const RunConfig& c, const char* label) {
  auto cpu = make(c, ExecutorKind::kCpu);
  auto gpu = make(c, ExecutorKind::kCuda);
  EXPECT_TRUE(cpu && gpu);
  if (!cpu || !gpu) return 1e300;
  EXPECT_TRUE(cpu->runUntil(0.1).isOk());
  EXPECT_TRUE(gpu->runUntil(0.1).isOk());
  EXPECT_EQ(cpu->stepCount(), gpu->stepCount());
  const double worst = largestDifference(positions(cpu->snapshot()), positions(gpu->snapshot()));
  std::printf("%slargest CPU-GPU position difference after %lld steps: %.3g m\n", label, (long long)cpu->stepCount(), worst);
  return worst;
}

// Double on both: the dam break for 0.1 s (1,300 steps) at the seed's resolution. Every particle within
// 1e-6 m of its CPU position (a millionth of the tank; contraction differences of 1e-16 grow over the
// steps), the same step count.
TEST(SphCudaVsCpu, DamBreakDoubleAgrees) {
  SKIP_WITHOUT_GPU();
  EXPECT_LT(largestCpuGpuDifference(test::damBreak2D(0.01, 0.1), ""), 1e-6) << "largest position difference [m]";
}

// Probes and gauges read by the GPU's two sampling passes as by the CPU's: 3D dam break at dp 0.02 m in double,
// after 20 steps (the runs still agree to about 1e-12 m), pressures within 1e-6 of the largest and heights within
// 1e-9 m.
TEST(SphCudaVsCpu, ProbesAndGaugesAgree) {
  SKIP_WITHOUT_GPU();
  RunConfig c = test::damBreak3D(0.02, 0.1);
  c.sph.probes = {{"P1", {0.1, 0.06, 0.1}, false}, {"P2", {0.21, 0.06, 0.02}, false}, {"P3", {0.0, 0.06, 0.05}, false},
                  {"H1", {0.1, 0.06, 0}, true}, {"H2", {0.15, 0.03, 0}, true}};
  auto cpu = make(c, ExecutorKind::kCpu);
  auto gpu = make(c, ExecutorKind::kCuda);
  ASSERT_TRUE(cpu && gpu);
  for (int i = 0; i < 20; ++i) {
    ASSERT_TRUE(cpu->step().isOk());
    ASSERT_TRUE(gpu->step().isOk());
  }
  const std::vector<double> a = cpu->probeValues(), b = gpu->probeValues();
  ASSERT_EQ(a.size(), b.size());
  double scale = 0;
  for (std::size_t k = 0; k < 3; ++k) scale = std::max(scale, std::fabs(a[k]));
  EXPECT_GT(scale, 100.0);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(a[k], b[k], 1e-6 * scale) << c.sph.probes[k].name;
  for (std::size_t k = 3; k < 5; ++k) {
    EXPECT_GT(a[k], 0.1) << c.sph.probes[k].name;
    EXPECT_NEAR(a[k], b[k], 1e-9) << c.sph.probes[k].name;
  }
}

// Float on the GPU against double on the CPU: the surge front's times within 1 % (the precision study's
// question: is float harmless here?), with each pair from both sides and once (simulation.reproducible: false).
class SphCudaFloat : public ::testing::TestWithParam<bool> {};

TEST_P(SphCudaFloat, FloatFrontWithinOnePercentOfDouble) {
  SKIP_WITHOUT_GPU();
  const double dp = 0.01;
  RunConfig c = test::damBreak2D(dp);
  auto cpu = make(c, ExecutorKind::kCpu);
  c.sim.precision = Precision::kFloat;
  c.sim.reproducible = !GetParam();
  auto gpu = make(c, ExecutorKind::kCuda);
  ASSERT_TRUE(cpu && gpu);
  const std::vector<double> zs = {1.5, 2.0, 2.5, 3.0, 3.5};
  const auto t64 = test::frontTimes(*cpu, dp, zs), t32 = test::frontTimes(*gpu, dp, zs);
  for (std::size_t k = 0; k < zs.size(); ++k) EXPECT_NEAR(t32[k], t64[k], 0.01 * t64[k]) << "Z = " << zs[k];
  EXPECT_EQ(gpu->engine().pairsOnce(), GetParam());
}
INSTANTIATE_TEST_SUITE_P(BothSidesAndOnce, SphCudaFloat, ::testing::Bool());

// Component k of row i of a state array as a double, whatever its precision.
double component(const SnapshotArray& a, std::size_t i, int k) {
  const std::size_t j = i * std::size_t(a.components) + std::size_t(k);
  return a.type == ScalarType::kF32 ? double(a.as<float>()[j]) : a.as<double>()[j];
}

// The float pairs once on the GPU (its 16-byte vector atomic adds, red.v4.f32, the path a float run takes) against the
// CPU's float walk: the 3D dam break's rates after one step from rest, particle by particle, within 1e-4 of the
// largest (both runs are at the same state to rounding; a lost or misplaced component of the sums is of order 1).
TEST_P(SphCudaFloat, RatesAfterOneStepMatchTheCpu) {
  SKIP_WITHOUT_GPU();
  RunConfig c = test::damBreak3D(0.02, 0.1);
  c.sim.precision = Precision::kFloat;
  c.sim.reproducible = !GetParam();
  auto cpu = make(c, ExecutorKind::kCpu);
  auto gpu = make(c, ExecutorKind::kCuda);
  ASSERT_TRUE(cpu && gpu);
  ASSERT_TRUE(cpu->runSteps(1).isOk());
  ASSERT_TRUE(gpu->runSteps(1).isOk());
  EXPECT_EQ(gpu->engine().pairsOnce(), GetParam());
  const ParticleSnapshot a = cpu->engine().stateArrays(1, 0), b = gpu->engine().stateArrays(1, 0);
  ASSERT_EQ(a.n, b.n);
  std::map<Gid, std::size_t> rowOf;
  for (std::size_t i = 0; i < b.n; ++i) rowOf[b.find("id")->as<Gid>()[i]] = i;
  for (const char* name : {"acceleration", "density_rate"}) {
    const SnapshotArray& x = *a.find(name);
    const SnapshotArray& y = *b.find(name);
    double scale = 0, worst = 0;
    for (std::size_t i = 0; i < a.n; ++i)
      for (int k = 0; k < x.components; ++k) scale = std::max(scale, std::fabs(component(x, i, k)));
    for (std::size_t i = 0; i < a.n; ++i) {
      const std::size_t j = rowOf.at(a.find("id")->as<Gid>()[i]);
      for (int k = 0; k < x.components; ++k) worst = std::max(worst, std::fabs(component(x, i, k) - component(y, j, k)));
    }
    std::printf("%s, %s: largest difference from the CPU's float walk %.3g of the largest %.3g\n", GetParam() ? "pairs once" : "both sides",
                name, worst / scale, scale);
    EXPECT_GT(scale, 0.0);
    EXPECT_LT(worst, 1e-4 * scale) << name;
  }
}

// The GPU's pairs once (each pair evaluated once, the partner's share by atomic adds) against the CPU's walk from both
// sides, double (forced: in double the scene key alone keeps the walk, faster there), the 2D dam break and a 3D one to
// 0.1 s: every particle within 1e-6 m of its CPU position, as the GPU's walk is.
TEST(SphCudaVsCpu, PairsOnceAgreesWithTheCpu) {
  SKIP_WITHOUT_GPU();
  for (RunConfig c : {test::damBreak2D(0.01, 0.1), test::damBreak3D(0.02, 0.1)}) {
    c.sim.reproducible = false;  // ignored on the CPU and in double
    auto cpu = make(c, ExecutorKind::kCpu);
    auto plain = make(c, ExecutorKind::kCuda);
    auto gpu = make(c, ExecutorKind::kCuda);
    ASSERT_TRUE(cpu && plain && gpu);
    gpu->engine().setRatePasses(false, true, true);  // the two-phase walk, each pair once
    ASSERT_TRUE(cpu->runUntil(0.1).isOk());
    ASSERT_TRUE(gpu->runUntil(0.1).isOk());
    ASSERT_TRUE(plain->runSteps(1).isOk());
    EXPECT_FALSE(cpu->engine().pairsOnce());
    EXPECT_FALSE(plain->engine().pairsOnce());
    EXPECT_TRUE(gpu->engine().pairsOnce());
    EXPECT_EQ(cpu->stepCount(), gpu->stepCount());
    const double worst = largestDifference(positions(cpu->snapshot()), positions(gpu->snapshot()));
    std::printf("pairs once, %d-D, after %lld steps: largest position difference from the CPU %.3g m\n", c.sph.dimension,
                (long long)gpu->stepCount(), worst);
    EXPECT_LT(worst, 1e-6);
  }
}

// Verlet on both executors (double): the dam break to 0.1 s, every particle within 1e-6 m of its CPU position.
TEST(SphCudaVsCpu, VerletDamBreakAgrees) {
  SKIP_WITHOUT_GPU();
  RunConfig c = test::damBreak2D(0.01, 0.1);
  c.sph.integrator = Integrator::kVerlet;
  EXPECT_LT(largestCpuGpuDifference(c, "verlet: "), 1e-6) << "largest position difference [m]";
}

// Velocity Verlet on both executors (double): the dam break to 0.1 s, every particle within 1e-6 m of its CPU position.
TEST(SphCudaVsCpu, VelocityVerletDamBreakAgrees) {
  SKIP_WITHOUT_GPU();
  RunConfig c = test::damBreak2D(0.01, 0.1);
  c.sph.integrator = Integrator::kVelocityVerlet;
  EXPECT_LT(largestCpuGpuDifference(c, "velocity verlet: "), 1e-6) << "largest position difference [m]";
}

// Mirror walls on both executors (double): the dam break to 0.1 s, every particle within 1e-6 m of its CPU
// position, as with boundary particles.
TEST(SphCudaVsCpu, MirrorWallsDamBreakAgrees) {
  SKIP_WITHOUT_GPU();
  EXPECT_LT(largestCpuGpuDifference(test::withMirrorWalls(test::damBreak2D(0.01, 0.1)), "mirror walls: "), 1e-6)
      << "largest position difference [m]";
}

// The modified dynamic boundary (sph.boundary_density: mdbc) on both executors (double, velocity Verlet): the 2D dam
// break and a 3D one with a box in its path to 0.1 s, every particle within 1e-6 m of its CPU position.
TEST(SphCudaVsCpu, ModifiedBoundaryDamBreakAgrees) {
  SKIP_WITHOUT_GPU();
  RunConfig flat = test::damBreak2D(0.01, 0.1), box = test::damBreak3D(0.02, 0.1);
  compute::sph::addObstacle(box.sph, "box", {0.3, 0.0, 0}, {0.44, 0.12, 0.08});  // across the tank: thick enough along x
  for (RunConfig* c : {&flat, &box}) {
    c->sph.mdbc = true;
    c->sph.integrator = Integrator::kVelocityVerlet;
    EXPECT_LT(largestCpuGpuDifference(*c, c == &flat ? "mdbc 2D: " : "mdbc 3D, box: "), 1e-6) << "largest position difference [m]";
  }
}

// Hit masks (SphConfig::hitMasks, column-major on the GPU), double, the 2D dam break and a 3D one to 0.1 s: against
// the GPU's own walk bit for bit (the same pairs in the same order), and within 1e-6 m of the CPU's walk as the walk is.
TEST(SphCudaVsCpu, HitMasksAgreeWithTheWalk) {
  SKIP_WITHOUT_GPU();
  for (RunConfig c : {test::damBreak2D(0.01, 0.1), test::damBreak3D(0.02, 0.1)}) {
    auto cpu = make(c, ExecutorKind::kCpu);
    auto walk = make(c, ExecutorKind::kCuda);
    c.sph.hitMasks = true;
    auto gpu = make(c, ExecutorKind::kCuda);
    ASSERT_TRUE(cpu && walk && gpu);
    ASSERT_TRUE(cpu->runUntil(0.1).isOk());
    ASSERT_TRUE(walk->runUntil(0.1).isOk());
    ASSERT_TRUE(gpu->runUntil(0.1).isOk());
    EXPECT_EQ(cpu->stepCount(), gpu->stepCount());
    EXPECT_EQ(walk->stepCount(), gpu->stepCount());
    const auto b = positions(gpu->snapshot());
    const double worst = largestDifference(positions(cpu->snapshot()), b), fromWalk = largestDifference(positions(walk->snapshot()), b);
    std::printf("hit masks, %d-D, after %lld steps: largest position difference from the CPU %.3g m, from the GPU's walk %.3g m\n",
                c.sph.dimension, (long long)cpu->stepCount(), worst, fromWalk);
    EXPECT_LT(worst, 1e-6);
    EXPECT_EQ(fromWalk, 0.0);
  }
}

// The walk in two phases (RatePass::kTwoPhase: every candidate tested, then the pairs in one loop) on the GPU
// takes the GPU walk's pairs in its order: the same run exactly, in 2D and 3D.
TEST(SphCudaVsCpu, TwoPhaseWalkAgreesWithTheWalk) {
  SKIP_WITHOUT_GPU();
  for (RunConfig c : {test::damBreak2D(0.01, 0.1), test::damBreak3D(0.02, 0.1)}) {
    auto walk = make(c, ExecutorKind::kCuda);
    auto gpu = make(c, ExecutorKind::kCuda);
    ASSERT_TRUE(walk && gpu);
    walk->engine().setRatePasses(false, false, false);  // the GPU's default is the two-phase walk
    gpu->engine().setRatePasses(false, true, false);
    ASSERT_TRUE(walk->runUntil(0.1).isOk());
    ASSERT_TRUE(gpu->runUntil(0.1).isOk());
    EXPECT_EQ(walk->stepCount(), gpu->stepCount());
    const double fromWalk = largestDifference(positions(walk->snapshot()), positions(gpu->snapshot()));
    std::printf("two-phase walk, %d-D, after %lld steps: largest position difference from the GPU's walk %.3g m\n",
                c.sph.dimension, (long long)gpu->stepCount(), fromWalk);
    EXPECT_EQ(fromWalk, 0.0);
  }
}

}  // namespace
