// The rates pass's walk (sph::kernels::Interact) skips the rows and cells of its 125 that lie farther than the support
// from a particle even when their particles have moved half the skin out of them (walkGap). It must still find
// every neighbour: random particles, some listed in the grid's edge cells from beyond the grid, are moved up to
// half the skin after the sort, and the pass with the skipping gives the same rates bit for bit as the full walk.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <vector>

#include "compute/sph/SphKernels.h"

using namespace pflow;
using namespace pflow::compute;
using namespace pflow::compute::sph;

namespace {

template <class R>
struct Outputs {
  std::vector<Vec3<R>> acc;
  std::vector<R> drho, visc;
};

template <class R>
Outputs<R> runPass(const sph::kernels::Interact<R>& base, R margin, Index n, bool twoPhase = false) {
  Outputs<R> o{std::vector<Vec3<R>>(n), std::vector<R>(n), std::vector<R>(n)};
  sph::kernels::Interact<R> k = base;
  k.acc = o.acc.data();
  k.drho = o.drho.data();
  k.visc = o.visc.data();
  k.margin = margin;
  for (Index a = 0; a < n; ++a) {
    if (twoPhase) k.template run<sph::kernels::RatePass::kTwoPhase>(a);
    else k(a);
  }
  return o;
}

// Random particles in a grid of cells h + skin/2 wide, sorted by cell and packed for the rates pass: 3 % listed in the
// edge cells from up to a cell beyond the grid, each moved up to half the skin since the sort (many by exactly half of
// it), a quarter of them boundary particles; masses 1 g, or random in [0.5, 1.5] g (`randomMass`).
template <class R>
struct RandomScene {
  static constexpr double h = 0.01, skin = 0.25 * h, cs = h + skin / 2;
  Index n = 0;
  CellGrid grid;
  std::vector<Vec3d> home, pos;
  std::vector<Index> cellStart;
  std::vector<Vec3<R>> vel;
  std::vector<R> rho, p, mass;
  std::vector<std::int32_t> kind;
  std::vector<sph::kernels::RateRow<R>> row;
  std::vector<sph::kernels::RateState<R>> state;
  std::vector<sph::kernels::RatePm<R>> pm;

  RandomScene(unsigned seed, Index count, bool randomMass = false) : n(count) {
    grid.lo = {0, 0, 0};
    grid.cellSize = cs;
    grid.invCellSize = 1 / cs;
    grid.nx = 9, grid.ny = 7, grid.nz = 8;
    grid.reach = 2;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    home.resize(n), pos.resize(n);
    for (Index i = 0; i < n; ++i) {
      const bool outside = u(rng) < 0.03;
      const double pad = outside ? cs : 0;
      home[i] = {-pad + u(rng) * (grid.nx * cs + 2 * pad), -pad + u(rng) * (grid.ny * cs + 2 * pad), -pad + u(rng) * (grid.nz * cs + 2 * pad)};
    }
    std::vector<Index> order(n);
    std::iota(order.begin(), order.end(), Index(0));
    std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return grid.cellOf(home[a]) < grid.cellOf(home[b]); });
    std::vector<Vec3d> sorted(n);
    for (Index i = 0; i < n; ++i) sorted[i] = home[order[i]];
    home = sorted;
    cellStart.assign(grid.numCells() + 1, 0);
    for (Index i = 0; i < n; ++i) ++cellStart[grid.cellOf(home[i]) + 1];
    std::partial_sum(cellStart.begin(), cellStart.end(), cellStart.begin());
    for (Index i = 0; i < n; ++i) {
      Vec3d d{u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5};
      const double len = norm(d);
      d = (0.5 * skin * (u(rng) < 0.5 ? 1.0 : u(rng)) / len) * d;
      pos[i] = home[i] + d;
    }
    vel.resize(n), rho.resize(n), p.resize(n), mass.assign(n, R(1e-3)), kind.resize(n);
    for (Index i = 0; i < n; ++i) {
      vel[i] = {R(u(rng) - 0.5), R(u(rng) - 0.5), R(u(rng) - 0.5)};
      rho[i] = R(990 + 20 * u(rng));
      p[i] = R(1000 * (u(rng) - 0.3));
      kind[i] = u(rng) < 0.25 ? 1 : sph::kernels::kFluid;
      if (randomMass) mass[i] = R(1e-3 * (0.5 + u(rng)));
    }
    row.resize(n), state.resize(n), pm.resize(n);
    for (Index i = 0; i < n; ++i) pack()(i);
  }
  sph::kernels::PackRates<R> pack() {
    return {grid, home.data(), nullptr, n, pos.data(), vel.data(), rho.data(), p.data(), mass.data(), kind.data(), row.data(), state.data(), pm.data()};
  }
  // The rates pass over these rows (outputs unset): alpha 0.1, laminar nu 1e-3 m^2/s, delta 0.1 with the hydrostatic
  // correction or without (`hydrostatic`), c0 30 m/s, Wendland C2 in 3D.
  sph::kernels::Interact<R> pass(bool hydrostatic = true) {
    PairParams<R> params;
    params.alpha = R(0.1);
    params.nu = R(1e-3);
    params.delta = R(0.1);
    params.hydrostatic = hydrostatic;
    params.h = R(h);
    params.c0 = R(30);
    params.eta2 = R(0.01 * h * h);
    params.gOverC2 = {R(0), R(0), R(-9.81 / 900)};
    return {grid, cellStart.data(), home.data(), row.data(), state.data(), pm.data(), Kernel<R>::make(KernelKind::kWendlandC2, 3, h), params,
            Vec3<R>{R(0), R(0), R(-9.81)}, nullptr, nullptr, nullptr};
  }
};

// How many of n particles' rates differ between the full walk and one that skips with `marginOfSkin` times half the
// skin as its margin (and 1e-5 of a cell for rounding); a negative `marginOfSkin`: the pass over hit masks instead
// (overfullRows: how many particles had a row longer than the masks hold).
template <class R>
int differingRates(unsigned seed, double marginOfSkin, Index n = 6000, int* overfullRows = nullptr, double markedSkin = 1.0,
                   bool twoPhase = false) {
  int overfull = 0, markedDiffer = 0;
  RandomScene<R> sc(seed, n);
  const double skin = sc.skin, cs = sc.cs, h = sc.h;
  const sph::kernels::PackRates<R> pack = sc.pack();
  const sph::kernels::Interact<R> k = sc.pass();
  const Outputs<R> full = runPass(k, R(-1), n);
  Outputs<R> pruned;
  if (marginOfSkin >= 0) {
    pruned = runPass(k, R(0.5 * skin * marginOfSkin + 1e-5 * cs), n, twoPhase);
  } else {  // hit masks instead of the walk: marked by the pass at the sort (positions = home)
    std::vector<sph::kernels::RateRow<R>> atSort(n);
    sph::kernels::PackRates<R> packAtSort = pack;
    packAtSort.pos = sc.home.data();
    packAtSort.row = atSort.data();
    for (Index i = 0; i < n; ++i) packAtSort(i);
    const double reach = 2 * h + markedSkin * skin;  // the support plus the skin (markedSkin: a fraction of it)
    std::vector<std::uint32_t> masks(std::size_t(n) * sph::kernels::kMaskSlots, 0xdeadbeefu);  // unused slots hold junk
    std::vector<std::uint64_t> rows(n);
    sph::kernels::Interact<R> marking = k;
    marking.row = atSort.data();
    marking.markMasks = masks.data();
    marking.markRows = rows.data();
    marking.markCut2 = R(reach * reach * (1 + 1e-4));
    marking.maskLayout = ListLayout::columnMajor(n);  // the GPU's layout
    const Outputs<R> marked = runPass(marking, R(0.5 * skin * 1.001 + 1e-5 * cs), n);
    for (Index a = 0; a < n; ++a) overfull += (rows[a] >> 32) != 0;
    // The marking pass's own rates (at the sort) are the full walk's there.
    sph::kernels::Interact<R> atSortWalk = k;
    atSortWalk.row = atSort.data();
    const Outputs<R> walked = runPass(atSortWalk, R(-1), n);
    for (Index a = 0; a < n; ++a)
      markedDiffer += marked.drho[a] != walked.drho[a] || marked.visc[a] != walked.visc[a] || marked.acc[a].x != walked.acc[a].x ||
                      marked.acc[a].y != walked.acc[a].y || marked.acc[a].z != walked.acc[a].z;
    sph::kernels::Interact<R> withMasks = k;
    withMasks.masks = masks.data();
    withMasks.maskRows = rows.data();
    withMasks.maskLayout = marking.maskLayout;
    pruned = runPass(withMasks, R(-1), n);
    if (overfullRows) *overfullRows = overfull;
  }
  int differ = 0, neighbours = 0;
  for (Index a = 0; a < n; ++a) {
    differ += full.drho[a] != pruned.drho[a] || full.visc[a] != pruned.visc[a] || full.acc[a].x != pruned.acc[a].x ||
              full.acc[a].y != pruned.acc[a].y || full.acc[a].z != pruned.acc[a].z;
    neighbours += full.drho[a] != R(0);
  }
  EXPECT_GT(neighbours, int(n / 2));  // the pass did see neighbours
  return differ + markedDiffer;
}

TEST(SphWalk, SkippedCellsHoldNoNeighbourDouble) {
  for (unsigned seed : {1u, 2u, 3u}) EXPECT_EQ(differingRates<double>(seed, 1.001), 0) << "seed " << seed;
}

TEST(SphWalk, SkippedCellsHoldNoNeighbourFloat) {
  for (unsigned seed : {4u, 5u, 6u}) EXPECT_EQ(differingRates<float>(seed, 1.001), 0) << "seed " << seed;
}

// The hit masks marked by the pass at the sort give the walk's rates bit for bit after the particles moved: at
// about 12 particles a cell (rows of about 60, some past the 64 places the masks hold) and at 48 (every row past
// them: the rest walked).
TEST(SphWalk, HitMasksGiveTheWalksRates) {
  for (unsigned seed : {7u, 8u}) EXPECT_EQ(differingRates<double>(seed, -1.0), 0) << "seed " << seed;
  for (unsigned seed : {9u, 10u}) EXPECT_EQ(differingRates<float>(seed, -1.0), 0) << "seed " << seed;
  int overfull = 0;
  EXPECT_EQ(differingRates<float>(11u, -1.0, 24000, &overfull), 0);
  EXPECT_GT(overfull, 20000);
  EXPECT_EQ(differingRates<double>(12u, -1.0, 24000, &overfull), 0);
  EXPECT_GT(overfull, 20000);
}

// The walk in two phases (every candidate tested, then the pairs in one loop over the buffered pieces) adds the
// same pairs in the same order: the same sums, at 12 particles a cell and at 48, where a particle has more pieces
// with neighbours than the buffer holds (added in turns).
TEST(SphWalk, TwoPhaseWalkGivesTheWalksRates) {
  EXPECT_EQ(differingRates<double>(14u, 1.001, 6000, nullptr, 1.0, true), 0);
  EXPECT_EQ(differingRates<float>(15u, 1.001, 6000, nullptr, 1.0, true), 0);
  EXPECT_EQ(differingRates<float>(16u, 1.001, 24000, nullptr, 1.0, true), 0);
  EXPECT_EQ(differingRates<double>(17u, 1.001, 24000, nullptr, 1.0, true), 0);
}

// So is the masks': marked within the support alone, they miss neighbours that came closer since the sort.
TEST(SphWalk, MasksMarkedWithoutTheSkinMissNeighbours) {
  EXPECT_GT(differingRates<double>(13u, -1.0, 6000, nullptr, 0.0), 0);
}

// The pairs once (Interact's kOnce: each particle walks the upper half of its rows, evaluates those pairs and adds the
// partner's share to its sums; FinishRates writes the rates) against the full walk from both sides, on particles of
// random masses (the partner's share takes the other's mass), with every pair term on (artificial and laminar
// viscosity, the diffusion with and without its hydrostatic correction): the same rates to rounding, the acceleration
// and the density rate as vectors over all particles (||once - walk|| / ||walk||) and particle by particle (within
// 100 times that of the particle's own scale, the sum of its pairs' magnitudes, bounded here by the walk's largest
// rate), and the largest viscous rate (the step's limit) the same. The walk in one phase and in two, at 12
// particles a cell and at 48 (the two-phase buffer full).
template <class R>
void expectPairsOnceGiveTheWalksRates(unsigned seed, Index n, bool twoPhase, double tolerance, bool hydrostatic = true) {
  RandomScene<R> sc(seed, n, true);
  const sph::kernels::Interact<R> k = sc.pass(hydrostatic);
  const Outputs<R> walk = runPass(k, R(-1), n);
  Outputs<R> once{std::vector<Vec3<R>>(n, Vec3<R>{R(7), R(7), R(7)}), std::vector<R>(n, R(7)), std::vector<R>(n, R(7))};
  std::vector<sph::kernels::RateSum<R>> sums(n, sph::kernels::RateSum<R>{{R(0), R(0), R(0)}, R(0)});
  sph::kernels::Interact<R> half = k;
  half.acc = once.acc.data();
  half.drho = once.drho.data();
  half.visc = once.visc.data();
  half.sums = sums.data();
  half.margin = R(0.5 * sc.skin * 1.001 + 1e-5 * sc.cs);
  for (Index a = 0; a < n; ++a) {
    if (twoPhase) half.template run<sph::kernels::RatePass::kTwoPhase, true>(a);
    else half.template run<sph::kernels::RatePass::kWalk, true>(a);
  }
  const sph::kernels::FinishRates<R> finish{sums.data(), sc.kind.data(), k.gravity, once.acc.data(), once.drho.data()};
  for (Index i = 0; i < n; ++i) finish(i);
  double dAcc = 0, nAcc = 0, dRho = 0, nRho = 0, maxWalk = 0, maxOnce = 0, accScale = 0, rhoScale = 0;
  for (Index i = 0; i < n; ++i) {
    accScale = std::max(accScale, norm(vcast<double>(walk.acc[i])));
    rhoScale = std::max(rhoScale, std::fabs(double(walk.drho[i])));
  }
  int wallsMoved = 0, farOff = 0;
  for (Index i = 0; i < n; ++i) {
    farOff += norm(vcast<double>(once.acc[i] - walk.acc[i])) > 100 * tolerance * accScale ||
              std::fabs(double(once.drho[i] - walk.drho[i])) > 100 * tolerance * rhoScale;
    dAcc += norm2(vcast<double>(once.acc[i] - walk.acc[i]));
    nAcc += norm2(vcast<double>(walk.acc[i]));
    dRho += std::pow(double(once.drho[i] - walk.drho[i]), 2);
    nRho += std::pow(double(walk.drho[i]), 2);
    maxWalk = std::max(maxWalk, double(walk.visc[i]));
    maxOnce = std::max(maxOnce, double(once.visc[i]));
    wallsMoved += sc.kind[i] != sph::kernels::kFluid && norm2(once.acc[i]) != R(0);
    EXPECT_EQ(sums[i].drho, R(0)) << "the sums are zeroed for the next pass";
  }
  std::printf("pairs once (%s, %d particles): acceleration %.3g, density rate %.3g off the walk's; largest viscous rate %.9g / %.9g\n",
              twoPhase ? "two phases" : "one phase", int(n), std::sqrt(dAcc / nAcc), std::sqrt(dRho / nRho), maxOnce, maxWalk);
  EXPECT_LT(std::sqrt(dAcc / nAcc), tolerance);
  EXPECT_LT(std::sqrt(dRho / nRho), tolerance);
  EXPECT_NEAR(maxOnce, maxWalk, tolerance * maxWalk);
  EXPECT_GT(maxWalk, 0.0);
  EXPECT_EQ(wallsMoved, 0);
  EXPECT_EQ(farOff, 0) << "particles whose rates are off the walk's";
}

TEST(SphWalk, PairsOnceGiveTheWalksRates) {
  expectPairsOnceGiveTheWalksRates<double>(21u, 6000, false, 1e-12);
  expectPairsOnceGiveTheWalksRates<double>(22u, 6000, true, 1e-12);
  expectPairsOnceGiveTheWalksRates<float>(23u, 6000, false, 5e-6);
  expectPairsOnceGiveTheWalksRates<float>(24u, 24000, true, 5e-6);
  expectPairsOnceGiveTheWalksRates<double>(25u, 6000, true, 1e-12, false);
}

// The check is sharp: skipping as if no particle had moved drops real neighbours of some that did.
TEST(SphWalk, AMarginBelowHalfTheSkinDropsNeighbours) {
  EXPECT_GT(differingRates<double>(1u, 0.0), 0);
}

}  // namespace
