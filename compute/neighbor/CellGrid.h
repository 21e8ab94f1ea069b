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
  // f(c) for the cells that share a face, edge or corner with the cell holding `p`, itself included, in index
  // order (z, then y, then x): at most 27, 9 in a grid one cell thick.
  template <class F>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void forNeighbourCells(Vec3d p, const F& f) const {
    int cx, cy, cz;
    coords(p, cx, cy, cz);
    forNeighbourCells(cx, cy, cz, f);
  }
  template <class F>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void forNeighbourCells(int cx, int cy, int cz, const F& f) const {
    for (int z = cz > 0 ? cz - 1 : 0; z <= (cz + 1 < nz ? cz + 1 : nz - 1); ++z)
      for (int y = cy > 0 ? cy - 1 : 0; y <= (cy + 1 < ny ? cy + 1 : ny - 1); ++y)
        for (int x = cx > 0 ? cx - 1 : 0; x <= (cx + 1 < nx ? cx + 1 : nx - 1); ++x) f(index(x, y, z));
  }
};

}  // namespace pflow::compute
