// Janssen's wall-stress saturation on the GPU (docs/accuracy.md, "Janssen"): ~4e4 beads settle in a silo of
// diameter 40 mm (20 mean diameters), the floor sinks 0.5 mm to mobilise the wall friction, and the per-surface
// loads of the side wall's bands give the wall's normal and shear stress against depth (bench/JanssenSilo.h). Held:
// the floor and the wall's shear carry the weight (1 %); the wall friction mobilised stays within the wall's
// Coulomb limit; the profile saturates as Janssen's exponential (fit within 10 % rms) at rho_b g D / (4 mu) with the
// mobilised mu, within 15 %; and the fitted K (lambda = D / (4 mu K)) is a lateral stress ratio granular beds show
// (0.2-1). Skips without a GPU.
#include <gtest/gtest.h>

#include <cstdio>

#include "bench/JanssenSilo.h"
#include "compute/core/ExecutorKind.h"

namespace pflow::test {
namespace {

TEST(Janssen, SiloWallStressSaturatesAsJanssenSays) {
  if (compute::cudaDeviceCount() == 0) GTEST_SKIP() << "no CUDA device";
  bench::JanssenOptions o;
  const bench::JanssenResult r = bench::runJanssen(o, compute::ExecutorKind::kCuda);
  ASSERT_TRUE(r.error.empty()) << r.error;
  for (const auto& b : r.bands) std::printf("depth %.4f m: sigma_w %.1f Pa, tau_w %.1f Pa\n", b.depth, b.normal, b.shear);
  std::printf("%zu beads, %.1f s; weight %.4g N = floor %.4g N + wall %.4g N; rho_b %.1f; mobilised mu %.3f; fit sigma_inf %.1f Pa, "
              "lambda %.4f m; Janssen rho_b g D / (4 mu) %.1f Pa; K %.3f; rms %.3f\n",
              r.particles, r.wall, r.weight, r.floorLoad, r.wallShearLoad, r.bulkDensity, r.mobilised, r.sigmaInf, r.lambda,
              r.janssenInf, r.K, r.fitResidual);
  ASSERT_GE(r.bands.size(), 6u);
  EXPECT_NEAR((r.floorLoad + r.wallShearLoad) / r.weight, 1.0, 0.01);
  EXPECT_GT(r.mobilised, 0.0);
  EXPECT_LE(r.mobilised, 1.02 * o.wallFriction);
  EXPECT_LT(r.fitResidual, 0.10);
  EXPECT_NEAR(r.sigmaInf / r.janssenInf, 1.0, 0.15);
  EXPECT_GE(r.K, 0.2);
  EXPECT_LE(r.K, 1.0);
}

}  // namespace
}  // namespace pflow::test
