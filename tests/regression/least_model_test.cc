// The least model (simulation.model: auto, compute/dem/ModelChoice.h) gives the full model's answer where
// it applies: each simplification run against simulation.model: full on a scene where it holds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <map>

#include "compute/dem/ModelChoice.h"
#include "compute/dem/Simulation.h"
#include "tests/support/TestScenes.h"

namespace pflow::test {
namespace {

using compute::ModelMode;
using compute::RunConfig;
using compute::Simulation;

constexpr double kR = 1e-3;

// A pseudo-random offset in [-1, 1] (deterministic, platform-independent).
double jitter(int k) { return std::sin(12.9898 * k + 78.233) * 0.5 + std::cos(4.1414 * k) * 0.5; }

// 4 x 4 x 4 spheres, slightly overlapping, each moving towards the centre: a cluster that collides and
// rebounds. Optionally resting on a floor under gravity.
RunConfig cluster(double mu, double muRoll, bool floor) {
  RunConfig c;
  c.materials = {material("m", 1e7, 0.3, 2500, 0.6, mu, muRoll)};
  const double s = 2 * kR * 0.995;
  int k = 0;
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x, ++k) {
        const Vec3d at{x * s + 0.01 * kR * jitter(3 * k), y * s + 0.01 * kR * jitter(3 * k + 1), kR + z * s + 0.01 * kR * jitter(3 * k + 2)};
        const Vec3d centre{1.5 * s, 1.5 * s, kR + 1.5 * s};
        addParticle(c, at, kR * (1 + 0.01 * jitter(5 * k)), 0, -0.2 * (at - centre) * (1.0 / s),
                    {10 * jitter(7 * k), 10 * jitter(7 * k + 1), 10 * jitter(7 * k + 2)});
      }
  if (floor) {
    c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 0, "floor"));
    c.sim.gravity = {0, 0, -9.81};
  } else {
    c.sim.gravity = {0, 0, 0};
  }
  c.sim.duration = 1;
  return c;
}

struct State {
  std::map<Gid, Vec3d> x, v, w;
};

State run(RunConfig c, ModelMode mode, int steps, compute::ModelFlags* flags = nullptr, int* slots = nullptr,
          compute::CellGrid* grid = nullptr) {
  c.sim.model = mode;
  // PFLOW_TEST_EXECUTOR=cuda runs both models on the GPU (the same comparison of its kernels' paths).
  compute::SimulationOptions options;
  if (const char* e = std::getenv("PFLOW_TEST_EXECUTOR"); e && std::string(e) == "cuda") options.executor = compute::ExecutorKind::kCuda;
  auto sim = Simulation::create(c, options);
  EXPECT_TRUE(sim.isOk()) << sim.status().toString();
  if (!sim.isOk()) return {};
  EXPECT_TRUE(sim.value()->runSteps(steps).isOk());
  if (flags) *flags = compute::deriveModel(c).flags;
  if (slots) *slots = sim.value()->engine().historySlots();
  if (grid) *grid = sim.value()->grid();
  const auto s = sim.value()->snapshot();
  State st;
  const Gid* id = s.find("id")->as<Gid>();
  for (std::size_t i = 0; i < s.n; ++i) {
    st.x[id[i]] = s.find("position")->as<Vec3d>()[i];
    st.v[id[i]] = s.find("velocity")->as<Vec3d>()[i];
    st.w[id[i]] = s.find("angular_velocity")->as<Vec3d>()[i];
  }
  return st;
}

// Largest difference between two runs, and whether they are bit for bit the same.
double maxDiff(const std::map<Gid, Vec3d>& a, const std::map<Gid, Vec3d>& b, bool* identical) {
  double d = 0;
  for (const auto& [g, x] : a) {
    const Vec3d y = b.at(g);
    d = std::max(d, norm(x - y));
    *identical = *identical && x.x == y.x && x.y == y.y && x.z == y.z;
  }
  return d;
}

// The two runs agree within round-off: positions to 1e-10 of a radius, velocities to 1e-8 m/s, spins to
// 1e-6 rad/s after thousands of steps (speeds are ~0.1 m/s, spins ~10 rad/s). Not always bit for bit: the
// compiler contracts a*b + c into fused multiply-adds differently in each instantiation of the kernels
// (x86-64-v3 has FMA), which changes the last bit. Prints what it measured.
void expectSame(const State& least, const State& full, const char* what) {
  bool identical = true;
  const double dx = maxDiff(least.x, full.x, &identical);
  const double dv = maxDiff(least.v, full.v, &identical);
  const double dw = maxDiff(least.w, full.w, &identical);
  EXPECT_LT(dx, 1e-10 * kR) << what;
  EXPECT_LT(dv, 1e-8) << what;
  EXPECT_LT(dw, 1e-6) << what;
  std::printf("%s: least against full model, largest differences: position %.3g m, velocity %.3g m/s, spin %.3g rad/s%s\n",
              what, dx, dv, dw, identical ? " (bit for bit the same)" : "");
}

TEST(LeastModel, FrictionlessClusterWithoutHistoryMatchesTheFullModel) {
  const RunConfig c = cluster(0.0, 0.0, true);
  compute::ModelFlags flags;
  int slots = -1;
  const State least = run(c, ModelMode::kAuto, 3000, &flags, &slots);
  const State full = run(c, ModelMode::kFull, 3000);
  EXPECT_FALSE(flags.tangential);
  EXPECT_FALSE(flags.rolling);
  EXPECT_EQ(slots, 0);  // no history slots allocated
  // Frictionless, so spins never change: the least model drops their terms from v_n, which changes v_n by
  // round-off only (the spin terms are normal to n).
  expectSame(least, full, "frictionless cluster on a floor");
  bool spinsSame = true;
  maxDiff(least.w, full.w, &spinsSame);
  EXPECT_TRUE(spinsSame);
}

TEST(LeastModel, FrictionlessClusterWithoutSpinsOrWalls) {
  RunConfig c = cluster(0.0, 0.0, false);
  c.particles.angularVelocity.assign(c.particles.size(), Vec3d{0, 0, 0});
  const State least = run(c, ModelMode::kAuto, 2000);
  const State full = run(c, ModelMode::kFull, 2000);
  expectSame(least, full, "frictionless cluster, no spins, no walls");
}

TEST(LeastModel, NoRollingFrictionWithoutTheRollingPath) {
  const RunConfig c = cluster(0.5, 0.0, true);
  compute::ModelFlags flags;
  const State least = run(c, ModelMode::kAuto, 3000, &flags);
  const State full = run(c, ModelMode::kFull, 3000);
  EXPECT_TRUE(flags.tangential);
  EXPECT_FALSE(flags.rolling);
  expectSame(least, full, "cluster on a floor with friction, no rolling friction");
}

TEST(LeastModel, NoGeometryWithoutWallPhases) {
  const RunConfig c = cluster(0.5, 0.02, false);
  compute::ModelFlags flags;
  const State least = run(c, ModelMode::kAuto, 3000, &flags);
  const State full = run(c, ModelMode::kFull, 3000);
  EXPECT_FALSE(flags.walls);
  EXPECT_TRUE(flags.tangential);
  EXPECT_TRUE(flags.rolling);
  expectSame(least, full, "cluster with friction and rolling friction, no walls");
}

// A 2D pile: 10 x 6 discs in the x-z plane (y = 0.004), with friction and rolling friction, on a floor
// between two side walls, under gravity: it collapses and settles.
RunConfig planarPile() {
  RunConfig c;
  c.materials = {material("m", 1e7, 0.3, 2500, 0.5, 0.5, 0.02)};
  int k = 0;
  for (int z = 0; z < 6; ++z)
    for (int x = 0; x < 10; ++x, ++k)
      addParticle(c, {kR + x * 2.05 * kR + 0.02 * kR * jitter(k), 0.004, 1.05 * kR + z * 2.05 * kR}, kR * (1 + 0.02 * jitter(3 * k)), 0,
                  {0.05 * jitter(5 * k), 0, 0}, {0, 20 * jitter(7 * k), 0});
  c.planes.push_back(plane({0, 0, 0}, {0, 0, 1}, 0, "floor"));
  c.planes.push_back(plane({-0.1 * kR, 0, 0}, {1, 0, 0}, 0, "left"));
  c.planes.push_back(plane({22 * kR, 0, 0}, {-1, 0, 0}, 0, "right"));
  c.sim.gravity = {0, 0, -9.81};
  c.sim.duration = 1;
  return c;
}

TEST(LeastModel, PlanarSceneIn2DMatchesFull3D) {
  const RunConfig c = planarPile();
  compute::ModelFlags flags;
  compute::CellGrid grid2, grid3;
  const State d2 = run(c, ModelMode::kAuto, 4000, &flags, nullptr, &grid2);
  const State d3 = run(c, ModelMode::kFull, 4000, nullptr, nullptr, &grid3);
  EXPECT_EQ(flags.planarAxis, 1);
  EXPECT_EQ(grid2.ny, 1);  // one layer of cells: 9 searched instead of 27
  EXPECT_GT(grid3.ny, 1);
  expectSame(d2, d3, "2D pile (2D against 3D)");
  // Really moved, and stayed in the plane with spins about y only.
  double moved = 0;
  for (const auto& [g, x] : d2.x) {
    EXPECT_EQ(x.y, 0.004);
    EXPECT_EQ(d2.w.at(g).x, 0.0);
    EXPECT_EQ(d2.w.at(g).z, 0.0);
    moved = std::max(moved, norm(x - c.particles.position[g]));
  }
  EXPECT_GT(moved, 0.05 * kR);
}

}  // namespace
}  // namespace pflow::test
