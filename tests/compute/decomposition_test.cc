// Domain decomposition (compute/decomp): every point has exactly one owner, ranges along the curve are
// contiguous and compact, and the busiest rank stays within 10 % of the mean for uniform beds and for a
// bed gathered in one corner (a hopper draining into a bin), for any rank count.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "compute/decomp/Decomposition.h"

namespace pflow::test {
namespace {

using compute::CellGrid;
using compute::decomp::MultiSectionDecomposition;
using compute::decomp::SfcDecomposition;

CellGrid grid(int n) {
  CellGrid g;
  g.lo = {0, 0, 0};
  g.cellSize = 1.0 / n;
  g.invCellSize = n;
  g.nx = g.ny = g.nz = n;
  return g;
}

// Particles of a hopper discharge late in the run: 70 % piled in the corner box [0, 0.3]^3, the rest
// spread through the domain.
std::vector<Vec3d> cornerHeavy(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec3d> x(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double s = k % 10 < 7 ? 0.3 : 1.0;
    x[k] = {s * u(rng), s * u(rng), s * u(rng)};
  }
  return x;
}

std::vector<double> cellCounts(const CellGrid& g, const std::vector<Vec3d>& x) {
  std::vector<double> w(g.numCells(), 0.0);
  for (const auto& p : x) w[g.cellOf(p)] += 1;
  return w;
}

TEST(Decomposition, MortonKeyInterleavesBits) {
  EXPECT_EQ(compute::decomp::mortonKey(0, 0, 0), 0u);
  EXPECT_EQ(compute::decomp::mortonKey(1, 0, 0), 1u);
  EXPECT_EQ(compute::decomp::mortonKey(0, 1, 0), 2u);
  EXPECT_EQ(compute::decomp::mortonKey(0, 0, 1), 4u);
  EXPECT_EQ(compute::decomp::mortonKey(3, 3, 3), 63u);
  EXPECT_EQ(compute::decomp::mortonKey(0x1fffff, 0, 0), 0x1249249249249249ull);
}

TEST(Decomposition, DivisionsMultiplyToTheRankCountAndFollowTheDomain) {
  for (int p : {1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 27, 64}) {
    const auto d = compute::decomp::chooseDivisions(p, {1, 1, 1});
    EXPECT_EQ(d[0] * d[1] * d[2], p);
  }
  EXPECT_EQ(compute::decomp::chooseDivisions(8, {1, 1, 1}), (std::array<int, 3>{2, 2, 2}));
  EXPECT_EQ(compute::decomp::chooseDivisions(4, {4, 1, 0.1}), (std::array<int, 3>{4, 1, 1}));  // a long, flat bed
  const auto d7 = compute::decomp::chooseDivisions(7, {1, 1, 1});  // a prime: all on one axis
  EXPECT_EQ(std::max({d7[0], d7[1], d7[2]}), 7);
}

TEST(Decomposition, SfcGivesEveryCellOneOwnerAndContiguousRanges) {
  const CellGrid g = grid(16);
  std::vector<double> w(g.numCells(), 1.0);
  for (int ranks : {1, 2, 3, 5, 8}) {
    auto d = SfcDecomposition::build(g, w, ranks);
    ASSERT_TRUE(d.isOk()) << d.status().toString();
    std::vector<int> cells(std::size_t(ranks), 0);
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x) {
          const int r = d.value().ownerOfCell(x, y, z);
          ASSERT_GE(r, 0);
          ASSERT_LT(r, ranks);
          ++cells[std::size_t(r)];
          // Contiguity: the owner never decreases along the curve.
          const std::uint64_t key = compute::decomp::mortonKey(std::uint32_t(x), std::uint32_t(y), std::uint32_t(z));
          EXPECT_GE(key, d.value().firstKeys()[std::size_t(r)]);
        }
    const double mean = double(g.numCells()) / ranks;
    for (int c : cells) EXPECT_NEAR(c, mean, 1.0) << ranks << " ranks";
    EXPECT_LE(compute::decomp::imbalance(d.value().rankWeights()), 1.0 + 1.0 / mean);
  }
}

TEST(Decomposition, SfcRangesAreCompact) {
  // 8 ranks on a uniform 16^3 grid: the Z-order curve cuts it into the eight 8^3 octants exactly.
  const CellGrid g = grid(16);
  auto d = SfcDecomposition::build(g, std::vector<double>(g.numCells(), 1.0), 8);
  ASSERT_TRUE(d.isOk());
  for (int z = 0; z < 16; ++z)
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) EXPECT_EQ(d.value().ownerOfCell(x, y, z), (x / 8) + 2 * (y / 8) + 4 * (z / 8));
}

TEST(Decomposition, SfcBalancesABedGatheredInOneCorner) {
  const CellGrid g = grid(32);
  const auto x = cornerHeavy(200000, 3);
  const auto w = cellCounts(g, x);
  for (int ranks : {2, 3, 4, 6, 8}) {
    auto d = SfcDecomposition::build(g, w, ranks);
    ASSERT_TRUE(d.isOk());
    std::vector<double> load(std::size_t(ranks), 0.0);
    for (const auto& p : x) load[std::size_t(d.value().ownerOf(p))] += 1;
    const double im = compute::decomp::imbalance(load);
    std::printf("sfc, %d ranks: busiest/mean %.4f\n", ranks, im);
    EXPECT_LE(im, 1.10);
    EXPECT_EQ(load, d.value().rankWeights());  // owners agree with the weights the split saw
  }
}

TEST(Decomposition, MultiSectionBalancesAnyRankCount) {
  for (const bool corner : {false, true}) {
    std::vector<Vec3d> x;
    if (corner) {
      x = cornerHeavy(100000, 5);
    } else {
      std::mt19937_64 rng(9);
      std::uniform_real_distribution<double> u(0, 1);
      for (int k = 0; k < 100000; ++k) x.push_back({2 * u(rng), u(rng), 0.5 * u(rng)});
    }
    for (int ranks : {1, 2, 3, 4, 5, 6, 7, 8, 12, 16}) {
      auto d = MultiSectionDecomposition::build(x, {}, ranks, {0, 0, 0}, corner ? Vec3d{1, 1, 1} : Vec3d{2, 1, 0.5});
      ASSERT_TRUE(d.isOk()) << d.status().toString();
      const auto div = d.value().divisions();
      EXPECT_EQ(div[0] * div[1] * div[2], ranks);
      std::vector<double> load(std::size_t(ranks), 0.0);
      for (const auto& p : x) {
        const int r = d.value().ownerOf(p);
        ASSERT_GE(r, 0);
        ASSERT_LT(r, ranks);
        load[std::size_t(r)] += 1;
      }
      EXPECT_EQ(load, d.value().rankWeights());
      EXPECT_LE(compute::decomp::imbalance(load), 1.10) << ranks << " ranks, corner " << corner;
    }
  }
}

TEST(Decomposition, WeightsAreCostsNotCounts) {
  // Half the samples cost three times as much: the split follows the cost.
  std::vector<Vec3d> x;
  std::vector<double> w;
  for (int k = 0; k < 1000; ++k) {
    x.push_back({k / 1000.0, 0.5, 0.5});
    w.push_back(k < 500 ? 3.0 : 1.0);
  }
  auto d = MultiSectionDecomposition::build(x, w, 2, {0, 0, 0}, {1, 0.1, 0.1});
  ASSERT_TRUE(d.isOk());
  EXPECT_NEAR(d.value().rankWeights()[0], 1000.0, 3.0);  // the first 333 expensive samples
  EXPECT_NEAR(d.value().rankWeights()[1], 1000.0, 3.0);
  EXPECT_LT(d.value().ownerOf({0.2, 0.5, 0.5}), d.value().ownerOf({0.5, 0.5, 0.5}));
}

TEST(Decomposition, OutsidePointsStillHaveAnOwner) {
  const auto x = cornerHeavy(1000, 1);
  auto m = MultiSectionDecomposition::build(x, {}, 6, {0, 0, 0}, {1, 1, 1});
  auto s = SfcDecomposition::build(grid(8), cellCounts(grid(8), x), 6);
  ASSERT_TRUE(m.isOk() && s.isOk());
  for (Vec3d p : {Vec3d{-5, -5, -5}, Vec3d{5, 5, 5}, Vec3d{0.5, -1, 2}}) {
    EXPECT_GE(m.value().ownerOf(p), 0);
    EXPECT_LT(m.value().ownerOf(p), 6);
    EXPECT_GE(s.value().ownerOf(p), 0);
    EXPECT_LT(s.value().ownerOf(p), 6);
  }
}

TEST(Decomposition, BadInputIsRefusedWithTheReason) {
  const CellGrid g = grid(4);
  EXPECT_EQ(SfcDecomposition::build(g, std::vector<double>(g.numCells(), 1.0), 0).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(SfcDecomposition::build(g, std::vector<double>(3, 1.0), 2).status().code(), StatusCode::kInvalidArgument);
  std::vector<double> w(g.numCells(), 1.0);
  w[5] = std::nan("");
  const auto bad = SfcDecomposition::build(g, w, 2);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("cell weight[5]"), std::string::npos) << bad.status().message();
  EXPECT_EQ(MultiSectionDecomposition::build({{0, 0, 0}}, {1.0, 2.0}, 2, {0, 0, 0}, {1, 1, 1}).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(MultiSectionDecomposition::build({{0, std::nan(""), 0}}, {}, 2, {0, 0, 0}, {1, 1, 1}).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace pflow::test
