// Domain decomposition: which rank owns each point of space, from weights that measure cost. Two
// strategies behind one interface, chosen per run:
//  - SfcDecomposition (the seed patent's): per-cell weights, cells ordered along a Morton (Z-order)
//    space-filling curve, contiguous ranges of about equal weight, so each rank's cells are compact in 3D;
//  - MultiSectionDecomposition (FDPS): cuts along x, then y within each slab, then z within each column,
//    for any rank count, placed at weighted quantiles of sampled particles.
// Both are built from the same global inputs on every rank (the caller reduces cell weights or gathers
// samples first), so every rank holds the whole map and agrees on every owner. Plain host code: no MPI.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/core/VectorMath.h"
#include "compute/neighbor/CellGrid.h"

namespace pflow::compute::decomp {

class Decomposition {
 public:
  virtual ~Decomposition() = default;
  virtual const char* name() const = 0;
  virtual int ranks() const = 0;
  // The rank that owns point x (every point has exactly one owner, points outside the domain included).
  virtual int ownerOf(Vec3d x) const = 0;
};

// Morton key of a cell: the bits of its three coordinates interleaved (x lowest), up to 21 bits each.
std::uint64_t mortonKey(std::uint32_t cx, std::uint32_t cy, std::uint32_t cz);

class SfcDecomposition final : public Decomposition {
 public:
  // cellWeights: one non-negative value per cell of `grid`, indexed by grid.index(x, y, z).
  static Result<SfcDecomposition> build(const CellGrid& grid, const std::vector<double>& cellWeights, int ranks);

  const char* name() const override { return "sfc"; }
  int ranks() const override { return int(m_firstKey.size()); }
  int ownerOf(Vec3d x) const override;
  int ownerOfCell(int cx, int cy, int cz) const;
  // The Morton key at which each rank's range begins (rank 0's is 0); ranges are [first[r], first[r+1]).
  const std::vector<std::uint64_t>& firstKeys() const { return m_firstKey; }
  // The weight each rank received.
  const std::vector<double>& rankWeights() const { return m_rankWeight; }

 private:
  CellGrid m_grid;
  std::vector<std::uint64_t> m_firstKey;
  std::vector<double> m_rankWeight;
};

class MultiSectionDecomposition final : public Decomposition {
 public:
  // samples: positions of (a sample of) the particles; weights: one non-negative cost per sample (empty:
  // all 1). domainLo/domainHi: the box the divisions' proportions are chosen for.
  static Result<MultiSectionDecomposition> build(const std::vector<Vec3d>& samples, const std::vector<double>& weights,
                                                 int ranks, Vec3d domainLo, Vec3d domainHi);

  const char* name() const override { return "multisection"; }
  int ranks() const override { return m_div[0] * m_div[1] * m_div[2]; }
  int ownerOf(Vec3d x) const override;
  // nx * ny * nz = ranks, chosen so the cut surfaces are smallest for the domain's proportions.
  std::array<int, 3> divisions() const { return m_div; }
  // The weight of the samples each rank received.
  const std::vector<double>& rankWeights() const { return m_rankWeight; }

 private:
  std::array<int, 3> m_div{1, 1, 1};
  std::vector<double> m_xCuts;                            // nx - 1
  std::vector<std::vector<double>> m_yCuts;               // [i]: ny - 1
  std::vector<std::vector<std::vector<double>>> m_zCuts;  // [i][j]: nz - 1
  std::vector<double> m_rankWeight;
};

// max / mean of the ranks' weights (1 = perfect balance; 0 when there is no weight at all).
double imbalance(const std::vector<double>& rankWeights);

// The divisions nx * ny * nz = ranks whose cut surfaces are smallest in a box of these extents.
std::array<int, 3> chooseDivisions(int ranks, Vec3d extent);

}  // namespace pflow::compute::decomp
