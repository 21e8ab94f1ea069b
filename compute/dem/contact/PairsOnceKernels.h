// The CPU executor's pairs once (EngineSetup::pairsOnce): each pair evaluated by one partner over slabs of cells
// (ComputePairsOnce, after OwnedFirst), and the histories moved to the pairs' owners at each rebuild (PullHistory;
// HistoryRows, which the GPU's pairs once shares: HalfPairs.h).
#pragma once
#include <cstdint>
#include <utility>
#include <vector>

#include "compute/dem/contact/ContactBatch.h"
#include "compute/dem/contact/ForceKernel.h"

namespace pflow::compute::kernels {
// The CPU executor's pair forces with each pair evaluated once, half the arithmetic of evaluating it from
// both sides: ComputeForces::row with kOnce, over the particles of one slab. Particle i owns its pair with
// candidate j when slab(i) < slab(j), or the same slab and i < j (OwnedFirst puts those candidates at the
// head of its row). The tangential displacement is kept by the owner alone, in its slots keyed by j's gid;
// when a rebuild hands a pair to the other partner, PullHistory moves it over.
// No two tasks write the same particle: slabs are one cell layer thick along one axis and a candidate
// lies in the same layer or the next, so an owner writes only its own slab and the next one. The slabs
// run in two colours (even ones, then odd ones), one slab per task, its particles in ascending order:
// the sums are the same whatever the number of threads. An even slab's task zeroes its own and the next
// slab's forces and torques first (only it writes into the next slab in that colour). Host only.
template <class R, bool kCohesion = false, bool kFixed = false>
struct ComputePairsOnce {
  ComputeForces<R, kCohesion, kFixed> pairs;
  const Index* slabStart;        // [numSlabs + 1]
  const Index* slabItems;        // particles by slab, ascending within each
  const std::uint32_t* owned;    // [particle]: how many candidates at the head of its row it owns (OwnedFirst)
  Index numSlabs;
  // The contact law a batch of contacts at a time, in SIMD lanes (ContactBatch.h; the same bits): not with adhesion,
  // nor in the store-only pass. EngineSetup::batchedContacts.
  bool batched = true;

  void operator()(Index slab) const {
    const ForceArgs<R>& a = pairs.a;
    if (!a.storeOnly && slab % 2 == 0)
      for (Index s = slab; s < slab + 2 && s < numSlabs; ++s)
        for (Index k = slabStart[s]; k < slabStart[s + 1]; ++k) {
          a.force[slabItems[k]] = zero3<R>();
          a.torque[slabItems[k]] = zero3<R>();
        }
    if constexpr (!kCohesion) {
      if (batched && !a.storeOnly) {
        const Index from = slabStart[slab], to = slabStart[slab + 1];
        if (!a.tangential) {
          if (a.rolling) batchedSlab<R, kFixed, false, true>(pairs, slabItems, from, to, owned);
          else batchedSlab<R, kFixed, false, false>(pairs, slabItems, from, to, owned);
        } else if (a.rolling) {
          batchedSlab<R, kFixed, true, true>(pairs, slabItems, from, to, owned);
        } else {
          batchedSlab<R, kFixed, true, false>(pairs, slabItems, from, to, owned);
        }
        return;
      }
    }
    for (Index k = slabStart[slab]; k < slabStart[slab + 1]; ++k) pairs.template dispatch<true>(slabItems[k], owned);
  }
};

// Before ComputePairsOnce: the candidates whose pair particle i owns (slab(i) < slab(j), or the same slab
// and i < j) moved to the head of its row, in their order, with their slots; owned[i] says how many.
struct OwnedFirst {
  static constexpr bool kVariableCost = true;  // work per particle varies (CpuExecutor::forEach)
  const std::uint32_t* slabOf;
  Index* nbr;
  std::int8_t* nbrSlot;  // null without history slots
  RowSlices layout;
  std::uint32_t* owned;
  void operator()(Index i) const {
    const std::uint32_t count = layout.count(i);
    thread_local std::vector<std::pair<Index, std::int8_t>> others;
    others.clear();
    const std::uint32_t si = slabOf[i];
    std::uint32_t w = 0;
    for (std::uint32_t e = 0; e < count; ++e) {
      const Index j = nbr[layout.at(i, e)];
      const std::int8_t slot = nbrSlot ? nbrSlot[layout.at(i, e)] : std::int8_t(-1);
      const std::uint32_t sj = slabOf[j];
      if (sj > si || (sj == si && j > i)) {
        nbr[layout.at(i, w)] = j;
        if (nbrSlot) nbrSlot[layout.at(i, w)] = slot;
        ++w;
      } else {
        others.emplace_back(j, slot);
      }
    }
    owned[i] = w;
    for (const auto& [j, slot] : others) {
      nbr[layout.at(i, w)] = j;
      if (nbrSlot) nbrSlot[layout.at(i, w)] = slot;
      ++w;
    }
  }
};

// The candidate rows and the history slots, as the passes that move histories between partners see them.
template <class R>
struct HistoryRows {
  const Index* nbr;
  std::int8_t* nbrSlot;
  RowSlices layout;
  PartnerId* histPartner;
  Vec3<R>* histDisp;
  SlotLayout histLayout;
  int slots;
  const Gid* gid;
  // The slot of particle j that holds partner g's history, or -1.
  PFLOW_HOSTDEVICE int heldBy(Index j, PartnerId g) const {
    const SlotRow<PartnerId> theirs = histLayout.at(histPartner, j);
    int from = -1;
    for (int s = 0; s < slots; ++s)
      if (theirs[s] == g) from = s;
    return from;
  }
  // An owner found no free slot: the host grows the slots by one and runs the pass again.
  PFLOW_HOSTDEVICE void overflow(Conditions* cond) const {
    atomicOrU32(&cond->flags, kHistoryOverflow);
    atomicMaxU32(&cond->neededHistory, std::uint32_t(slots) + 1);
  }
};

// After OwnedFirst, per slab in the two colours of ComputePairsOnce: a pair whose history its partner j
// holds (j owned it before this rebuild) moves into the owner's slots (negated: it is the displacement
// seen from the other side), and the slot of j is freed. Runs once at each rebuild; a pair keeps its
// owner until the next. When the owner has no free slot it raises the overflow flag; the host grows the
// slots and runs the pass again (what moved already is found in place).
template <class R>
struct PullHistory {
  const Index* slabStart;
  const Index* slabItems;
  const std::uint32_t* owned;
  HistoryRows<R> rows;
  Conditions* cond;
  void operator()(Index slab) const {
    const HistoryRows<R>& h = rows;
    for (Index k = slabStart[slab]; k < slabStart[slab + 1]; ++k) {
      const Index i = slabItems[k];
      const PartnerId gi = PartnerId(h.gid[i]);
      for (std::uint32_t e = 0; e < owned[i]; ++e) {
        if (h.nbrSlot[h.layout.at(i, e)] >= 0) continue;  // i holds it already (or the pair has none)
        const Index j = h.nbr[h.layout.at(i, e)];
        const int from = h.heldBy(j, gi);
        if (from < 0) continue;  // no history: not in contact
        const int to = ComputeForces<R>::claimSlot(h.histLayout.at(h.histPartner, i), h.slots, h.gid[j]);
        if (to < 0) {
          h.overflow(cond);
          continue;
        }
        h.histLayout.at(h.histDisp, i)[to] = -h.histLayout.at(h.histDisp, j)[from];
        h.histLayout.at(h.histPartner, j)[from] = kNoPartner;
        h.nbrSlot[h.layout.at(i, e)] = std::int8_t(to);
      }
    }
  }
};

}  // namespace pflow::compute::kernels
