// Wall loads: the force and torque of the particles' contacts on each surface, as the DEM series records them
// (backend/store/DemSeries.h, summed during the sampled step's forces): a resting heap's walls carry its weight, and
// a resting sphere's torque about the origin is the lever arm of its weight.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "backend/store/DemSeries.h"
#include "compute/dem/Simulation.h"
#include "compute/sim/Domain.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

// The last sample of series `name`.
double last(const backend::ProbeSeries& s, const std::string& name) {
  for (std::size_t k = 0; k < s.names.size(); ++k)
    if (s.names[k] == name) return s.values[k].back();
  ADD_FAILURE() << "no series " << name;
  return NAN;
}

// Runs `c` to `until` recording the DEM series every `interval` s; the series.
backend::ProbeSeries runRecorded(const compute::RunConfig& c, double interval, double until) {
  auto created = compute::Simulation::create(c);
  EXPECT_TRUE(created.isOk()) << created.status().toString();
  if (!created.isOk()) return {};
  compute::Simulation& sim = *created.value();
  compute::Domain single;
  compute::SeriesConfig series;
  series.interval = interval;
  backend::DemSeriesRecorder recorder(sim, single, series, c.surfaceNames);
  EXPECT_TRUE(sim.runUntil(until, [&](const compute::Simulation& s) {
    recorder.sample(s, single);
    return Status::ok();
  }).isOk());
  return recorder.series();
}

// A heap of 600 spheres poured into a box of five planes, each its own surface, settled for 1 s: the vertical loads
// of the five walls add up to the heap's weight within 0.5 % (the rest is what still moves), most of it on the floor;
// the side walls are pushed outwards, and the horizontal loads (the floor's friction with them) cancel.
TEST(WallLoads, RestingHeapWeighsOnItsWalls) {
  compute::RunConfig c = pouredHeap(1.5e-3);
  c.surfaceNames = {"floor", "x0", "x1", "y0", "y1"};
  for (std::size_t p = 0; p < c.planes.size(); ++p) c.planes[p].surface = std::int32_t(p);
  const backend::ProbeSeries s = runRecorded(c, 0.05, 1.0);
  ASSERT_GE(s.time.size(), 20u);
  EXPECT_TRUE(std::isnan(s.values[4][0])) << "the start's sample has no loads";
  double weight = 0;
  for (const auto& p : c.particles.radius) weight += sphereMass(p, 2500) * 9.81;
  double fz = 0;
  for (const char* wall : {"floor", "x0", "x1", "y0", "y1"}) fz += last(s, std::string("force_z:") + wall);
  EXPECT_NEAR(fz / -weight, 1.0, 0.005) << "wall loads " << fz << " N, weight " << weight << " N";
  EXPECT_GT(last(s, "force_z:floor") / -weight, 0.8);
  EXPECT_LT(last(s, "force_x:x0"), 0.0) << "the heap pushes the wall at x = 0 outwards, towards -x";
  EXPECT_GT(last(s, "force_x:x1"), 0.0) << "and the wall at x = side towards +x";
  // Horizontally the walls' loads, the floor's friction included, cancel: the heap does not accelerate.
  for (const char* axis : {"x", "y"}) {
    double sum = 0;
    for (const char* wall : {"floor", "x0", "x1", "y0", "y1"}) sum += last(s, std::string("force_") + axis + ":" + wall);
    EXPECT_NEAR(sum / weight, 0.0, 0.005) << axis;
  }
}

// One sphere damped to rest on a floor plane at (x, y): the load is its weight, -m g along z, and the torque about the
// origin is r x F with r the contact point (x, y, 0): (-m g y, m g x, 0).
TEST(WallLoads, RestingSphereTorqueAboutTheOrigin) {
  const double r = 5e-3, x = 0.02, y = 0.01, g = 9.81;
  compute::RunConfig c;
  c.materials = {material("ball", 1e8, 0.3, 2500, 0.1, 0.5), rigid(0.1, 0.5)};
  addParticle(c, {x, y, r}, r, 0);
  c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 1, "floor"));
  c.surfaceNames = {"floor"};
  c.sim.gravity = {0, 0, -g};
  c.sim.duration = 0.5;
  const backend::ProbeSeries s = runRecorded(c, 0.1, 0.5);
  ASSERT_FALSE(s.time.empty());
  const double mg = sphereMass(r, 2500) * g;
  EXPECT_NEAR(last(s, "force_z:floor") / -mg, 1.0, 1e-6);
  EXPECT_NEAR(last(s, "force_x:floor"), 0.0, 1e-9 * mg);
  EXPECT_NEAR(last(s, "torque_x:floor") / (-mg * y), 1.0, 1e-5);
  EXPECT_NEAR(last(s, "torque_y:floor") / (mg * x), 1.0, 1e-5);
  EXPECT_NEAR(last(s, "torque_z:floor"), 0.0, 1e-9 * mg * x);
  // The particle's torque is written when output.fields names it, and only then.
  auto sim = compute::Simulation::create(c);
  ASSERT_TRUE(sim.isOk());
  EXPECT_EQ(sim.value()->snapshot().find("torque"), nullptr);
  const auto named = sim.value()->snapshot({"id", "position", "torque"});
  ASSERT_NE(named.find("torque"), nullptr);
  EXPECT_EQ(named.find("torque")->components, 3);
  EXPECT_EQ(named.find("torque")->unit, "N m");
}

}  // namespace
}  // namespace pflow::test
