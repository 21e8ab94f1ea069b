// Uniform cell grid over the domain. Positions outside the domain map to the nearest boundary cell,
// which keeps every contact findable (clamping never separates two points closer than a cell).
#pragma once
#include <cstdint>

#include "compute/core/VectorMath.h"

namespace pflow::compute {

struct CellGrid {
  Vec3d lo{0, 0, 0};
  double cellSize = 1;
  double invCellSize = 1;
  int nx = 1, ny = 1, nz = 1;
  // How many cells around a particle's own hold its neighbours: 1 where cells are as wide as the cut-off
  // (DEM), 2 where they are half of it (SPH: fewer candidates per neighbour). forNeighbourCells walks them,
  // and the MPI halo sends every particle to the ranks owning a cell within reach of its own.
  int reach = 1;

  std::uint32_t numCells() const { return std::uint32_t(nx) * std::uint32_t(ny) * std::uint32_t(nz); }

  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE static int clampAxis(double x, double lo, double inv, int n) {
    const double f = (x - lo) * inv;
    if (!(f >= 0.0)) return 0;  // also catches NaN
    if (f >= double(n)) return n - 1;
    return int(f);
  }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void coords(Vec3d p, int& cx, int& cy, int& cz) const {
    cx = clampAxis(p.x, lo.x, invCellSize, nx);
    cy = clampAxis(p.y, lo.y, invCellSize, ny);
    cz = clampAxis(p.z, lo.z, invCellSize, nz);
  }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint32_t index(int cx, int cy, int cz) const {
    return (std::uint32_t(cz) * std::uint32_t(ny) + std::uint32_t(cy)) * std::uint32_t(nx) + std::uint32_t(cx);
  }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint32_t cellOf(Vec3d p) const {
    int cx, cy, cz;
    coords(p, cx, cy, cz);
    return index(cx, cy, cz);
  }
  // f(c) for the cells within `reach` cells of the one holding `p` along every axis, itself included, in index
  // order (z, then y, then x): at most (2 reach + 1)^3 (27 at reach 1), (2 reach + 1)^2 in a grid one cell thick.
  template <class F>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void forNeighbourCells(Vec3d p, const F& f) const {
    int cx, cy, cz;
    coords(p, cx, cy, cz);
    forNeighbourCells(cx, cy, cz, f);
  }
  template <class F>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void forNeighbourCells(int cx, int cy, int cz, const F& f) const {
    for (int z = cz > reach ? cz - reach : 0; z <= (cz + reach < nz ? cz + reach : nz - 1); ++z)
      for (int y = cy > reach ? cy - reach : 0; y <= (cy + reach < ny ? cy + reach : ny - 1); ++y)
        for (int x = cx > reach ? cx - reach : 0; x <= (cx + reach < nx ? cx + reach : nx - 1); ++x) f(index(x, y, z));
  }
};

}  // namespace pflow::compute
