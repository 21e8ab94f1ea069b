// SPH scenes built in code for the tests: the seed's 2D dam break and a hydrostatic tank, with the surge
// front measured as the benchmark defines it.
#pragma once
#include <algorithm>
#include <cstdio>
#include <cmath>
#include <string>
#include <vector>

#include "compute/sim/RunConfig.h"
#include "compute/sph/SphLattice.h"
#include "compute/sph/SphSimulation.h"

namespace pflow::test {

// Z = x/a at which the surge front's times are compared, and Martin & Moyce's (1952) T there: the a = 2.25 in
// series (../shared/data/validation/martin_moyce_1952_pysph.csv), linearly interpolated.
inline const std::vector<double> kFrontZ = {1.5, 2.0, 2.5, 3.0, 3.5};
inline const std::vector<double> kMartinMoyceT = {1.244, 1.719, 2.160, 2.551, 2.901};

inline compute::RunConfig sphBase(double dp, double duration) {
  compute::RunConfig c;
  c.solver = compute::Solver::kSph;
  c.sph.dimension = 2;
  c.sph.spacing = dp;
  c.sph.density = 1000;
  c.sim.gravity = {0, 0, -9.81};
  c.sim.duration = duration;
  return c;
}

// Seed 002 / Martin & Moyce: a column a = 0.2 m wide, 2a high against the left wall of a 1 m tank (open top).
inline compute::RunConfig damBreak2D(double dp, double duration = 0.45) {
  compute::RunConfig c = sphBase(dp, duration);
  compute::sph::addFluidBlock(c.sph, "fluid.blocks[0]", {0, 0, 0}, {0.2, 0, 0.4});
  compute::sph::addTank(c.sph, "tank", {0, 0, 0}, {1.0, 0, 1.2});
  return c;
}

// A small 3D dam break (all 25 rows of cells the rates pass walks): a column 0.2 x 0.12 x 0.3 m in a tank 0.5 x
// 0.12 m (closed sides), for the comparisons of passes and executors.
inline compute::RunConfig damBreak3D(double dp, double duration) {
  compute::RunConfig c = sphBase(dp, duration);
  c.sph.dimension = 3;
  compute::sph::addFluidBlock(c.sph, "fluid.blocks[0]", {0, 0, 0}, {0.2, 0.12, 0.3});
  compute::sph::addTank(c.sph, "tank", {0, 0, 0}, {0.5, 0.12, 0.4});
  return c;
}

// The tank's walls as mirrors instead of boundary particles (sph.boundary: mirror).
inline compute::RunConfig withMirrorWalls(compute::RunConfig c) {
  c.sph.boundary = compute::sph::BoundaryKind::kMirror;
  std::size_t keep = 0;  // drop the tank's wall particles (the obstacles' stay)
  std::vector<Vec3d> x;
  std::vector<compute::sph::ParticleKind> k;
  for (std::size_t i = 0; i < c.sph.size(); ++i)
    if (c.sph.kind[i] == compute::sph::ParticleKind::kFluid) {
      x.push_back(c.sph.position[i]);
      k.push_back(c.sph.kind[i]);
      ++keep;
    }
  c.sph.position = x;
  c.sph.kind = k;
  if (!c.sph.velocity.empty()) c.sph.velocity.resize(keep);
  return c;
}

// Water H deep at rest in a tank `width` wide.
inline compute::RunConfig hydrostaticTank(double dp, double width, double depth, double duration) {
  compute::RunConfig c = sphBase(dp, duration);
  compute::sph::addFluidBlock(c.sph, "fluid.blocks[0]", {0, 0, 0}, {width, 0, depth});
  compute::sph::addTank(c.sph, "tank", {0, 0, 0}, {width, 0, depth + 0.1});
  return c;
}

// The surge front is the largest x of a fluid particle plus half a spacing (a particle stands for a cell dp
// wide, so the column's initial front is its width).
// Runs the dam break and returns T = t sqrt(2g/a) at which the front first reaches each Z = x/a (linear
// interpolation between steps); NaN for a Z not reached.
inline std::vector<double> frontTimes(compute::sph::SphSimulation& sim, double dp, const std::vector<double>& zs, double tEnd = 0.6,
                                      double a = 0.2, double g = 9.81) {
  std::vector<double> t(zs.size(), std::nan(""));
  double lastT = sim.time(), lastX = sim.fluidReach({1, 0, 0}) + 0.5 * dp;
  std::size_t next = 0;
  const double scale = std::sqrt(2 * g / a);
  Status s = sim.runUntil(tEnd, [&](const compute::sph::SphSimulation& r) -> Status {
    const double x = r.fluidReach({1, 0, 0}) + 0.5 * dp;
    while (next < zs.size() && x >= zs[next] * a) {
      const double f = x > lastX ? (zs[next] * a - lastX) / (x - lastX) : 1.0;
      t[next] = (lastT + f * (r.time() - lastT)) * scale;
      ++next;
    }
    lastT = r.time();
    lastX = x;
    if (next == zs.size()) return Status(StatusCode::kCancelled, "done");
    return Status::ok();
  });
  if (!s.isOk() && s.code() != StatusCode::kCancelled) std::fprintf(stderr, "frontTimes: %s\n", s.message().c_str());  // the times stay NaN
  return t;
}

}  // namespace pflow::test
