// SPH across MPI ranks on the CPU executor (PFLOW_TEST_EXECUTOR=cuda: the GPUs), at whatever rank count mpirun gives (ctest runs 1, 2 and 4 ranks):
// the dam break's particles split by cell (the same MpiDomain as DEM: decomposition, migration, halo). With
// neighbours summed in global-id order (canonical order, as distributed runs sum them), the run equals one
// process bit for bit: the surge front's times are equal (the issue asks for 0.5 %), every particle is kept
// (mass conserved exactly), and the halo overlap (interior rates while the ghosts travel) equals the halo in
// sequence.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <cstdio>

#include "compute/mpi/MpiDomain.h"
#include "tests/support/MpiTest.h"
#include "tests/support/SphScenes.h"

namespace pflow::test {
namespace {

using compute::MpiDomain;
using compute::RunConfig;
using compute::sph::SphOptions;
using compute::sph::SphSimulation;

int worldRank() {
  int r;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

// The dam break at 20 x 40 to Z = 3.5: front times at kFrontZ, and the gathered snapshot's fluid count and mass.
struct Result {
  std::vector<double> t;
  std::size_t fluid = 0;
  double mass = 0;
  std::int64_t steps = 0;
};

Result run(bool distributed, bool overlap, bool mirror = false) {
  const double dp = 0.01;
  RunConfig c = damBreak2D(dp, 0.45);
  if (mirror) c = withMirrorWalls(c);
  SphOptions o;
  o.executor = testExecutor();  // PFLOW_TEST_EXECUTOR=cuda: on the GPUs, one a rank where there are enough
  if (o.executor == compute::ExecutorKind::kCuda) o.device = testDevice();
  o.overlapHalo = overlap;
  o.canonicalOrder = true;  // the one-process reference sums in the distributed runs' order
  // Balance by particle count: measured costs would make the decomposition, and so the summation order, depend
  // on timings.
  compute::MpiDomainOptions split;
  split.cost = compute::MpiDomainOptions::Cost::kCount;
  if (distributed) o.domain = std::make_shared<MpiDomain>(MPI_COMM_WORLD, split);
  auto sim = SphSimulation::create(c, o);
  EXPECT_TRUE(sim.isOk()) << sim.status().message();
  Result r;
  if (!sim.isOk()) return r;
  r.t = frontTimes(*sim.value(), dp, kFrontZ, 0.45);
  r.steps = sim.value()->stepCount();
  const compute::ParticleSnapshot s = sim.value()->snapshot({"mass", "kind"});
  if (worldRank() == 0 || !distributed) {
    const auto* m = s.find("mass")->as<double>();
    const auto* kind = s.find("kind")->as<std::int32_t>();
    for (std::size_t i = 0; i < s.n; ++i)
      if (kind[i] == 0) ++r.fluid, r.mass += m[i];
  }
  return r;
}

// The one-process reference, run by rank 0 alone and sent to the others (its fluid count and mass stay on rank 0,
// which alone compares them): four ranks on two cores computing it at once took twice as long.
Result reference(bool mirror) {
  Result r;
  if (worldRank() == 0) r = run(false, true, mirror);
  int n = int(r.t.size());
  MPI_Bcast(&n, 1, MPI_INT, 0, MPI_COMM_WORLD);
  r.t.resize(std::size_t(n));
  MPI_Bcast(r.t.data(), n, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  MPI_Bcast(&r.steps, 1, MPI_INT64_T, 0, MPI_COMM_WORLD);
  return r;
}

TEST(SphDistributed, SurgeFrontWithinHalfAPercentOfOneProcess) {
  const Result one = reference(false);
  const Result split = run(true, true);     // the halo overlapped with the interior rates
  const Result serial = run(true, false);   // the halo in sequence
  ASSERT_EQ(one.t.size(), kFrontZ.size());
  for (std::size_t k = 0; k < kFrontZ.size(); ++k) {
    ASSERT_TRUE(std::isfinite(split.t[k])) << "Z = " << kFrontZ[k];
    EXPECT_NEAR(split.t[k], one.t[k], 0.005 * one.t[k]) << "Z = " << kFrontZ[k];
    EXPECT_EQ(split.t[k], one.t[k]) << "Z = " << kFrontZ[k] << ": not bit for bit";
    // Overlap changes when the ghosts are read, never their values: bit for bit the same as in sequence.
    EXPECT_EQ(split.t[k], serial.t[k]) << "Z = " << kFrontZ[k];
  }
  EXPECT_EQ(split.steps, one.steps);
  if (worldRank() == 0) {
    EXPECT_EQ(split.fluid, one.fluid);
    EXPECT_EQ(split.mass, one.mass);
    std::printf("ranks: front T at Z = 1.5 .. 3.5:");
    for (std::size_t k = 0; k < kFrontZ.size(); ++k) std::printf(" %.4f (one process %.4f)", split.t[k], one.t[k]);
    std::printf("; %lld steps (one process %lld)\n", (long long)split.steps, (long long)one.steps);
  }
}

// Mirror walls: the images are taken of whichever particle is listed near a wall, owned or ghost, in the same
// canonical order, so ranks give the one process's front bit for bit.
TEST(SphDistributed, MirrorWallsSameFrontAsOneProcess) {
  const Result one = reference(true);
  const Result split = run(true, true, true);
  ASSERT_EQ(one.t.size(), kFrontZ.size());
  for (std::size_t k = 0; k < kFrontZ.size(); ++k) {
    ASSERT_TRUE(std::isfinite(split.t[k])) << "Z = " << kFrontZ[k];
    EXPECT_EQ(split.t[k], one.t[k]) << "Z = " << kFrontZ[k] << ": not bit for bit";
  }
  EXPECT_EQ(split.steps, one.steps);
  if (worldRank() == 0) {
    EXPECT_EQ(split.mass, one.mass);
  }
}

// The ranks share the expected work, not the particle count: a wall particle near the fluid weighs half a fluid
// particle, a dry one 0.05 (compute::sph::sphCostWeight). In the dam break most walls are dry (the column fills a
// fifth of the tank), so count balance would leave the ranks away from the column with little to do.
TEST(SphDistributed, PartitionBalancesTheExpectedWork) {
  const RunConfig c = damBreak2D(0.01, 0.45);
  auto setup = compute::sph::prepareSphSetup(c);
  ASSERT_TRUE(setup.isOk()) << setup.status().message();
  const auto& st = setup.value();
  const std::vector<double> w = compute::sph::sphCostWeights(st.grid, st.position, st.kind);
  ASSERT_EQ(w.size(), st.position.size());
  double total = 0;
  int fluid = 0, wet = 0, dry = 0;
  for (std::size_t i = 0; i < w.size(); ++i) {
    total += w[i];
    if (st.kind[i] == 0) {
      EXPECT_EQ(w[i], 1.0);
      ++fluid;
      continue;
    }
    // A wall particle is wet when a fluid particle is listed within the grid's reach of its cell: closer than `reach`
    // cells to the column (its particles span x, z = 0.005 .. 0.195, 0.395 m) it is, further than reach + 1 it is not.
    const double reach = st.grid.reach * st.grid.cellSize;
    const bool nearColumn = st.position[i].x < 0.195 + reach && st.position[i].z < 0.395 + reach;
    const bool farFromColumn = st.position[i].x > 0.195 + reach + st.grid.cellSize;
    if (nearColumn) {
      EXPECT_EQ(w[i], 0.5) << "x = " << st.position[i].x;
    }
    if (farFromColumn) {
      EXPECT_EQ(w[i], 0.05) << "x = " << st.position[i].x;
    }
    (w[i] == 0.5 ? wet : dry) += 1;
  }
  EXPECT_GT(dry, wet);  // most of the tank's walls are dry
  EXPECT_EQ(fluid, 800);

  SphOptions o;
  o.executor = testExecutor();
  if (o.executor == compute::ExecutorKind::kCuda) o.device = testDevice();
  compute::MpiDomainOptions split;
  split.cost = compute::MpiDomainOptions::Cost::kCount;
  o.domain = std::make_shared<MpiDomain>(MPI_COMM_WORLD, split);
  auto sim = SphSimulation::create(c, o);
  ASSERT_TRUE(sim.isOk()) << sim.status().message();
  const compute::ParticleSnapshot mine = sim.value()->snapshot({"id"}, true);
  double local = 0;
  const auto* id = mine.find("id")->as<Gid>();
  for (std::size_t i = 0; i < mine.n; ++i) local += w[std::size_t(id[i])];
  int ranks = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  std::vector<double> all(std::size_t(ranks), 0.0);
  MPI_Allgather(&local, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, MPI_COMM_WORLD);
  const double mean = total / ranks;
  // The curve cuts between cells (a cell of the column holds about 3.5 fluid particles here): within 10 %.
  for (int r = 0; r < ranks; ++r) EXPECT_NEAR(all[std::size_t(r)], mean, 0.1 * mean) << "rank " << r << " of " << ranks;
}

}  // namespace
}  // namespace pflow::test
