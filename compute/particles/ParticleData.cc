#include "compute/particles/ParticleData.h"

#include <algorithm>
#include <vector>

namespace pflow::compute {

template <class R>
void ParticleData<R>::resizeSlots(Multiplicity kind, int newSlots) {
  const int oldSlots = kind == Multiplicity::kContactSlots ? m_contactSlots : m_wallSlots;
  if (newSlots == oldSlots) return;
  if (newSlots < oldSlots) return;  // slots only grow
  for (int k = 0; k < kNumFields; ++k) {
    const FieldInfo& f = kTable[k];
    if (f.multiplicity != kind) continue;
    // Empty slots: partner/key bytes 0xFF (kNoPartner, kNoGid), displacements 0.
    const unsigned char fill = (f.id == Field::HistoryPartner || f.id == Field::WallKey) ? 0xFF : 0x00;
    Buffer& b = m_fields[int(f.id)];
    if (m_slotMajor) {
      // One column of n values per slot: growing appends empty columns, every slot stays in place; on the
      // device.
      const std::size_t column = columnBytes(f);
      b.growKeep(column * std::size_t(newSlots));
      const std::size_t keep = column * std::size_t(oldSlots);
      m_space->fillBytes(static_cast<unsigned char*>(b.data()) + keep, fill, b.bytes() - keep);
    } else {
      // Particle-major (host memory on the CPU executor): re-stride every particle's row.
      const std::size_t oldStride = f.elementBytes * std::size_t(oldSlots);
      const std::size_t newStride = f.elementBytes * std::size_t(newSlots);
      std::vector<unsigned char> oldHost(oldStride * m_capacity), newHost(newStride * m_capacity, fill);
      m_space->copyToHost(oldHost.data(), b.data(), oldHost.size());
      for (Index i = 0; i < m_capacity; ++i)
        std::copy_n(oldHost.data() + i * oldStride, oldStride, newHost.data() + i * newStride);
      Buffer grown(*m_space, newHost.size());  // allocated before the old one goes: a failure loses nothing
      m_space->copyFromHost(grown.data(), newHost.data(), newHost.size());
      b.swap(grown);
    }
  }
  (kind == Multiplicity::kContactSlots ? m_contactSlots : m_wallSlots) = newSlots;
}

template <class R>
void ParticleData<R>::resize(Index n) {
  if (n <= m_capacity) {
    m_n = n;
    return;
  }
  const Index capacity = std::max<Index>(n, m_capacity + m_capacity / 2);
  for (int k = 0; k < kNumFields; ++k) {
    const FieldInfo& f = kTable[k];
    Buffer& b = m_fields[k];
    Buffer grown(*m_space, f.elementBytes * valuesPerParticle(f) * std::size_t(capacity));
    if (m_slotMajor && f.multiplicity != Multiplicity::kOne) {
      // Columns are `capacity` long: each moves to its new offset.
      for (std::size_t c = 0; c < valuesPerParticle(f); ++c)
        m_space->copyWithin(static_cast<unsigned char*>(grown.data()) + c * f.elementBytes * capacity,
                            static_cast<const unsigned char*>(b.data()) + c * columnBytes(f), f.elementBytes * m_n);
    } else if (m_n) {
      m_space->copyWithin(grown.data(), b.data(), fieldBytes(f, m_n));
    }
    b.swap(grown);
  }
  m_capacity = capacity;
  m_n = n;
}

template class ParticleData<float>;
template class ParticleData<double>;

}  // namespace pflow::compute
