// summarize() for solver: sph scenes: what `pflow validate`, the frontend service and the manager need of an SPH
// run (particle count, memory estimate, the first time step and the steps to the end, the method as the model's
// decisions). The DEM summary is SceneSummary.cc.
#include <cmath>
#include <string>

#include "compute/core/Format.h"
#include "compute/sph/SphFields.h"
#include "compute/sph/SphKernels.h"
#include "compute/sph/SphSimulation.h"
#include "frontend/SceneSummary.h"

namespace pflow::frontend {

namespace {

// Device bytes per particle, as SphEngineImpl allocates them: every field of the SPH table at the run's precision,
// the reorder scratch (one column of the widest field), the cell sort (key and permutation), the positions at the
// last sort (the skin's reference), the boundary/interior split list, the wet flags and the packed rows the rates
// pass reads (SphKernels.h, PackRates). No neighbour lists: the rates walk the cells. 229 B in float and 337 in
// double; pflow-sph-bench measures them on SPHERIC (bench/RESULTS.md): the buffers grow with a quarter of slack.
template <class R>
double sphBytesPerParticle() {
  double bytes = 0, widest = 0;
  const compute::sph::SphFieldInfo* table = compute::sph::kSphFieldTableOf<R>;
  for (int k = 0; k < compute::sph::kNumSphFields; ++k) {
    bytes += double(table[k].elementBytes);
    widest = std::max(widest, double(table[k].elementBytes));
  }
  const double packed = double(sizeof(compute::sph::kernels::RateRow<R>) + sizeof(compute::sph::kernels::RateState<R>) +
                               sizeof(compute::sph::kernels::RatePm<R>));
  return bytes + widest + 4 + 4 + double(sizeof(Vec3d)) + double(sizeof(Index)) + 1 + packed;
}

}  // namespace

Result<SceneSummary> summarizeSph(const LoadedScene& scene) {
  const compute::RunConfig& c = scene.config;
  const compute::sph::SphConfig& sph = c.sph;
  auto setup = compute::sph::prepareSphSetup(c);
  if (!setup) return setup.status();
  const compute::sph::SphDerived d = compute::sph::derive(sph, c.sim);
  const std::size_t n = sph.size(), fluid = sph.fluidCount();
  const double dp = sph.spacing;
  // In 2D a particle stands for dp^2 of the plane and 1 m of depth.
  const double particleVolume = sph.dimension == 3 ? dp * dp * dp : dp * dp;

  SceneSummary s;
  s.solver = "sph";
  s.particles = n;
  s.minRadius = s.maxRadius = 0.5 * dp;
  s.solidVolume = double(fluid) * particleVolume;
  ParticleSetInfo fluidSet{"fluid", "sph lattice", 0, fluid, 0.5 * dp, 0.5 * dp, double(fluid) * particleVolume, 0};
  for (const auto& b : sph.fluidBlocks) {
    const Vec3d e = b.hi - b.lo;
    fluidSet.regionVolume += sph.dimension == 3 ? e.x * e.y * e.z : e.x * e.z;
  }
  s.sets.push_back({fluidSet, fluidSet.regionVolume > 0 ? fluidSet.solidVolume / fluidSet.regionVolume : 0.0});
  if (n > fluid) {
    const ParticleSetInfo walls{"boundary", "sph wall layers", fluid, n - fluid, 0.5 * dp, 0.5 * dp, double(n - fluid) * particleVolume, 0};
    s.sets.push_back({walls, 0.0});
  }
  const compute::CellGrid& g = setup.value().grid;
  s.cells = {g.nx, g.ny, g.nz};
  s.cellSize = g.cellSize;
  s.domain = {g.lo, g.lo + Vec3d{g.nx * g.cellSize, g.ny * g.cellSize, g.nz * g.cellSize}};
  const Vec3d e = s.domain.hi - s.domain.lo;
  const double volume = e.x * e.y * e.z;
  s.domainSolidFraction = volume > 0 && sph.dimension == 3 ? s.solidVolume / volume : 0;

  // The first step: the acoustic limit at rest. Later steps shorten by at most c0 / (c0 + v_max) >= 10/11 while
  // the flow stays within the expected speed, so the step count is an estimate to within about 10 %.
  s.dt = sph.dt ? *sph.dt
               : compute::sph::stableDt(sph.cfl, d.h, sph.kinematicViscosity, compute::sph::inverseStep(d.h, d.c0, 0, 0, false));
  s.dtReason = sph.dt ? "sph.dt, fixed" : "CFL " + format::num4(sph.cfl) + " x h / c0 at rest (h " + format::num4(d.h) + " m, c0 " + format::num4(d.c0) + " m/s), adapted every step";
  s.steps = std::llround(c.sim.duration / s.dt);

  s.model.precision = c.sim.precision;
  s.model.decisions = {
      {"solver", "sph", "solver: sph (weakly compressible SPH, docs/sph.md)"},
      {"particles", std::to_string(fluid) + " fluid, " + std::to_string(n - fluid) + " boundary",
       std::to_string(sph.dimension) + "D lattice of spacing " + format::num4(dp) + " m, " + std::to_string(d.boundaryLayers) + " wall layers"},
      {"kernel", compute::sph::kernelName(sph.kernel), "h = " + format::num4(d.h) + " m (h/dp " + format::num4(sph.smoothingRatio) + ")"},
      {"sound speed", format::num4(d.c0) + " m/s", d.soundSpeedReason},
      {"precision", c.sim.precision == compute::Precision::kFloat ? "float" : "double", "simulation.precision"}};
  s.bytesPerParticle = c.sim.precision == compute::Precision::kFloat ? sphBytesPerParticle<float>() : sphBytesPerParticle<double>();
  s.memoryBytes = s.bytesPerParticle * double(n) + 4.0 * (double(g.nx) * g.ny * g.nz + 1);
  return s;
}

}  // namespace pflow::frontend
