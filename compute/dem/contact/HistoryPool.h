// The tangential histories beyond a particle's inline slots (docs/performance.md, "History sized by the typical
// contact count"). Every particle carries `inline` slots (EngineSetup::inlineHistorySlots, 7 by default); the few
// with more contacts keep the rest here, in one open-addressing table keyed by the pair (the particle's gid, the
// partner's gid). A cell sort moves the inline slots only: the table is keyed by identities, not rows.
//
// - The force pass claims an entry when a contact starts and finds no inline slot (an atomic compare-and-swap on
//   an empty key: only particle i's thread ever inserts or erases i's keys, so no key is inserted twice), reads and
//   writes it while the contact lasts, and erases it (an erased mark, never empty again before the next rebuild, so
//   no probe sequence is cut) when it ends. Its candidate entry's slot byte says kPoolSlot.
// - Each particle counts its pooled contacts (the `history_pooled` field, 4 bytes: the reorder moves whole words), so that a rebuild looks for pooled
//   histories only in the rows of the particles that have some (ResolvePool): their candidates that touch now are
//   moved into a fresh table, and everything else (ended contacts, erased marks) is dropped.
// - A full table (more claims since the last rebuild than half its entries) raises kHistoryOverflow: the host
//   doubles it (RehashPool) and runs the store-only pass, as it grows inline slots, so no history is lost.
//
// Used where each pair is evaluated from both sides in one process (the GPU's pass, the CPU's with pairsOnce off);
// not with adhesion (a JKR contact outlives zero overlap, which ResolvePool's test would drop), distributed runs
// (migration carries inline slots only) or the CPU's pairs-once pass (its owner-side histories move between
// partners at each rebuild): those keep every slot inline, as before.
#pragma once
#include <cstdint>

#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/core/Types.h"
#include "compute/core/VectorMath.h"
#include "compute/neighbor/NeighborKernels.h"

namespace pflow::compute {

inline constexpr std::int8_t kPoolSlot = 127;  // a candidate's slot byte: its history is in the pool

template <class R>
struct HistoryPool {
  static constexpr std::uint64_t kEmpty = ~std::uint64_t(0);
  static constexpr std::uint64_t kErased = ~std::uint64_t(0) - 1;  // gid 2^32 - 1 is never a particle's
  std::uint64_t* key = nullptr;   // [capacity]; null: no pool (every slot inline)
  Vec3<R>* disp = nullptr;        // [capacity]
  std::uint32_t* claimed = nullptr;  // claims since the table was (re)built, live or erased since
  std::uint32_t capacity = 0;     // a power of two, at most 2^30
  std::uint32_t limit = 0;        // claims allowed: half the capacity, so a probe always meets an empty entry
  int shift = 64;                 // 64 - log2(capacity)

  PFLOW_HOSTDEVICE static std::uint64_t keyOf(PartnerId i, PartnerId j) { return (std::uint64_t(i) << 32) | j; }
  PFLOW_HOSTDEVICE std::uint32_t home(std::uint64_t k) const {
    return capacity == 1 ? 0 : std::uint32_t((k * 0x9E3779B97F4A7C15ull) >> shift);
  }
  // The entry holding k, or -1. Entries only go from empty to a key, and from a key to erased, until the next
  // rebuild: a key's probe sequence never meets an empty entry before it, whatever other threads insert.
  PFLOW_HOSTDEVICE std::int32_t find(std::uint64_t k) const {
    std::uint32_t p = home(k);
    for (std::uint32_t n = 0; n < capacity; ++n, p = (p + 1) & (capacity - 1)) {
      const std::uint64_t at = key[p];
      if (at == k) return std::int32_t(p);
      if (at == kEmpty) return -1;
    }
    return -1;
  }
  // Claims an empty entry for k (not in the table: its owner checked), or -1 when the table is full.
  PFLOW_HOSTDEVICE std::int32_t insert(std::uint64_t k) const {
    if (atomicAddU32(claimed, 1) >= limit) return -1;
    std::uint32_t p = home(k);
    for (std::uint32_t n = 0; n < capacity; ++n, p = (p + 1) & (capacity - 1))
      if (key[p] == kEmpty && atomicCasU64(&key[p], kEmpty, k)) return std::int32_t(p);
    return -1;
  }
};

namespace kernels {

// After BuildNeighbors, for the particles with pooled contacts: the candidates that touch now and whose history is
// in `from` get an entry in `to` (the same displacement) and the slot byte kPoolSlot; `pooled` is recounted. What
// is not carried over (contacts that ended, erased marks) is gone with `from`. A candidate that does not touch now
// would have its history cleared by the next force pass anyway (the rebuild's positions are that pass's).
template <class R>
struct ResolvePool {
  static constexpr bool kVariableCost = true;
  const Vec3d* pos;
  const R* radius;
  const Gid* gid;
  const Index* nbr;
  std::int8_t* nbrSlot;
  RowSlices layout;
  std::int32_t* pooled;
  HistoryPool<R> from, to;
  Conditions* cond;
  // The GPU's pairs once (ComputeForces' kHalf): a pair's owner, its lower index, changes with the rows' order, so
  // every particle looks, and a history its partner pooled as the pair's owner before is taken over, negated (the
  // displacement seen from the other side).
  bool half = false;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    if (pooled[i] == 0 && !half) return;
    const PartnerId gi = PartnerId(gid[i]);
    const double ri = double(radius[i]);
    int n = 0;
    const std::uint32_t count = layout.count(i);
    for (std::uint32_t e = 0; e < count; ++e) {
      const std::size_t at = layout.at(i, e);
      if (nbrSlot[at] >= 0) continue;  // inline
      const Index j = nbr[at];
      const double rs = ri + double(radius[j]);
      if (norm2(pos[j] - pos[i]) >= rs * rs) continue;
      const std::uint64_t k = HistoryPool<R>::keyOf(gi, PartnerId(gid[j]));
      std::int32_t old = from.find(k);
      const bool turned = old < 0 && half;
      if (turned) old = from.find(HistoryPool<R>::keyOf(PartnerId(gid[j]), gi));
      if (old < 0) continue;
      const std::int32_t now = to.insert(k);
      if (now < 0) {  // sized by the host for every live entry: cannot happen
        atomicOrU32(&cond->flags, kNeighborMismatch);
        continue;
      }
      to.disp[now] = turned ? -from.disp[old] : from.disp[old];
      nbrSlot[at] = kPoolSlot;
      ++n;
    }
    pooled[i] = n;
  }
};

// Every live entry of `from` into `to` (a larger table: the pool grew within a step; slot bytes say kPoolSlot and
// find the entry by key, so nothing else changes).
template <class R>
struct RehashPool {
  HistoryPool<R> from, to;
  Conditions* cond;
  PFLOW_HOSTDEVICE void operator()(Index p) const {
    const std::uint64_t k = from.key[p];
    if (k == HistoryPool<R>::kEmpty || k == HistoryPool<R>::kErased) return;
    const std::int32_t now = to.insert(k);
    if (now < 0) {
      atomicOrU32(&cond->flags, kNeighborMismatch);
      return;
    }
    to.disp[now] = from.disp[p];
  }
};

}  // namespace kernels
}  // namespace pflow::compute
