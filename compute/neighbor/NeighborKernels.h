// Cell hash, reorder, and contact candidates from the 27 neighbouring cells.
#pragma once
#include <cstdint>
#include <cstring>

#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/neighbor/CellGrid.h"

namespace pflow::compute {

// Where entry e of particle i's row lives, in rows of a fixed capacity. Row-major (i * capacity + e) suits a
// CPU core walking its own row; column-major (e * n + i) lets the 32 threads of a GPU warp, 32 consecutive
// particles, read 32 consecutive words. The SPH hit masks' rows (each executor picks: Exec::kColumnMajorLists);
// DEM's candidate rows are RowSlices.
struct ListLayout {
  std::size_t rowStride = 1, colStride = 1;
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::size_t at(Index i, std::uint32_t e) const {
    return std::size_t(i) * rowStride + std::size_t(e) * colStride;
  }
  static ListLayout rowMajor(Index capacity) { return {capacity, 1}; }
  static ListLayout columnMajor(Index n) { return {1, n}; }
};

// Where entry e of particle i's candidate row lives: rows of exact length, in slices of 2^shift consecutive
// particles. A slice is as wide as its longest row, and holds its rows column-major: entry e of its particles
// are 2^shift consecutive words, from start[slice] * 2^shift. Both executors use shift 0 (compressed rows: a
// thread walks its own row, which the GPU's L1 serves after the first entry): on the H200's settled bed, slices
// of 32 (a warp's lanes reading 32 consecutive words) made the float force pass 6 % slower than compressed
// rows, which read no padding up to the slice's longest row (docs/performance.md). The rows take what the
// particles' own counts need, not every particle the longest row's room. Compressed rows need no counts of their
// own: row i ends where row i + 1 starts (start has one entry more than there are rows).
struct RowSlices {
  const std::uint32_t* start = nullptr;  // [slice]: first entry / 2^shift (exclusive scan of the widths)
  std::uint32_t shift = 0;
  const std::uint32_t* counts = nullptr;  // [i]: row lengths, for slices wider than a row (shift > 0); null at shift 0
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint32_t count(Index i) const { return counts ? counts[i] : start[i + 1] - start[i]; }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::size_t base(Index i) const {
    return (std::size_t(start[i >> shift]) << shift) + (i & ((Index(1) << shift) - 1));
  }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::size_t stride() const { return std::size_t(1) << shift; }
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::size_t at(Index i, std::uint32_t e) const {
    return base(i) + (std::size_t(e) << shift);
  }
};

}  // namespace pflow::compute

namespace pflow::compute::kernels {

// Distributed runs: flag[i] = 1 when owned particle i has a ghost (local row >= owned) among its
// candidates, so its forces need the refreshed halo; 0 when they can be computed while it is in flight.
struct MarkBoundary {
  const Index* nbr;
  RowSlices layout;
  Index owned;
  std::uint32_t* flag;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const std::uint32_t n = layout.count(i);
    std::uint32_t b = 0;
    for (std::uint32_t e = 0; e < n; ++e) b |= nbr[layout.at(i, e)] >= owned ? 1u : 0u;
    flag[i] = b;
  }
};

// Splits [0, n) by flag into one list: flagged rows first ([0, flagged), in order), then the others.
// `scan` is the exclusive prefix sum of `flag`.
struct SplitByFlag {
  const std::uint32_t* flag;
  const std::uint32_t* scan;
  Index flagged;
  Index* list;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    if (flag[i]) list[scan[i]] = i;
    else list[flagged + i - scan[i]] = i;
  }
};

// The flagged rows only, in order: list[scan[i]] = i where flag[i] (scan: flag's exclusive scan), list sized by their
// count (SplitByFlag when the rest is wanted after them).
struct CompactFlagged {
  const std::uint32_t* flag;
  const std::uint32_t* scan;
  Index* list;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    if (flag[i]) list[scan[i]] = i;
  }
};

// Runs kernel `f` over the rows in `list` (item k is row list[k]): a pass over part of the particles.
// Only the force kernels use it, whose work per particle varies.
template <class F>
constexpr int maxRegisters() {
  if constexpr (requires { F::kMaxRegisters; }) return F::kMaxRegisters;
  else return 0;
}

template <class F>
struct OverList {
  static constexpr bool kVariableCost = true;  // CpuExecutor::forEach: dynamic chunks
  static constexpr int kMaxRegisters = maxRegisters<F>();  // CudaExecutor: as f's
  F f;
  const Index* list;
  PFLOW_HOSTDEVICE void operator()(Index k) const { f(list[k]); }
};

// f over [first, first + count): a forEach over part of the rows.
template <class F>
struct Offset {
  F f;
  Index first;
  PFLOW_HOSTDEVICE void operator()(Index k) const { f(first + k); }
};

struct CellKey {
  CellGrid grid;
  const Vec3d* pos;
  std::uint32_t* key;
  PFLOW_HOSTDEVICE void operator()(Index i) const { key[i] = grid.cellOf(pos[i]); }
};

// key[i] = the cell layer of particle i along `axis` (0 x, 1 y, 2 z): its slab for ComputePairsOnce.
struct SlabKey {
  CellGrid grid;
  const Vec3d* pos;
  int axis;
  std::uint32_t* key;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    int c[3];
    grid.coords(pos[i], c[0], c[1], c[2]);
    key[i] = std::uint32_t(c[axis]);
  }
};

// Several blocks of rows in one launch (FieldRows::reorder where the rows are few, and a launch per block would cost
// more than its bytes): back = false gathers block b's row perm[k] to scratch + offset[b] + k stride[b]; back = true
// copies the scratch's rows to the blocks in place (FieldRows::pack: the gather alone, into packed blocks). Strides
// multiples of 4; 8-byte words where the stride and both bases allow.
struct GatherBlocks {
  static constexpr int kMax = 48;
  struct Block {
    unsigned char* data;
    std::size_t stride, offset;
  };
  Block block[kMax];
  int blocks = 0;
  unsigned char* scratch;
  const Index* perm;
  bool back = false;
  PFLOW_HOSTDEVICE void operator()(Index k) const {
    for (int b = 0; b < blocks; ++b) {
      const Block& x = block[b];
      const unsigned char* src = back ? scratch + x.offset + std::size_t(k) * x.stride : x.data + std::size_t(perm[k]) * x.stride;
      unsigned char* dst = back ? x.data + std::size_t(k) * x.stride : scratch + x.offset + std::size_t(k) * x.stride;
      if (x.stride % 8 == 0 && (reinterpret_cast<std::uintptr_t>(x.data) | reinterpret_cast<std::uintptr_t>(scratch + x.offset)) % 8 == 0) {
        for (std::size_t w = 0; w < x.stride / 8; ++w)
          reinterpret_cast<std::uint64_t*>(dst)[w] = reinterpret_cast<const std::uint64_t*>(src)[w];
      } else {
        for (std::size_t w = 0; w < x.stride / 4; ++w)
          reinterpret_cast<std::uint32_t*>(dst)[w] = reinterpret_cast<const std::uint32_t*>(src)[w];
      }
    }
  }
};

// dst[k] = src[perm[k]] for elements of `stride` bytes: one field of the table at a time.
struct GatherBytes {
  const unsigned char* src;
  unsigned char* dst;
  const Index* perm;
  std::size_t stride;
  // Copies by 8- or 4-byte words (every field is a multiple of one and buffers are 64-byte aligned):
  // a run-time-sized memcpy would go byte by byte on the GPU.
  // The word size also needs both bases aligned to it: packed blocks (Engine::pack) start wherever the
  // previous block ended, a multiple of 4 bytes only (a GPU faults on a misaligned 8-byte access).
  PFLOW_HOSTDEVICE void operator()(Index k) const {
    const std::size_t from = std::size_t(perm[k]) * stride, to = std::size_t(k) * stride;
    const std::size_t bases = std::size_t(reinterpret_cast<std::uintptr_t>(src) | reinterpret_cast<std::uintptr_t>(dst));
    if (stride % 8 == 0 && bases % 8 == 0) {
      const auto* s = reinterpret_cast<const std::uint64_t*>(src + from);
      auto* d = reinterpret_cast<std::uint64_t*>(dst + to);
      for (std::size_t w = 0; w < stride / 8; ++w) d[w] = s[w];
    } else if (stride % 4 == 0 && bases % 4 == 0) {
      const auto* s = reinterpret_cast<const std::uint32_t*>(src + from);
      auto* d = reinterpret_cast<std::uint32_t*>(dst + to);
      for (std::size_t w = 0; w < stride / 4; ++w) d[w] = s[w];
    } else {
      std::memcpy(dst + to, src + from, stride);
    }
  }
};


// Frees the history slots of `partners` that no entry of the row (nbrSlot, `count` entries `col` apart) refers to: the
// partner is no longer a candidate, so the contact has ended.
PFLOW_HOSTDEVICE inline void clearUnlistedSlots(SlotRow<PartnerId> partners, int slots, const std::int8_t* nbrSlot,
                                                std::size_t col, std::uint32_t count) {
  for (int k = 0; k < slots; ++k) {
    if (partners[k] == kNoPartner) continue;
    bool candidate = false;
    for (std::uint32_t e = 0; e < count && !candidate; ++e) candidate = nbrSlot[e * col] == k;
    if (!candidate) partners[k] = kNoPartner;
  }
}

// Candidates j of particle i with |x_i - x_j| < r_i + r_j + skin, in two passes over the same walk: the first
// (countOnly) counts each row, the host lays the rows out from the counts (SliceWidths, a scan: RowSlices), and
// the second fills them. Each candidate's history slot (the slot of i holding j's gid, or -1) is resolved in
// the second, so the force loop reaches its history directly; slots whose partner is no longer a candidate (it
// moved beyond the skin, so the contact has ended) are cleared. R: the precision of the radii. Without
// tangential history (slots == 0) only the candidates are listed (nbrSlot is not touched).
template <class R>
struct BuildNeighbors {
  static constexpr bool kVariableCost = true;  // work per particle varies (CpuExecutor::forEach)
  CellGrid grid;
  const Index* cellStart;  // numCells + 1
  const Vec3d* pos;
  const R* radius;
  const Gid* gid;
  PartnerId* historyPartner;
  int slots;
  SlotLayout slotLayout;
  double skin;
  RowSlices layout;
  Index* nbr;               // [layout.at(i, e)]
  std::int8_t* nbrSlot;     // [layout.at(i, e)]
  std::uint32_t* counted;   // [i]: written by the counting pass (the rows' starts, scanned in place, at shift 0)
  Conditions* cond;
  bool countOnly = false;
  // Ghosts (distributed runs; null otherwise): local particles ghostBase + ghostItems[k] for k in
  // [ghostCellStart[c], ghostCellStart[c + 1]) lie in cell c. Candidates of the owned particles only.
  const Index* ghostCellStart = nullptr;
  const Index* ghostItems = nullptr;
  Index ghostBase = 0;
  // Candidates in ascending global id, not in row order: a particle's forces are then summed in the same
  // order whatever the rows' order, so a distributed run reproduces one process bit for bit.
  bool canonicalOrder = false;
  // Only the candidates above i (j > i): the rows of the GPU's pairs once, where the lower index evaluates a pair
  // (ComputeForces' kHalf). Cells whose particles all lie at or below i are not walked.
  bool upperOnly = false;

  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const Vec3d xi = pos[i];
    const double ri = double(radius[i]) + skin;
    int cx, cy, cz;
    grid.coords(xi, cx, cy, cz);
    std::uint32_t count = 0;
    // The counting pass has no rows yet; the filling one writes no more than it counted (the same walk over
    // the same positions finds the same candidates: a mismatch is flagged, never written past).
    const std::uint32_t capacity = countOnly ? 0 : layout.count(i);
    const std::size_t row = countOnly ? 0 : layout.base(i), col = layout.stride();
    const SlotRow<PartnerId> partners = slotLayout.at(historyPartner, i);
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
          if (upperOnly && cellStart[c + 1] <= i + 1) continue;
          auto consider = [&](Index j) {
            const double cut = ri + double(radius[j]);
            if (norm2(pos[j] - xi) >= cut * cut) return;
            if (!countOnly && count < capacity) {
              nbr[row + count * col] = j;
              if (slots == 0) {  // no tangential history (ModelFlags::tangential): nothing to resolve
                ++count;
                return;
              }
              std::int8_t slot = -1;
              const PartnerId g = PartnerId(gid[j]);
              for (int k = 0; k < slots; ++k)
                if (partners[k] == g) slot = std::int8_t(k);
              nbrSlot[row + count * col] = slot;
            }
            ++count;
          };
          for (Index j = upperOnly && cellStart[c] <= i ? i + 1 : cellStart[c]; j < cellStart[c + 1]; ++j)
            if (j != i) consider(j);
          if (ghostCellStart)
            for (Index k = ghostCellStart[c]; k < ghostCellStart[c + 1]; ++k) consider(ghostBase + ghostItems[k]);
        }
      }
    }
    if (countOnly) {
      counted[i] = count;
      return;
    }
    if (count != capacity) {
      atomicOrU32(&cond->flags, kNeighborMismatch);
      return;
    }
    if (canonicalOrder)  // insertion sort by gid (rows are short and mostly in order already)
      for (std::uint32_t e = 1; e < count; ++e) {
        const Index j = nbr[row + e * col];
        const std::int8_t slot = nbrSlot[row + e * col];
        const Gid g = gid[j];
        std::uint32_t k = e;
        for (; k > 0 && gid[nbr[row + (k - 1) * col]] > g; --k) {
          nbr[row + k * col] = nbr[row + (k - 1) * col];
          nbrSlot[row + k * col] = nbrSlot[row + (k - 1) * col];
        }
        nbr[row + k * col] = j;
        nbrSlot[row + k * col] = slot;
      }
    // The upper rows of the GPU's pairs once keep their other histories until the pairs' owners have taken
    // theirs (PullHistoryHalf, then ClearUnlistedSlots).
    if (!upperOnly) clearUnlistedSlots(partners, slots, nbrSlot + row, col, count);
  }
};

// Width of each slice of candidate rows (RowSlices): its longest row, over the owned particles of the slice.
struct SliceWidths {
  const std::uint32_t* count;
  Index n;
  std::uint32_t shift;
  std::uint32_t* width;  // [slice]
  PFLOW_HOSTDEVICE void operator()(Index s) const {
    const Index first = s << shift;
    const Index last = n - first < (Index(1) << shift) ? n : first + (Index(1) << shift);
    std::uint32_t w = 0;
    for (Index i = first; i < last; ++i) w = count[i] > w ? count[i] : w;
    width[s] = w;
  }
};

}  // namespace pflow::compute::kernels
