// The step loop's integrator kernels, compiled for sm_90 and run on the GPU: free fall matches the
// CPU executor's result bit for bit (velocity Verlet is exact for constant acceleration up to
// round-off, and both run the same functor). Skipped where there is no GPU.
#include <gtest/gtest.h>

#include <vector>

#include "compute/cuda/KernelCompileCheck.cuh"
#include "compute/sim/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

TEST(GpuKernels, FreeFallMatchesCpuExecutor) {
  if (compute::gpu::deviceCount() == 0) GTEST_SKIP() << "no CUDA device";
  const int n = 1000, steps = 500;
  const double dt = 1e-4;
  const Vec3d g{0, 0, -9.81};
  std::vector<Vec3d> pos(n), vel(n);
  for (int i = 0; i < n; ++i) {
    pos[i] = {0.01 * i, 0.0, 1.0};
    vel[i] = {0.0, 0.001 * i, 0.5};
  }
  std::vector<Vec3d> gpuPos = pos, gpuVel = vel;
  ASSERT_EQ(compute::gpu::freeFallOnDevice(gpuPos.data(), gpuVel.data(), n, dt, steps, g), 0);

  compute::RunConfig c;
  c.materials = {material("m", 1e7, 0.3, 1.0 / (4.0 / 3.0 * 3.141592653589793))};  // unit mass at r = 1
  for (int i = 0; i < n; ++i) addParticle(c, pos[i], 1e-3, 0, vel[i]);
  c.sim.gravity = g;
  c.sim.dt = dt;
  c.sim.duration = 1;
  c.sim.domain = compute::Aabb{{-100, -100, -100}, {100, 100, 100}};
  auto sim = compute::Simulation::create(c);
  ASSERT_TRUE(sim.isOk()) << sim.status().toString();
  ASSERT_TRUE(sim.value()->runSteps(steps).isOk());
  const auto s = sim.value()->snapshot();
  const Vec3d* x = s.find("position")->as<Vec3d>();
  const Gid* id = s.find("id")->as<Gid>();
  for (std::size_t k = 0; k < s.n; ++k) {
    const Vec3d ref = gpuPos[id[k]];
    EXPECT_NEAR(x[k].z, ref.z, 1e-12);
    EXPECT_NEAR(x[k].y, ref.y, 1e-12);
  }
}

}  // namespace
}  // namespace pflow::test
