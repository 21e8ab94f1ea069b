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
};

}  // namespace pflow::compute
