// The GPU's pairs once (ComputeForces' kHalf; EngineImpl::m_halfPairs): each pair is evaluated by its lower index,
// whose row lists only its candidates above it (BuildNeighbors::upperOnly), which adds the reaction to its partner by atomic adds. What that loop needs around it: the sums zeroed
// before it, and at each rebuild every history moved to the pair's owner (indices change with each sort).
#pragma once
#include <cstdint>

#include "compute/core/Atomics.h"
#include "compute/core/Conditions.h"
#include "compute/core/Types.h"
#include "compute/core/VectorMath.h"
#include "compute/dem/contact/ForceKernel.h"
#include "compute/dem/contact/HistoryPool.h"
#include "compute/dem/contact/PairsOnceKernels.h"

namespace pflow::compute::kernels {

// The sums to zero before the pairs-once loop: force and torque, or the 16-byte rows that stand for them (float).
template <class R>
struct ZeroSums {
  Vec3<R>* force;
  Vec3<R>* torque;
  Sum4* sums = nullptr;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    if (sums) {
      sums[2 * std::size_t(i)] = Sum4{0, 0, 0, 0};
      sums[2 * std::size_t(i) + 1] = Sum4{0, 0, 0, 0};
      return;
    }
    force[i] = zero3<R>();
    torque[i] = zero3<R>();
  }
};
// After the float pairs-once loop: the 16-byte sum rows into force and torque.
template <class R>
struct FinishSums {
  Vec3<R>* force;
  Vec3<R>* torque;
  const Sum4* sums;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const Sum4 f = sums[2 * std::size_t(i)], t = sums[2 * std::size_t(i) + 1];
    force[i] = Vec3<R>{R(f.x), R(f.y), R(f.z)};
    torque[i] = Vec3<R>{R(t.x), R(t.y), R(t.z)};
  }
};

// After a rebuild (and ResolvePool), per particle i: for each candidate j (all above i: the pairs i owns), the history
// j keeps inline for the pair moves to i (negated: the displacement seen from the other side), into a free inline slot
// or, with the slots at their cap, the history pool, unless i holds one already; j's copy is freed either way (a run
// that evaluated pairs from both sides left one on each side). Only the owner ever claims a slot for a pair, so j's
// copy is read by nobody else; the fence orders the read of its displacement before the free that lets j claim the
// slot again. When the owner finds no room it raises the overflow flag; the host grows the slots or the pool and runs
// the pass again (what moved already is found in place).
template <class R>
struct PullHistoryHalf {
  static constexpr bool kVariableCost = true;
  using V = Vec3<R>;
  HistoryRows<R> rows;
  HistoryPool<R> pool;   // key null: no pool
  std::int32_t* pooled;  // [i]: i's contacts held in the pool
  Conditions* cond;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    const HistoryRows<R>& h = rows;
    const PartnerId gi = PartnerId(h.gid[i]);
    const std::uint32_t count = h.layout.count(i);
    int pooledHere = pool.key ? pooled[i] : 0;
    for (std::uint32_t e = 0; e < count; ++e) {
      const Index j = h.nbr[h.layout.at(i, e)];
      const int from = h.heldBy(j, gi);
      if (from < 0) continue;  // j holds nothing inline for this pair
      if (h.nbrSlot[h.layout.at(i, e)] < 0) {
        const V moved = -h.histLayout.at(h.histDisp, j)[from];
        const int to = ComputeForces<R>::claimSlot(h.histLayout.at(h.histPartner, i), h.slots, h.gid[j]);
        if (to >= 0) {
          h.histLayout.at(h.histDisp, i)[to] = moved;
          h.nbrSlot[h.layout.at(i, e)] = std::int8_t(to);
        } else {
          const std::int32_t entry = pool.key ? pool.insert(HistoryPool<R>::keyOf(gi, PartnerId(h.gid[j]))) : -1;
          if (entry < 0) {
            h.overflow(cond);
            continue;
          }
          pool.disp[entry] = moved;
          h.nbrSlot[h.layout.at(i, e)] = kPoolSlot;
          ++pooledHere;
        }
      }
#if defined(__CUDA_ARCH__)
      __threadfence();
#else
      __atomic_thread_fence(__ATOMIC_SEQ_CST);
#endif
      h.histLayout.at(h.histPartner, j)[from] = kNoPartner;
    }
    if (pool.key) pooled[i] = pooledHere;
  }
};

// After PullHistoryHalf: the slots of particle i that its row does not refer to are freed (its copies of pairs
// another owns were taken by their owners; what is left belongs to contacts that ended), as BuildNeighbors does
// for full rows.
struct ClearUnlistedSlots {
  const std::int8_t* nbrSlot;
  RowSlices layout;
  PartnerId* histPartner;
  SlotLayout histLayout;
  int slots;
  PFLOW_HOSTDEVICE void operator()(Index i) const {
    clearUnlistedSlots(histLayout.at(histPartner, i), slots, nbrSlot + layout.base(i), layout.stride(), layout.count(i));
  }
};

}  // namespace pflow::compute::kernels
