// Cell hash, reorder, and contact candidates from the 27 neighbouring cells.
#pragma once
#include <cstdint>
#include <cstring>

#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/neighbor/CellGrid.h"

namespace pflow::compute::kernels {

struct CellKey {
  CellGrid grid;
  const Vec3d* pos;
  std::uint32_t* key;
  PFLOW_HOSTDEVICE void operator()(Index i) const { key[i] = grid.cellOf(pos[i]); }
};

// dst[k] = src[perm[k]] for elements of `stride` bytes: one field of the table at a time.
struct GatherBytes {
  const unsigned char* src;
  unsigned char* dst;
  const Index* perm;
  std::size_t stride;
  PFLOW_HOSTDEVICE void operator()(Index k) const { std::memcpy(dst + k * stride, src + perm[k] * stride, stride); }
};

struct CopyPositions {
  const Vec3d* src;
  Vec3d* dst;
  PFLOW_HOSTDEVICE void operator()(Index i) const { dst[i] = src[i]; }
};

// Candidates j of particle i with |x_i - x_j| < r_i + r_j + skin, in fixed-stride rows of `capacity`.
// Each candidate's history slot (the slot of i holding j's gid, or -1) is resolved here, so the
// force loop reaches its history directly; slots whose partner is no longer a candidate (it moved
// beyond the skin, so the contact has ended) are cleared.
struct BuildNeighbors {
  CellGrid grid;
  const Index* cellStart;  // numCells + 1
  const Vec3d* pos;
  const double* radius;
  const Gid* gid;
  Gid* historyPartner;  // [i * slots + k]
  int slots;
  double skin;
  Index capacity;
  Index* nbr;               // [i * capacity + e]
  std::int8_t* nbrSlot;     // [i * capacity + e]
  std::uint32_t* nbrCount;  // [i]
  Conditions* cond;

  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const Vec3d xi = pos[i];
    const double ri = radius[i] + skin;
    int cx, cy, cz;
    grid.coords(xi, cx, cy, cz);
    std::uint32_t count = 0;
    const std::size_t row = std::size_t(i) * capacity;
    Gid* partners = historyPartner + std::size_t(i) * slots;
    for (int dz = -1; dz <= 1; ++dz) {
      const int z = cz + dz;
      if (z < 0 || z >= grid.nz) continue;
      for (int dy = -1; dy <= 1; ++dy) {
        const int y = cy + dy;
        if (y < 0 || y >= grid.ny) continue;
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = cx + dx;
          if (x < 0 || x >= grid.nx) continue;
          const std::uint32_t c = grid.index(x, y, z);
          for (Index j = cellStart[c]; j < cellStart[c + 1]; ++j) {
            if (j == i) continue;
            const double cut = ri + radius[j];
            if (norm2(pos[j] - xi) >= cut * cut) continue;
            if (count < capacity) {
              nbr[row + count] = j;
              std::int8_t slot = -1;
              const Gid g = gid[j];
              for (int k = 0; k < slots; ++k)
                if (partners[k] == g) slot = std::int8_t(k);
              nbrSlot[row + count] = slot;
            }
            ++count;
          }
        }
      }
    }
    nbrCount[i] = count;
    if (count > capacity) {
      atomicOrU32(&cond->flags, kNeighborOverflow);
      atomicMaxU32(&cond->neededNeighbors, count);
      return;
    }
    for (int k = 0; k < slots; ++k) {
      if (partners[k] == kNoGid) continue;
      bool candidate = false;
      for (std::uint32_t e = 0; e < count && !candidate; ++e) candidate = nbrSlot[row + e] == k;
      if (!candidate) partners[k] = kNoGid;
    }
  }
};

}  // namespace pflow::compute::kernels
