// The engine's side of the history pool (compute/dem/contact/HistoryPool.h): two tables, the live one and the one a
// rebuild fills, each `capacity` keys and displacements, plus a claim counter each. Grown by doubling when the force
// pass finds the live table full; copied to the host whole for the in-memory checkpoint of reduce_dt, and as its
// live entries for checkpoint files (which merge them into the inline slots: EngineImpl::stateArrays).
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <utility>
#include <vector>

#include "compute/core/Memory.h"
#include "compute/dem/Engine.h"
#include "compute/dem/contact/HistoryPool.h"

namespace pflow::compute {

template <class Exec, class R>
class HistoryPoolStore {
 public:
  using Pool = HistoryPool<R>;
  struct Entry {
    PartnerId owner, partner;
    Vec3<R> disp;
  };
  struct HostCopy {  // the live table as it is (the in-memory checkpoint)
    std::uint32_t capacity = 0, claimed = 0;
    std::vector<std::uint64_t> key;
    std::vector<Vec3<R>> disp;
  };

  HistoryPoolStore(Exec& exec, MemorySpace& mem) : m_exec(exec), m_mem(mem) {}

  bool active() const { return m_capacity > 0; }
  Pool view() const { return viewOf(m_live, m_capacity); }

  // Whether this run may pool, and its inline cap: the setup's (PFLOW_INLINE_SLOTS overrides a nonzero one), where
  // each pair is evaluated from both sides in one process (not by a pairs-once executor), with friction, without
  // adhesion.
  // The GPU's pairs once (`half`: each particle keeps the histories of the pairs it owns, about half its contacts)
  // pools too, beyond half the cap.
  void configure(const EngineSetup& s, bool pairsOnceExecutor, bool half = false) {
    int cap = s.inlineHistorySlots;
    if (half) cap = (cap + 1) / 2;
    if (const char* env = std::getenv("PFLOW_INLINE_SLOTS"); env && cap > 0) cap = std::clamp(std::atoi(env), 0, 126);
    const bool allowed = s.model.tangential && !s.model.cohesion && !s.canonicalOrder && !(pairsOnceExecutor && s.pairsOnce);
    m_cap = allowed ? cap : 0;
  }
  // The inline slots to carry for `wanted`: no more than the cap where a pool may take the rest.
  int inlineSlots(int wanted) const { return m_cap > 0 ? std::min(wanted, m_cap) : wanted; }
  // Once the inline slots reach the cap: an empty table, sized for a 64th of the particles (at least 256 entries).
  void enableAt(int slots, Index particles) {
    if (m_cap == 0 || slots < m_cap || active()) return;
    std::uint32_t c = 256;
    while (c < particles / 64) c *= 2;
    allocate(c);
    clear(m_live);
  }

  // At a rebuild: the touching candidates' pooled histories into the other table, which becomes the live one.
  template <class Resolve>
  void resolve(Resolve r, Index owned) {
    if (!active()) return;
    const int next = 1 - m_live;
    clear(next);
    r.from = viewOf(m_live, m_capacity);
    r.to = viewOf(next, m_capacity);
    m_exec.forEach(owned, r);
    m_live = next;
  }

  // The live table full: both tables doubled, the live entries rehashed into the larger one. False at 2^30 entries
  // (find and insert index the table with 32-bit integers).
  bool grow(Conditions* cond) {
    if (m_capacity >= (std::uint32_t(1) << 30)) return false;
    const int next = 1 - m_live;
    const std::uint32_t bigger = m_capacity * 2;
    sizeTable(next, bigger);
    const Pool to = viewOf(next, bigger);
    clearAt(to);
    m_exec.forEach(Index(m_capacity), kernels::RehashPool<R>{viewOf(m_live, m_capacity), to, cond});
    m_live = next;
    sizeTable(1 - m_live, bigger);  // the other table, for the next rebuild (its contents do not matter)
    m_capacity = bigger;
    return true;
  }

  // Live entries (owner gid, partner gid, displacement), for checkpoint files.
  std::vector<Entry> entries() const {
    std::vector<Entry> out;
    if (!active()) return out;
    const HostCopy h = copy();
    for (std::uint32_t p = 0; p < h.capacity; ++p)
      if (h.key[p] != Pool::kEmpty && h.key[p] != Pool::kErased)
        out.push_back({PartnerId(h.key[p] >> 32), PartnerId(h.key[p] & 0xFFFFFFFFu), h.disp[p]});
    return out;
  }

  HostCopy copy() const {
    HostCopy h;
    if (!active()) return h;
    h.capacity = m_capacity;
    h.key.resize(m_capacity);
    h.disp.resize(m_capacity);
    m_mem.copyToHost(h.key.data(), m_key[m_live].data(), m_capacity * sizeof(std::uint64_t));
    m_mem.copyToHost(h.disp.data(), m_disp[m_live].data(), m_capacity * sizeof(Vec3<R>));
    m_mem.copyToHost(&h.claimed, m_claimed.template as<std::uint32_t>() + m_live, sizeof h.claimed);
    return h;
  }
  void restore(const HostCopy& h) {
    if (h.capacity == 0) {
      if (active()) clear(m_live);
      return;
    }
    if (h.capacity != m_capacity) allocate(h.capacity);
    m_mem.copyFromHost(m_key[m_live].data(), h.key.data(), h.capacity * sizeof(std::uint64_t));
    m_mem.copyFromHost(m_disp[m_live].data(), h.disp.data(), h.capacity * sizeof(Vec3<R>));
    m_mem.copyFromHost(m_claimed.template as<std::uint32_t>() + m_live, &h.claimed, sizeof h.claimed);
  }

 private:
  static int shiftOf(std::uint32_t capacity) {
    int bits = 0;
    while ((std::uint32_t(1) << bits) < capacity) ++bits;
    return 64 - bits;
  }
  std::uint32_t* claimedOf(int t) const { return const_cast<Buffer&>(m_claimed).template as<std::uint32_t>() + t; }
  Pool viewOf(int t, std::uint32_t capacity) const {
    auto& self = const_cast<HistoryPoolStore&>(*this);
    return {self.m_key[t].template as<std::uint64_t>(), self.m_disp[t].template as<Vec3<R>>(), claimedOf(t), capacity,
            capacity / 2, shiftOf(capacity)};
  }
  void sizeTable(int t, std::uint32_t capacity) {
    m_key[t].resize(std::size_t(capacity) * sizeof(std::uint64_t));
    m_disp[t].resize(std::size_t(capacity) * sizeof(Vec3<R>));
  }
  void allocate(std::uint32_t capacity) {
    m_capacity = capacity;
    sizeTable(0, capacity);
    sizeTable(1, capacity);
    m_claimed.resize(2 * sizeof(std::uint32_t));
    m_live = 0;
  }
  void clearAt(const Pool& p) {
    m_mem.fillBytes(p.key, 0xFF, std::size_t(p.capacity) * sizeof(std::uint64_t));  // kEmpty
    m_mem.fillBytes(p.claimed, 0, sizeof(std::uint32_t));
  }
  void clear(int t) { clearAt(viewOf(t, m_capacity)); }

  Exec& m_exec;
  MemorySpace& m_mem;
  Buffer m_key[2]{Buffer{m_mem, 0}, Buffer{m_mem, 0}};
  Buffer m_disp[2]{Buffer{m_mem, 0}, Buffer{m_mem, 0}};
  Buffer m_claimed{m_mem, 0};
  std::uint32_t m_capacity = 0;
  int m_live = 0;
  int m_cap = 0;  // inline slots at most (configure); 0: no pool
};

}  // namespace pflow::compute
