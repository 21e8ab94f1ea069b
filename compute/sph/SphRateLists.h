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
  R margin = R(0);                 // Interact::margin

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
    // Cells whose nearest point, widened by the pass's margin (how far a particle may have left its cell since the
    // sort), is beyond the support plus the skin hold no candidate and are not walked (walkGap). The listed
    // candidates, and their order, are those of a walk over every cell.
    int cx, cy, cz;
    grid.coords(home[a], cx, cy, cz);
    const int r = grid.reach;
    R yRow = R(0), zRow = R(0);
    auto listed = [&](Index b, const RateRow<R>& rb) {
      if (b == a || (!fluidA && boundaryTag(rb.tag))) return false;  // walls: fluid neighbours only
      const Vec3<R> d{R(cxA - cellXOfTag(rb.tag)) * cs + (ra.x - rb.x), yRow - rb.y, zRow - rb.z};
      return norm2(d) < cut2;
    };
    for (int z = cz > r ? cz - r : 0; z <= (cz + r < grid.nz ? cz + r : grid.nz - 1); ++z) {
      const R gz = walkGap(ra.z, z - cz, cs, margin, z == 0, z == grid.nz - 1);
      if (gz * gz >= cut2) continue;
      zRow = ra.z - R(z - cz) * cs;
      for (int y = cy > r ? cy - r : 0; y <= (cy + r < grid.ny ? cy + r : grid.ny - 1); ++y) {
        const R gy = walkGap(ra.y, y - cy, cs, margin, y == 0, y == grid.ny - 1);
        const R g2 = gz * gz + gy * gy;
        if (g2 >= cut2) continue;
        yRow = ra.y - R(y - cy) * cs;
        int x0 = cx > r ? cx - r : 0, x1 = cx + r < grid.nx ? cx + r : grid.nx - 1;
        while (x0 < cx && [&] { const R g = walkGap(ra.x, x0 - cx, cs, margin, x0 == 0, false); return g2 + g * g >= cut2; }()) ++x0;
        while (x1 > cx && [&] { const R g = walkGap(ra.x, x1 - cx, cs, margin, false, x1 == grid.nx - 1); return g2 + g * g >= cut2; }()) --x1;
        const std::uint32_t c0 = grid.index(x0, y, z), c1 = grid.index(x1, y, z);
        const std::uint32_t code = rateListEntry(0, y - cy, z - cz);
        auto append = [&](Index b) {
          if (n < capacity) list[layout.at(a, n)] = code | (std::uint32_t(b) << 5);
          ++n;
        };
        if (ghostCellStart) {  // merged by id, cell by cell
          for (std::uint32_t c = c0; c <= c1; ++c)
            forCellMergedById(c, cellStart, ghostCellStart, ghostItems, ghostBase, gid, [&](Index b) {
              if (listed(b, row[b])) append(b);
            });
          continue;
        }
        // As the rates pass: 32 candidates tested into a mask, then the hits appended in order.
        const Index end = cellStart[c1 + 1];
        for (Index piece = cellStart[c0]; piece < end; piece += 32) {
          const int len = end - piece < 32 ? int(end - piece) : 32;
          std::uint32_t hits = 0;
          for (int j = 0; j < len; ++j) hits |= std::uint32_t(listed(piece + j, row[piece + j])) << j;
          for (; hits != 0; hits &= hits - 1) append(piece + Index(lowestSetBit(hits)));
        }
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
