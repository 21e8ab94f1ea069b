// EngineImpl's history pool on the host (compute/dem/contact/HistoryPool.h): the copy that reduce_dt's in-memory
// checkpoint keeps (save, restore: the table as it is, keyed by identities, so the rows' order does not matter),
// and the merge of the pooled histories into the inline slots of a checkpoint file, whose layout is then what it
// was without a pool (every history of a particle in its row, as many slots as the most any particle holds).
// Included at the end of EngineImpl.h: these are its member templates.
#pragma once

#include <unordered_map>

#include "compute/dem/EngineImpl.h"

namespace pflow::compute {

template <class Exec, class R>
void EngineImpl<Exec, R>::clearPooled() {
  Buffer& b = m_particles.buffer(Field::HistoryPooled);
  m_mem.fillBytes(b.data(), 0, b.bytes());
}

template <class Exec, class R>
void EngineImpl<Exec, R>::savePool() const {
  m_savedPool = m_pool.copy();
  m_savedPooled.assign(m_pool.active() ? m_owned : 0, 0);
  if (!m_savedPooled.empty())
    m_mem.copyToHost(m_savedPooled.data(), m_particles.template ptr<Field::HistoryPooled>(), m_savedPooled.size() * sizeof(std::int32_t));
}

template <class Exec, class R>
void EngineImpl<Exec, R>::restorePool() {
  clearPooled();
  m_pool.restore(m_savedPool);
  if (!m_savedPooled.empty() && m_savedPooled.size() <= m_owned)
    m_mem.copyFromHost(m_particles.template ptr<Field::HistoryPooled>(), m_savedPooled.data(), m_savedPooled.size() * sizeof(std::int32_t));
}

template <class Exec, class R>
void EngineImpl<Exec, R>::mergePool(ParticleSnapshot& s) const {
  const auto entries = m_pool.entries();
  if (entries.empty()) return;
  SnapshotArray* gidArray = nullptr;
  SnapshotArray* partnerArray = nullptr;
  SnapshotArray* dispArray = nullptr;
  for (auto& a : s.arrays) {
    if (a.name == kFieldTableOf<R>[int(Field::Gid)].name) gidArray = &a;
    if (a.name == kFieldTableOf<R>[int(Field::HistoryPartner)].name) partnerArray = &a;
    if (a.name == kFieldTableOf<R>[int(Field::HistoryDisp)].name) dispArray = &a;
  }
  if (!gidArray || !partnerArray || !dispArray) return;
  const std::size_t n = s.n, slots = std::size_t(partnerArray->components);
  std::unordered_map<PartnerId, std::vector<std::size_t>> byOwner;  // owner gid -> entries
  for (std::size_t k = 0; k < entries.size(); ++k) byOwner[entries[k].owner].push_back(k);
  const Gid* gid = gidArray->as<Gid>();
  const PartnerId* partner = partnerArray->as<PartnerId>();
  const Vec3<R>* disp = reinterpret_cast<const Vec3<R>*>(dispArray->data.data());
  // The widest row: a particle's occupied inline slots and its pooled entries.
  std::size_t width = slots;
  for (std::size_t i = 0; i < n; ++i) {
    auto it = byOwner.find(PartnerId(gid[i]));
    if (it == byOwner.end()) continue;
    std::size_t used = 0;
    for (std::size_t k = 0; k < slots; ++k) used += partner[i * slots + k] != kNoPartner;
    width = std::max(width, used + it->second.size());
  }
  std::vector<PartnerId> p(n * width, kNoPartner);
  std::vector<Vec3<R>> d(n * width, zero3<R>());
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t w = 0;
    for (std::size_t k = 0; k < slots; ++k)
      if (partner[i * slots + k] != kNoPartner) p[i * width + w] = partner[i * slots + k], d[i * width + w++] = disp[i * slots + k];
    auto it = byOwner.find(PartnerId(gid[i]));
    if (it == byOwner.end()) continue;
    for (std::size_t k : it->second) p[i * width + w] = entries[k].partner, d[i * width + w++] = entries[k].disp;
  }
  partnerArray->components = int(width);
  partnerArray->data.resize(p.size() * sizeof(PartnerId));
  std::memcpy(partnerArray->data.data(), p.data(), partnerArray->data.size());
  dispArray->components = int(3 * width);
  dispArray->data.resize(d.size() * sizeof(Vec3<R>));
  std::memcpy(dispArray->data.data(), d.data(), dispArray->data.size());
}

}  // namespace pflow::compute
