// The SPH rates pass's neighbour lists (docs/sph.md, "Neighbours"): built after each cell sort by the walk of the
// cells within reach that the pass itself would do (the same cells in the same order, ghosts merged by global id),
// keeping each candidate within the support plus the skin. Until the next sort no two particles come closer by more
// than the skin (the step loop sorts again before any particle moves half of it), so every pair within the support
// is listed, and the pass (kernels::Interact) evaluates exactly the walk's pairs in the walk's order: the same sums,
// bit for bit, while testing only the listed candidates.
#pragma once
#include <cstdint>

#include "compute/neighbor/NeighborKernels.h"
#include "compute/sph/SphKernels.h"

namespace pflow::compute::sph::kernels {

// A list entry: the candidate's row and which of the 25 rows of cells around a's it is listed in (dz and dy of
// -2..2 as (dz + 2) * 5 + dy + 2), so the pass rebuilds the separation from the packed offsets exactly as the walk.
inline constexpr std::uint32_t kMaxListedRow = (1u << 27) - 1;
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint32_t rateListEntry(Index b, int dy, int dz) {
  return (std::uint32_t(b) << 5) | std::uint32_t((dz + 2) * 5 + (dy + 2));
}

template <class R>
struct BuildRateLists {
  static constexpr bool kVariableCost = true;
  CellGrid grid;
  const Index* cellStart;
  const Vec3d* home;
  const RateRow<R>* row;  // PackRates, at the sort (every offset its particle's position then)
  R cut2;                 // (support + skin)^2, widened for rounding
  const std::uint8_t* wet = nullptr;
  const Index* ghostCellStart = nullptr;
  const Index* ghostItems = nullptr;
  Index ghostBase = 0;
  const Gid* gid = nullptr;
  std::uint32_t capacity = 0;
  ListLayout layout;
  std::uint32_t* list = nullptr;
  std::uint32_t* count = nullptr;  // the candidates found, also beyond capacity (the host grows it and builds again)

  PFLOW_HOSTDEVICE void operator()(Index a) const {
    const RateRow<R> ra = row[a];
    const bool fluidA = !boundaryTag(ra.tag);
    std::uint32_t n = 0;
    if (!fluidA && wet && !wet[a]) {  // a dry wall particle: the pass skips it
      count[a] = 0;
      return;
    }
    const R cs = R(grid.cellSize);
    const std::int32_t cxA = cellXOfTag(ra.tag);
    int cx, cy, cz;
    grid.coords(home[a], cx, cy, cz);
    const int r = grid.reach;
    for (int z = cz > r ? cz - r : 0; z <= (cz + r < grid.nz ? cz + r : grid.nz - 1); ++z) {
      const R zRow = ra.z - R(z - cz) * cs;
      for (int y = cy > r ? cy - r : 0; y <= (cy + r < grid.ny ? cy + r : grid.ny - 1); ++y) {
        const R yRow = ra.y - R(y - cy) * cs;
        auto consider = [&](Index b) {
          const RateRow<R> rb = row[b];
          if (b == a || (!fluidA && boundaryTag(rb.tag))) return;  // walls: fluid neighbours only
          const Vec3<R> d{R(cxA - cellXOfTag(rb.tag)) * cs + (ra.x - rb.x), yRow - rb.y, zRow - rb.z};
          if (norm2(d) >= cut2) return;
          if (n < capacity) list[layout.at(a, n)] = rateListEntry(b, y - cy, z - cz);
          ++n;
        };
        const int x0 = cx > r ? cx - r : 0, x1 = cx + r < grid.nx ? cx + r : grid.nx - 1;
        const std::uint32_t c0 = grid.index(x0, y, z), c1 = grid.index(x1, y, z);
        if (ghostCellStart) {
          for (std::uint32_t c = c0; c <= c1; ++c) forCellMergedById(c, cellStart, ghostCellStart, ghostItems, ghostBase, gid, consider);
          continue;
        }
        for (Index b = cellStart[c0]; b < cellStart[c1 + 1]; ++b) consider(b);
      }
    }
    count[a] = n;
  }
};

// The largest count (the capacity the lists need).
struct ListCountOf {
  const std::uint32_t* count;
  PFLOW_HOSTDEVICE double operator()(Index i) const { return double(count[i]); }
};

}  // namespace pflow::compute::sph::kernels
