// EngineImpl's pairs once, done after each rebuild's candidate lists. On the CPU (ComputePairsOnce): the particles by
// slab, each row's owned candidates first, the histories moved to the owners. On the GPU (ComputeForces' kHalf,
// PFLOW_GPU_HALF_PAIRS=1): every contact's history moved to the pair's owner, its lower index (indices change with
// each sort), into its inline slots or, those at their cap, the history pool. Included at the end of EngineImpl.h:
// member templates.
#pragma once

#include <algorithm>

#include "compute/dem/EngineImpl.h"

namespace pflow::compute {

// Runs `pass` (a history move) until no owner lacks room: one more inline slot a particle each time, or, with the
// slots at their cap (the GPU's pairs once), a pool twice as large.
template <class Exec, class R>
template <class Pass>
Status EngineImpl<Exec, R>::untilSlotsSuffice(Pass pass) {
  for (;;) {
    resetConditions();
    pass();
    const Conditions c = readConditions();
    if (!(c.flags & kHistoryOverflow)) return Status::ok();
    if (m_pool.active()) {
      if (!m_pool.grow(m_cond.as<Conditions>()))
        return Status(StatusCode::kResourceExhausted, "the contact-history pool reached 2^30 entries");
      continue;
    }
    const int grown = m_particles.contactSlots() + 1;
    if (grown > std::min(127, m_setup.maxContacts)) return slotOverflowError(m_setup.dt);
    m_particles.resizeSlots(Multiplicity::kContactSlots, m_pool.inlineSlots(grown));
    m_pool.enableAt(m_particles.contactSlots(), m_owned);
  }
}

template <class Exec, class R>
kernels::HistoryRows<R> EngineImpl<Exec, R>::historyRows() {
  return {m_nbr.as<Index>(), m_nbrSlot.as<std::int8_t>(), nbrLayout(), m_particles.template ptr<Field::HistoryPartner>(),
          m_particles.template ptr<Field::HistoryDisp>(), m_particles.layout(Multiplicity::kContactSlots),
          m_particles.contactSlots(), m_particles.template ptr<Field::Gid>()};
}

template <class Exec, class R>
Status EngineImpl<Exec, R>::pullHistoryToOwners() {
  if (!halfPairs() || !m_setup.model.tangential) return Status::ok();
  const Status st = untilSlotsSuffice([&] {
    m_exec.forEach(m_owned, kernels::PullHistoryHalf<R>{historyRows(), m_pool.active() ? m_pool.view() : HistoryPool<R>{},
                                                        m_particles.template ptr<Field::HistoryPooled>(),
                                                        m_cond.as<Conditions>()});
  });
  if (st.ok())
    m_exec.forEach(m_owned, kernels::ClearUnlistedSlots{m_nbrSlot.as<std::int8_t>(), nbrLayout(),
                                                        m_particles.template ptr<Field::HistoryPartner>(),
                                                        m_particles.layout(Multiplicity::kContactSlots),
                                                        m_particles.contactSlots()});
  return st;
}

template <class Exec, class R>
Status EngineImpl<Exec, R>::buildSlabs() {
  m_numSlabs = 0;
  if constexpr (Exec::kPairsOnce) {
    const CellGrid& g = m_setup.grid;
    if (!m_setup.pairsOnce || m_halfPairs || m_setup.canonicalOrder || m_n != m_owned || m_owned == 0) return Status::ok();
    // The particles' extent in cell layers along each axis (a bed fills the bottom of a tall domain).
    const Vec3d* x = m_particles.template ptr<Field::Position>();
    double span[3];
    for (int k = 0; k < 3; ++k) {
      const double hi = m_exec.maxOf(m_owned, [x, k](Index i) { return (&x[i].x)[k]; });
      const double lo = -m_exec.maxOf(m_owned, [x, k](Index i) { return -(&x[i].x)[k]; });
      span[k] = (hi - lo) * g.invCellSize;
    }
    // Not the longest axis: slabs across the cells' fastest index (x) scatter a slab's particles in memory; on the
    // 10^6 bed (0.5 x 0.1 m: five times as many x-layers) they ran the forces phase 2.4 times slower (bench/RESULTS.md).
    int axis = span[2] >= span[1] ? 2 : 1;
    if (span[axis] < 4 && span[0] >= 4) axis = 0;
    const Index layers = Index(axis == 0 ? g.nx : axis == 1 ? g.ny : g.nz);
    if (layers < 2) return Status::ok();  // one slab: every pair would be evaluated by one task
    if (m_slabOf.bytes() < m_owned * sizeof(std::uint32_t)) {
      m_slabOf.resize(m_owned * sizeof(std::uint32_t));
      m_slabItems.resize(m_owned * sizeof(Index));
      m_owned1.resize(m_owned * sizeof(std::uint32_t));
    }
    if (m_slabStart.bytes() < (layers + 1) * sizeof(Index)) m_slabStart.resize((layers + 1) * sizeof(Index));
    m_exec.forEach(m_owned, kernels::SlabKey{g, m_particles.template ptr<Field::Position>(), axis, m_slabOf.as<std::uint32_t>()});
    m_exec.sortByKey(m_slabOf.as<std::uint32_t>(), m_owned, std::uint32_t(layers), m_slabItems.as<Index>(),
                     m_slabStart.as<Index>());
    const bool slots = m_setup.model.tangential;
    m_exec.forEach(m_owned, kernels::OwnedFirst{m_slabOf.as<std::uint32_t>(), m_nbr.as<Index>(),
                                                slots ? m_nbrSlot.as<std::int8_t>() : nullptr, nbrLayout(),
                                                m_owned1.as<std::uint32_t>()});
    if (slots) {  // histories of pairs that changed owner move to the new owner
      const Status st = untilSlotsSuffice([&] {
        m_exec.forEachTwoColours(layers, kernels::PullHistory<R>{m_slabStart.as<Index>(), m_slabItems.as<Index>(),
                                                                 m_owned1.as<std::uint32_t>(), historyRows(),
                                                                 m_cond.as<Conditions>()});
      });
      if (!st.ok()) return st;
    }
    m_numSlabs = layers;
  }
  return Status::ok();
}

}  // namespace pflow::compute
