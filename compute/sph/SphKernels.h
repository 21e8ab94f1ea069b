// The SPH engine's kernels: one particle per call, PFLOW_HOSTDEVICE, run by either executor. The pair loop
// walks the cells within two of a particle's (125; 25 in 2D), so there are no neighbour lists to store (opt-in: hit
// masks, a bit for each of the first 64 places of each row): the cells are h + skin/2 wide and re-sorted when a particle may have moved
// half the skin (docs/sph.md, "Neighbours").
// Each kernel writes only the particle it owns (no atomics on the rates), but for the pairs once (Interact's kOnce:
// simulation.reproducible false, one process), where each pair is evaluated by one of its particles and its share
// added to the other's row of sums by an atomic add.
#pragma once
#include <cmath>
#include <cstdint>

#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/core/FastMath.h"
#include "compute/neighbor/CellGrid.h"
#include "compute/neighbor/NeighborKernels.h"
#include "compute/sph/SphPhysics.h"

namespace pflow::compute::sph::kernels {

inline constexpr std::int32_t kFluid = 0;

// The rates pass reads its neighbours from three packed arrays (PackRates writes them from the field table
// before each pass), so a candidate costs one 16-byte load (float) and a neighbour two more:
//  - RateRow: the position as an offset from the corner of the cell the row is listed in, in the run's
//    precision (a few cells' width, so float keeps 1e-7 of a cell: positions themselves are double), and a tag,
//    the cell's x index times 2 plus 1 for a boundary particle. y and z of the cell are the walk's own row.
//  - RateState: velocity and density. RatePm: p/rho^2, mass and m/rho (the pair terms' quotients, once per
//    particle instead of once per pair).
template <class R>
struct alignas(4 * sizeof(R)) RateRow {
  R x, y, z;
  std::int32_t tag;
};
template <class R>
struct alignas(4 * sizeof(R)) RateState {
  Vec3<R> v;
  R rho;
};
template <class R>
struct alignas(4 * sizeof(R)) RatePm {
  R pOverRho2, m, mOverRho, unused;
};
// The pairs once's sums of one particle: acceleration and density rate, added to by every pair it is in (FinishRates
// copies them into the rates). One 16-byte vector atomic add a pair in float (red.v4.f32), four double adds in double.
template <class R>
struct alignas(4 * sizeof(R)) RateSum {
  Vec3<R> a;
  R drho;
};
template <class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void addRateSum(RateSum<R>* to, Vec3<R> a, R drho) {
  if constexpr (sizeof(R) == 4) {
    atomicAddSum4(reinterpret_cast<Sum4*>(to), a.x, a.y, a.z, drho);
  } else {
    atomicAddReal(&to->a.x, a.x), atomicAddReal(&to->a.y, a.y), atomicAddReal(&to->a.z, a.z);
    atomicAddReal(&to->drho, drho);
  }
}
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool boundaryTag(std::int32_t tag) { return tag & 1; }
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::int32_t cellXOfTag(std::int32_t tag) { return tag >> 1; }

// Row i of the packed arrays: owned rows are listed in the cell of their position at the sort (`home`), ghosts
// in the cell their key names (LocalRows::setGhosts).
template <class R>
struct PackRates {
  CellGrid grid;
  const Vec3d* home;
  const std::uint32_t* ghostKey;  // null without ghosts
  Index owned;
  const Vec3d* pos;
  const Vec3<R>* vel;
  const R* rho;
  const R* p;
  const R* mass;
  const std::int32_t* kind;
  RateRow<R>* row;
  RateState<R>* state;
  RatePm<R>* pm;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    int cx, cy, cz;
    if (i < owned) {
      grid.coords(home[i], cx, cy, cz);
    } else {
      const std::uint32_t key = ghostKey[i - owned];
      cx = int(key % std::uint32_t(grid.nx));
      cy = int((key / std::uint32_t(grid.nx)) % std::uint32_t(grid.ny));
      cz = int(key / (std::uint32_t(grid.nx) * std::uint32_t(grid.ny)));
    }
    const Vec3d corner = grid.lo + grid.cellSize * Vec3d{double(cx), double(cy), double(cz)};
    const Vec3d o = pos[i] - corner;
    row[i] = RateRow<R>{R(o.x), R(o.y), R(o.z), cx * 2 + (kind[i] == kFluid ? 0 : 1)};
    state[i] = RateState<R>{vel[i], rho[i]};
    const R r = rho[i];
    pm[i] = RatePm<R>{p[i] / (r * r), mass[i], mass[i] / r, R(0)};
  }
};

// The rows and ghosts listed in cell c, merged by global id: in id order where each list is (SortCellByGid, the
// canonical order of distributed runs), so a particle's sums do not depend on the ranks.
template <class F>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void forCellMergedById(std::uint32_t c, const Index* cellStart, const Index* ghostCellStart,
                                                          const Index* ghostItems, Index ghostBase, const Gid* gid, F&& consider) {
  Index b = cellStart[c], k = ghostCellStart[c];
  const Index bEnd = cellStart[c + 1], kEnd = ghostCellStart[c + 1];
  while (b < bEnd || k < kEnd) {
    if (k >= kEnd || (b < bEnd && gid[b] < gid[ghostBase + ghostItems[k]])) consider(b++);
    else consider(ghostBase + ghostItems[k++]);
  }
}

// Rates of particle a at the current state: acceleration (fluid only: boundary particles do not move),
// density rate and the largest viscous rate over its neighbours (for the time step). Fluid particles
// interact with every neighbour; boundary particles only with fluid ones (their continuity equation:
// boundary-boundary pairs have no relative velocity).
// The walk: the grid's cells are half the support plus half the skin wide (reach 2: 1.7 times fewer candidates
// than 27 cells of the whole support), and without ghosts each of the 25 rows of 5 cells along x around a's home
// cell is one contiguous range of rows (cells are numbered x fastest): no per-cell loop. Rows, and cells at the
// ends of a row, that lie farther than the support from a even when their particles have moved `margin` out of
// them are not walked (walkGap: 81 of the 125 cells for a particle at the centre of its cell, skin 0.15 or 0.25 h).
// How far a's offset o (from the low corner of its home cell, along one axis) lies from the cells d away along
// that axis, widened by `margin` on both sides (a particle listed there is within margin of its cell). The grid's
// first and last cells along the axis also list the particles beyond it (CellGrid::coords clamps): open there.
template <class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R walkGap(R o, int d, R cs, R margin, bool first, bool last) {
  const R lo = R(d) * cs - margin, hi = R(d + 1) * cs + margin;
  return (o < lo && !first) ? lo - o : ((o > hi && !last) ? o - hi : R(0));
}

// The hit masks the pass can read instead of walking every candidate (the first pass after a sort marks them).
inline constexpr int kMaskRows = 25;   // rows of cells around a's, (dz + 2) * 5 + (dy + 2); reach 2 only
inline constexpr int kMaskPieces = 2;  // 32-candidate pieces kept per row, counted from the row's first cell
inline constexpr int kMaskSlots = kMaskRows * kMaskPieces;

// The first sorted particle of the walk's row of cells (y, z) around column cx: a row's pieces count from there (the
// cell two to the left, or the grid's first along x), whatever the walk prunes; and the row's end.
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Index maskRowBase(const CellGrid& grid, const Index* cellStart, int cx, int y, int z) {
  return cellStart[grid.index(cx > 2 ? cx - 2 : 0, y, z)];
}
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE Index maskRowEnd(const CellGrid& grid, const Index* cellStart, int cx, int y, int z) {
  return cellStart[grid.index(cx + 2 < grid.nx ? cx + 2 : grid.nx - 1, y, z) + 1];
}

// Which loop a rates pass runs (Interact::run): the walk of the cells, the walk that also marks the hit masks (the
// first pass after a sort), or the loop over the masks. Each is a kernel of its own on the GPU (InteractPass), so
// that none carries the others' registers.
// kTwoPhase is the walk that first tests every candidate of its rows, keeping the pieces with neighbours (a bit a
// candidate) in a small buffer, and then adds the pairs in one loop over the buffer: a warp's lanes wait through
// the lane with the most pairs once, not in every piece (pflow-sph-lanes: 30 of 32 lanes busy in that loop against
// 17 in the walk's, on SPHERIC at 4.8e6). The same pairs in the same order as the walk. The GPU's walk in float
// (timed on an H100 at 0.94-0.97 of the one-phase walk's pass: the buffer lives in local memory; in double 1.25).
// A full buffer is added at once by the lanes that filled it, while the warp's other lanes wait: with 8 words instead
// of 32 a step from rest took 3.3x as long, and with 16 the flow's 0.32 s advance did not finish in 200 s (not
// timed further). With 64, the same as 32 (bench/RESULTS.md).
enum class RatePass { kWalk, kMark, kMasks, kTwoPhase };
inline constexpr int kTwoPhaseWords = 32;  // pieces buffered before their pairs are added (more: added in turns)

template <class R>
struct Interact {
  static constexpr bool kVariableCost = true;  // work per particle varies (CpuExecutor::forEach)
  // CudaExecutor: 64 registers in float, more warps resident (11.9 -> 11.0 ms a step on SPHERIC at 4·10^6); in
  // double the cap spills (25.5 -> 38.1 ms).
  static constexpr int kMaxRegisters = sizeof(R) == 4 ? 64 : 0;
  CellGrid grid;
  const Index* cellStart;  // numCells + 1
  const Vec3d* home;       // positions at the last sort: the cell a particle is listed in
  const RateRow<R>* row;   // PackRates
  const RateState<R>* state;
  const RatePm<R>* pm;
  Kernel<R> kernel;
  PairParams<R> params;
  Vec3<R> gravity;
  Vec3<R>* acc;
  R* drho;
  R* visc;
  // Ghosts (distributed runs; null otherwise). They are merged with the rows by global id, cell by cell: with
  // each cell's rows and ghosts in id order (SortCellByGid: the canonical order distributed runs keep) a
  // particle's sums are taken in the same order whatever the ranks, so a distributed run equals one process
  // bit for bit (one process walks the same cells in the same order).
  const Index* ghostCellStart = nullptr;
  const Index* ghostItems = nullptr;
  Index ghostBase = 0;
  const Gid* gid = nullptr;
  // Boundary particles with no fluid listed in the cells within reach (MarkWet: wet[a] == 0) have no rates until
  // the next sort: they are skipped (most of a tank's walls and lid, most of the time).
  const std::uint8_t* wet = nullptr;
  // sph.boundary_density: mdbc: a boundary particle's rates are not used (its density is extrapolated), so the passes
  // from both sides skip its row as they skip a dry one. Not the pairs once: there a boundary row carries the pairs it
  // owns, the fluid's share included.
  bool skipBoundary = false;
  // How far a particle may be from the cell it is listed in: half the skin (the step loop sorts again before any
  // particle moves more), widened by 0.1 % and 1e-5 of a cell for the roundings of the gaps. Negative: walk all.
  R margin = R(-1);
  // Hit masks (RatePass::kMasks): which candidates of each of a's rows lay within the support plus the skin at the
  // last sort, a bit each for the first kMaskPieces x 32 places of a row (docs/sph.md, "Performance"), so a particle
  // evaluates the same pairs in the same order as the walk and tests only the candidates marked (and the rest of an
  // overfull row).
  const std::uint32_t* masks = nullptr;
  const std::uint64_t* maskRows = nullptr;
  ListLayout maskLayout;
  // The first pass after a sort (positions at home; no ghosts) writes them while it walks: which candidates lie
  // within markCut2 (the support plus the skin, widened for rounding), a row's used/overfull bits in markRows.
  std::uint32_t* markMasks = nullptr;
  std::uint64_t* markRows = nullptr;
  R markCut2 = R(0);
  // The pairs once (run<P, true>; the walk in one or two phases, one process without ghosts): a particle walks the
  // upper half of its rows only (dz > 0, or dz = 0 and dy > 0, and in its own row the particles after it), so each
  // pair within the support is evaluated by exactly one of its particles (the walk's pruning keeps every neighbour, so
  // the half it skips is walked by the partner), which adds the partner's share to `sums` and its own at its end;
  // FinishRates then writes acc and drho. Half the candidates tested and half the pairs, for an atomic add a pair and
  // sums in no fixed order (reruns agree to rounding only). visc keeps the largest viscous rate of the pairs a
  // particle evaluates: the step's limit reads only the largest over all particles, which is every pair's either way.
  RateSum<R>* sums = nullptr;

  // The pass the pointers set call for (the tests; the engine launches InteractPass).
  PFLOW_HOSTDEVICE void operator()(Index a) const {
    if (markMasks) run<RatePass::kMark>(a);
    else if (masks) run<RatePass::kMasks>(a);
    else run<RatePass::kWalk>(a);
  }

  template <RatePass P, bool kOnce = false>
  PFLOW_HOSTDEVICE void run(Index a) const {
    static_assert(!kOnce || P == RatePass::kWalk || P == RatePass::kTwoPhase, "the pairs once walk (no masks)");
    const RateRow<R> ra = row[a];
    const bool fluidA = !boundaryTag(ra.tag);
    if (!fluidA && ((wet && !wet[a]) || (skipBoundary && !kOnce))) {  // no pair to evaluate, none to receive (or not used)
      if constexpr (kOnce) {  // FinishRates writes its zero rates
        visc[a] = R(0);
        return;
      }
      acc[a] = Vec3<R>{R(0), R(0), R(0)};
      drho[a] = R(0);
      visc[a] = R(0);
      if constexpr (P == RatePass::kMark) markRows[a] = 0;
      return;
    }
    const RateState<R> sa = state[a];
    const RatePm<R> qa = pm[a];
    const PairSide<R> sideA{sa.rho, qa.pOverRho2, kOnce ? qa.m : R(0), kOnce ? qa.mOverRho : R(0)};
    const R cut2 = kernel.support() * kernel.support();
    const R cs = R(grid.cellSize);
    const std::int32_t cxA = cellXOfTag(ra.tag);
    Vec3<R> sumAcc{R(0), R(0), R(0)};
    R sumDrho = R(0), maxVisc = R(0);
    // b listed in a cell of the row being walked (dy, dz cells from a's): x_a - x_b from the offsets.
    R yRow = R(0), zRow = R(0);
    // b listed in a cell of the row being walked: its separation from a, and whether it is a neighbour.
    auto separation = [&](const RateRow<R>& rb) {
      return Vec3<R>{R(cxA - cellXOfTag(rb.tag)) * cs + (ra.x - rb.x), yRow - rb.y, zRow - rb.z};
    };
    auto isNeighbour = [&](Index b, const RateRow<R>& rb) {
      if (!fluidA && boundaryTag(rb.tag)) return false;  // walls: fluid neighbours only
      return norm2(separation(rb)) < cut2 && b != a;
    };
    auto add = [&](Index b, const RateRow<R>& rb) {
      const Vec3<R> d = separation(rb);
      const R r2 = norm2(d);
      const RateState<R> sb = state[b];
      const RatePm<R> qb = pm[b];
      [[maybe_unused]] PairReaction<R> toB;
      const PairRates<R> out = pairRates<kOnce>(params, d, sa.v - sb.v, r2, kernel.f(sqrtFast(r2)), sideA,
                                                PairSide<R>{sb.rho, qb.pOverRho2, qb.m, qb.mOverRho}, params.c0, params.c0,
                                                fluidA && !boundaryTag(rb.tag), &toB);
      if constexpr (kOnce) addRateSum(sums + b, toB.acceleration, toB.densityRate);
      sumAcc += out.acceleration;
      sumDrho += out.densityRate;
      maxVisc = out.viscousRate > maxVisc ? out.viscousRate : maxVisc;
    };
    int cx, cy, cz;
    grid.coords(home[a], cx, cy, cz);
    if constexpr (P == RatePass::kMasks) {
      // One flat loop over the marked candidates, row by row and piece by piece, so that a warp's lanes evaluate
      // their pairs together (nested loops over rows, pieces and bits make the warp wait at every level through
      // the lane with the most bits there). The pieces past the masks of an overfull row are tested as the walk's.
      const std::uint64_t used = maskRows[a];
      std::uint32_t rowsLeft = std::uint32_t(used), bits = 0;
      int code = 0, piece = kMaskPieces;
      Index base = 0, end = 0;
      for (;;) {
        while (bits == 0) {
          ++piece;
          if (piece >= kMaskPieces && base + Index(32 * piece) >= end) {  // the next row with marks
            if (rowsLeft == 0) break;
            code = lowestBit(rowsLeft);  // (dz + 2) * 5 + dy + 2: the walk's order
            rowsLeft &= rowsLeft - 1;
            const int dz = code / 5 - 2, dy = code % 5 - 2;
            zRow = ra.z - R(dz) * cs;  // the walk's row offsets, rounded the same way
            yRow = ra.y - R(dy) * cs;
            base = maskRowBase(grid, cellStart, cx, cy + dy, cz + dz);
            end = (used >> (32 + code)) & 1u ? maskRowEnd(grid, cellStart, cx, cy + dy, cz + dz) : Index(0);
            piece = 0;
          }
          if (piece < kMaskPieces) {
            bits = masks[maskLayout.at(a, std::uint32_t(code * kMaskPieces + piece))];
          } else {
            const Index lo = base + Index(32 * piece);
            const int len = end - lo < 32 ? int(end - lo) : 32;
            for (int j = 0; j < len; ++j) bits |= std::uint32_t(isNeighbour(lo + j, row[lo + j])) << j;
          }
        }
        if (bits == 0) break;
        const Index b = base + Index(32 * piece + lowestBit(bits));
        bits &= bits - 1;
        const RateRow<R> rb = row[b];
        if (norm2(separation(rb)) < cut2) add(b, rb);
      }
      acc[a] = fluidA ? sumAcc + gravity : Vec3<R>{R(0), R(0), R(0)};
      drho[a] = sumDrho;
      visc[a] = maxVisc;
      return;
    }
    const int r = grid.reach;
    const bool prune = margin >= R(0);
    constexpr bool mark = P == RatePass::kMark;
    const R reach2 = mark ? markCut2 : cut2;  // the cells walked: within the support (plus the skin when marking)
    std::uint64_t used = 0;                   // marking: rows with marks, rows overfull
    // kTwoPhase: the pieces with neighbours so far (their first candidate, hit bits, row code), added in one loop.
    [[maybe_unused]] Index wordBase[P == RatePass::kTwoPhase ? kTwoPhaseWords : 1];
    [[maybe_unused]] std::uint32_t wordBits[P == RatePass::kTwoPhase ? kTwoPhaseWords : 1];
    [[maybe_unused]] std::uint8_t wordRow[P == RatePass::kTwoPhase ? kTwoPhaseWords : 1];
    [[maybe_unused]] int words = 0;
    [[maybe_unused]] auto addBuffered = [&] {
      std::uint32_t bits = 0;
      Index base = 0;
      int w = 0, code = -1;
      for (;;) {
        while (bits == 0 && w < words) {
          bits = wordBits[w];
          base = wordBase[w];
          if (int(wordRow[w]) != code) {  // the row's offsets, rounded as the walk rounds them
            code = wordRow[w];
            zRow = ra.z - R(code / 5 - 2) * cs;
            yRow = ra.y - R(code % 5 - 2) * cs;
          }
          ++w;
        }
        if (bits == 0) break;
        const Index b = base + Index(lowestBit(bits));
        bits &= bits - 1;
        add(b, row[b]);
      }
      words = 0;
    };
    for (int z = kOnce ? cz : cz > r ? cz - r : 0; z <= (cz + r < grid.nz ? cz + r : grid.nz - 1); ++z) {
      const R gz = prune ? walkGap(ra.z, z - cz, cs, margin, z == 0, z == grid.nz - 1) : R(0);
      if (gz * gz >= reach2) continue;
      zRow = ra.z - R(z - cz) * cs;
      for (int y = kOnce && z == cz ? cy : cy > r ? cy - r : 0; y <= (cy + r < grid.ny ? cy + r : grid.ny - 1); ++y) {
        const R gy = prune ? walkGap(ra.y, y - cy, cs, margin, y == 0, y == grid.ny - 1) : R(0);
        const R g2 = gz * gz + gy * gy;
        if (g2 >= reach2) continue;
        yRow = ra.y - R(y - cy) * cs;
        // The row's cells within reach along x (a convex set: trimmed from both ends).
        int x0 = cx > r ? cx - r : 0, x1 = cx + r < grid.nx ? cx + r : grid.nx - 1;
        if (prune) {
          while (x0 < cx && [&] { const R g = walkGap(ra.x, x0 - cx, cs, margin, x0 == 0, false); return g2 + g * g >= reach2; }()) ++x0;
          while (x1 > cx && [&] { const R g = walkGap(ra.x, x1 - cx, cs, margin, false, x1 == grid.nx - 1); return g2 + g * g >= reach2; }()) --x1;
        }
        const std::uint32_t c0 = grid.index(x0, y, z), c1 = grid.index(x1, y, z);
        if (!kOnce && ghostCellStart) {  // merged by id, cell by cell
          for (std::uint32_t c = c0; c <= c1; ++c)
            forCellMergedById(c, cellStart, ghostCellStart, ghostItems, ghostBase, gid, [&](Index b) {
              const RateRow<R> rb = row[b];
              if (isNeighbour(b, rb)) add(b, rb);
            });
          continue;
        }
        // The row's range in pieces of 32 candidates: first which of them are neighbours (one bit each), then the
        // pair terms of those, in the same order. A warp's lanes evaluate pairs together instead of each lane
        // waiting through the others' pairs while its own candidate is not a neighbour (docs/sph.md, "Performance").
        Index from = cellStart[c0];
        const Index end = cellStart[c1 + 1];
        if (kOnce && z == cz && y == cy) from = a + 1;  // a's own row: the particles after it (x0 <= cx: before a)
        if constexpr (P == RatePass::kTwoPhase) {
          const int code = (z - cz + 2) * 5 + (y - cy + 2);
          for (Index piece = from; piece < end; piece += 32) {
            const int len = end - piece < 32 ? int(end - piece) : 32;
            std::uint32_t hits = 0;
            for (int j = 0; j < len; ++j) hits |= std::uint32_t(isNeighbour(piece + j, row[piece + j])) << j;
            if (hits == 0) continue;
            if (words == kTwoPhaseWords) {
              const R y0 = yRow, z0 = zRow;
              addBuffered();
              yRow = y0, zRow = z0;
            }
            wordBase[words] = piece;
            wordBits[words] = hits;
            wordRow[words] = std::uint8_t(code);
            ++words;
          }
          continue;
        }
        if constexpr (!mark) {
          for (Index piece = from; piece < end; piece += 32) {
            const int len = end - piece < 32 ? int(end - piece) : 32;
            std::uint32_t hits = 0;
            for (int j = 0; j < len; ++j) hits |= std::uint32_t(isNeighbour(piece + j, row[piece + j])) << j;
            for (; hits != 0; hits &= hits - 1) {
              const Index b = piece + Index(lowestBit(hits));
              add(b, row[b]);
            }
          }
          continue;
        }
        // Marking: the pieces counted from the row's first cell (the masks' pieces), each candidate tested against
        // both radii; the masks of the row's first kMaskPieces pieces written, zero where nothing was walked.
        const Index base = maskRowBase(grid, cellStart, cx, y, z);
        const int code = (z - cz + 2) * 5 + (y - cy + 2);
        std::uint32_t* slots = markMasks + maskLayout.at(a, std::uint32_t(code * kMaskPieces));
        const std::size_t stride = maskLayout.at(0, 1);
        std::uint32_t any = 0;
        Index k = (from - base) / 32;  // the first piece walked: those before it have no marks
        for (Index q = 0; q < k && q < Index(kMaskPieces); ++q) slots[q * stride] = 0;
        for (Index piece = base + k * 32; piece < end; piece += 32, ++k) {
          const int len = end - piece < 32 ? int(end - piece) : 32;
          std::uint32_t hits = 0, marks = 0;
          for (int j = 0; j < len; ++j) {
            const Index b = piece + Index(j);
            const RateRow<R> rb = row[b];
            const bool candidate = b >= from && b != a && (fluidA || !boundaryTag(rb.tag));  // walls: fluid neighbours only
            const R r2 = norm2(separation(rb));
            marks |= std::uint32_t(candidate && r2 < markCut2) << j;
            hits |= std::uint32_t(candidate && r2 < cut2) << j;
          }
          if (k < Index(kMaskPieces)) {
            slots[k * stride] = marks;
            any |= marks;
          }
          for (; hits != 0; hits &= hits - 1) {
            const Index b = piece + Index(lowestBit(hits));
            add(b, row[b]);
          }
        }
        for (; k < Index(kMaskPieces); ++k) slots[k * stride] = 0;
        const bool overfull = end > base + Index(32 * kMaskPieces);
        if (any != 0 || overfull) used |= std::uint64_t(1) << code;
        if (overfull) used |= std::uint64_t(1) << (32 + code);
      }
    }
    if constexpr (mark) markRows[a] = used;
    if constexpr (P == RatePass::kTwoPhase) addBuffered();
    if constexpr (kOnce) {
      visc[a] = maxVisc;
      addRateSum(sums + a, sumAcc, sumDrho);
      return;
    }
    acc[a] = fluidA ? sumAcc + gravity : Vec3<R>{R(0), R(0), R(0)};
    drho[a] = sumDrho;
    visc[a] = maxVisc;
  }
};

// One pass of Interact as a kernel of its own (kOnce: the pairs once).
template <class R, RatePass P, bool kOnce = false>
struct InteractPass {
  static constexpr bool kVariableCost = true;
  // The marking walk spills under the cap (96 bytes in float) and runs once a sort: uncapped.
  static constexpr int kMaxRegisters = P != RatePass::kMark ? Interact<R>::kMaxRegisters : 0;
  Interact<R> k;
  PFLOW_HOSTDEVICE void operator()(Index a) const { k.template run<P, kOnce>(a); }
};

// After the pairs once: each particle's sums into its rates (gravity added to the fluid's acceleration, a boundary
// particle's zero), and the sums zeroed for the next pass.
template <class R>
struct FinishRates {
  RateSum<R>* sums;
  const std::int32_t* kind;
  Vec3<R> gravity;
  Vec3<R>* acc;
  R* drho;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const RateSum<R> s = sums[i];
    acc[i] = kind[i] == kFluid ? s.a + gravity : Vec3<R>{R(0), R(0), R(0)};
    drho[i] = s.drho;
    sums[i] = RateSum<R>{{R(0), R(0), R(0)}, R(0)};
  }
};

// The field table's arrays of a rates pass, for the passes that read it directly (MirrorImages).
template <class R>
struct RateFields {
  CellGrid grid;
  const Index* cellStart;
  const Vec3d* home;
  const Vec3d* pos;
  const Vec3<R>* vel;
  const R* rho;
  const R* p;
  const R* mass;
  const std::int32_t* kind;
  const Index* ghostCellStart = nullptr;
  const Index* ghostItems = nullptr;
  Index ghostBase = 0;
  const Gid* gid = nullptr;

  // Every owned row and ghost listed in the cells within reach of a's (in global-id order when gid is set).
  template <class F>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void forCandidates(Index a, F&& consider) const {
    grid.forNeighbourCells(home[a], [&](std::uint32_t c) {
      if (ghostCellStart && gid) {  // merged by id
        forCellMergedById(c, cellStart, ghostCellStart, ghostItems, ghostBase, gid, consider);
        return;
      }
      for (Index b = cellStart[c]; b < cellStart[c + 1]; ++b) consider(b);
      if (ghostCellStart)
        for (Index k = ghostCellStart[c]; k < ghostCellStart[c + 1]; ++k) consider(ghostBase + ghostItems[k]);
    });
  }
};

// Mirror walls (SphPhysics.h, MirrorWalls): after Interact, each particle within the kernel's support of a mirror
// wall adds the terms of the images of its fluid neighbours near the same walls. A pass of its own, over the
// particles near a wall only, so the pair loop of every other particle stays as lean as without mirrors.
template <class R>
struct MirrorImages {
  static constexpr bool kVariableCost = true;
  Interact<R> k;        // the parameters, outputs and wet flags of the rates pass just run
  RateFields<R> f;      // its arrays, ghosts and order
  MirrorWalls mirror;

  PFLOW_HOSTDEVICE void operator()(Index a) const {
    const Vec3d xa = f.pos[a];
    // An image reaches a only through a wall a is near itself (it is at least as far as a's distance to the
    // wall plus b's).
    const int nearA = mirror.near(xa);
    if (!nearA) return;
    const bool fluidA = f.kind[a] == kFluid;
    if (!fluidA && ((k.wet && !k.wet[a]) || k.skipBoundary)) return;
    const Vec3<R> va = f.vel[a];
    const R rhoA = f.rho[a], pA = f.p[a];
    const double cut2 = double(k.kernel.support()) * double(k.kernel.support());
    Vec3<R> sumAcc{R(0), R(0), R(0)};
    R sumDrho = R(0), maxVisc = k.visc[a];
    f.forCandidates(a, [&](Index b) {
      if (f.kind[b] != kFluid) return;
      const int shared = nearA & mirror.near(f.pos[b]);  // walls both are near
      // Every non-empty subset of those walls: one image per subset.
      for (int m = shared; m != 0; m = (m - 1) & shared) {
        const Vec3d xi = mirror.reflect(f.pos[b], m);
        const Vec3d d = xa - xi;
        const double r2 = norm2(d);
        if (r2 >= cut2) continue;
        const R r = R(std::sqrt(r2));
        const R rhoB = f.rho[b];
        const R pI = f.p[b] + rhoB * dot(k.gravity, vcast<R>(xi - f.pos[b]));  // hydrostatic across the wall
        const R fab = k.kernel.f(r);
        // Continuity sees the wall as impermeable only (the free-slip image: no tangential divergence at the
        // wall); the momentum's viscous terms see the wall's condition (no-slip: the reversed velocity).
        const PairRates<R> slip = pairRates(k.params, vcast<R>(d), va - mirror.imageVelocity(f.vel[b], m, false), R(r2), fab, rhoA, rhoB,
                                            pA, pI, f.mass[b], k.params.c0, k.params.c0, false);
        sumDrho += slip.densityRate;
        const PairRates<R> wall = mirror.noSlip ? pairRates(k.params, vcast<R>(d), va - mirror.imageVelocity(f.vel[b], m, true), R(r2), fab,
                                                            rhoA, rhoB, pA, pI, f.mass[b], k.params.c0, k.params.c0, false)
                                                : slip;
        sumAcc += wall.acceleration;
        maxVisc = wall.viscousRate > maxVisc ? wall.viscousRate : maxVisc;
      }
    });
    if (fluidA) k.acc[a] += sumAcc;
    k.drho[a] += sumDrho;
    k.visc[a] = maxVisc;
  }
};

// wet[i] = 1 for a fluid particle, and for a boundary particle with a fluid particle (owned or ghost) listed in the
// cells within reach of its own: until the next sort, only those can have a fluid neighbour within 2h (no particle moves half the skin).
struct MarkWet {
  CellGrid grid;
  const Index* cellStart;
  const Vec3d* home;
  const std::int32_t* kind;
  const Index* ghostCellStart = nullptr;  // distributed runs
  const Index* ghostItems = nullptr;
  Index ghostBase = 0;
  std::uint8_t* wet = nullptr;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    if (kind[i] == kFluid) {
      wet[i] = 1;
      return;
    }
    bool any = false;
    grid.forNeighbourCells(home[i], [&](std::uint32_t c) {
      for (Index b = cellStart[c]; b < cellStart[c + 1] && !any; ++b) any = kind[b] == kFluid;
      if (ghostCellStart)
        for (Index k = ghostCellStart[c]; k < ghostCellStart[c + 1] && !any; ++k) any = kind[ghostBase + ghostItems[k]] == kFluid;
    });
    wet[i] = any ? 1 : 0;
  }
};

// Canonical order: the entries [cellStart[c], cellStart[c + 1]) of `items` (rows, or ghosts relative to `base`)
// reordered by the global id of the row they name (insertion sort: cells hold tens of particles).
struct SortCellByGid {
  const Index* cellStart;
  Index* items;
  const Gid* gid;
  Index base;
  PFLOW_HOSTDEVICE void operator()(Index c) const {
    for (Index e = cellStart[c] + 1; e < cellStart[c + 1]; ++e) {
      const Index item = items[e];
      const Gid g = gid[base + item];
      Index k = e;
      for (; k > cellStart[c] && gid[base + items[k - 1]] > g; --k) items[k] = items[k - 1];
      items[k] = item;
    }
  }
};

// Distributed runs: flag[i] = 1 when a ghost lies in a cell within reach of owned particle i's (its rates
// need the refreshed halo), 0 when they can be computed while the halo travels.
struct MarkNearGhosts {
  CellGrid grid;
  const Vec3d* pos;
  const Index* ghostCellStart;
  std::uint32_t* flag;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    std::uint32_t near = 0;
    grid.forNeighbourCells(pos[i], [&](std::uint32_t c) { near |= ghostCellStart[c] < ghostCellStart[c + 1] ? 1u : 0u; });
    flag[i] = near;
  }
};

// Pressure from density (the start, and rows that arrive without it).
template <class R>
struct EquationOfState {
  const R* rho;
  R* p;
  Tait<R> eos;
  PFLOW_HOSTDEVICE void operator()(Index i) const { p[i] = eos.pressure(rho[i]); }
};

// Kernel sums of the fluid at arbitrary points (probes and gauges): fraction[k] = sum_b V_b W(x_k - x_b) (the
// fluid's share of the kernel there: 1 inside the fluid, about 1/2 on a wall or the free surface, 0 in air) and
// pressure[k] = sum_b V_b p_b W, over this engine's owned fluid particles b (V_b = m_b/rho_b): sums, so that
// ranks add theirs; the Shepard pressure is pressure / fraction. In two passes, so that a few points still make
// many items: SampleRows takes one row of a point's neighbouring cells (the cells along x at one y and z, whose
// particles are contiguous in the cell order), item = point * rows + row, rows = (2 reach + 1)^2; SampleSum adds a
// point's rows in their order (the same bits on both executors).
template <class R>
struct SampleRows {
  CellGrid grid;
  const Index* cellStart;
  const Vec3d* pos;
  const R* rho;
  const R* p;
  const R* mass;
  const std::int32_t* kind;
  Kernel<R> kernel;
  const Vec3d* points;
  int rows;
  double* partial;  // 2 a row: the fraction's and the pressure's sums
  PFLOW_HOSTDEVICE void operator()(Index item) const {
    const Index k = item / Index(rows);
    const int r = int(item - k * Index(rows)), side = 2 * grid.reach + 1;
    const Vec3d x = points[k];
    int cx, cy, cz;
    grid.coords(x, cx, cy, cz);
    const int y = cy + r % side - grid.reach, z = cz + r / side - grid.reach;
    double sw = 0, swp = 0;
    if (y >= 0 && y < grid.ny && z >= 0 && z < grid.nz) {
      const int x0 = cx > grid.reach ? cx - grid.reach : 0, x1 = cx + grid.reach < grid.nx ? cx + grid.reach : grid.nx - 1;
      const double cut2 = double(kernel.support()) * double(kernel.support());
      for (Index b = cellStart[grid.index(x0, y, z)]; b < cellStart[grid.index(x1, y, z) + 1]; ++b) {
        if (kind[b] != kFluid) continue;
        const double r2 = norm2(x - pos[b]);
        if (r2 >= cut2) continue;
        const double w = double(kernel.w(R(std::sqrt(r2)))) * double(mass[b]) / double(rho[b]);
        sw += w;
        swp += w * double(p[b]);
      }
    }
    partial[2 * item] = sw;
    partial[2 * item + 1] = swp;
  }
};

struct SampleSum {
  const double* partial;
  int rows;
  double* fraction;
  double* pressure;
  PFLOW_HOSTDEVICE void operator()(Index k) const {
    double sw = 0, swp = 0;
    for (int r = 0; r < rows; ++r) {
      sw += partial[2 * (k * Index(rows) + r)];
      swp += partial[2 * (k * Index(rows) + r) + 1];
    }
    fraction[k] = sw;
    pressure[k] = swp;
  }
};

// How far a fluid particle reaches along `direction`, from `base` (>= 0 inside the grid; boundary: 0).
struct FluidReach {
  const Vec3d* pos;
  const std::int32_t* kind;
  Vec3d direction, base;
  PFLOW_HOSTDEVICE double operator()(Index i) const {
    if (kind[i] != kFluid) return 0.0;
    const double d = dot(pos[i] - base, direction);
    return d > 0.0 ? d : 0.0;
  }
};

}  // namespace pflow::compute::sph::kernels
