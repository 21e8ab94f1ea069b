#include "compute/particles/ParticleData.h"

#include <algorithm>
#include <vector>

namespace pflow::compute {

template <class R>
void ParticleData<R>::resizeSlots(Multiplicity kind, int newSlots) {
  const int oldSlots = kind == Multiplicity::kContactSlots ? m_contactSlots : m_wallSlots;
  if (newSlots == oldSlots) return;
  // Slot layout is [particle][slot]; re-stride on the host side of the memory space. This is a rare,
  // growth-only event, so a round trip through host memory is acceptable and keeps it executor-neutral.
  for (int k = 0; k < kNumFields; ++k) {
    const FieldInfo& f = kTable[k];
    if (f.multiplicity != kind) continue;
    const std::size_t oldStride = f.elementBytes * std::size_t(oldSlots);
    const std::size_t newStride = f.elementBytes * std::size_t(newSlots);
    std::vector<unsigned char> oldHost(oldStride * m_n), newHost(newStride * m_n);
    m_space->copyToHost(oldHost.data(), m_fields[int(f.id)].data(), oldHost.size());
    // Empty slots: partner/key bytes 0xFF (kNoGid), displacements 0.
    const unsigned char fill = (f.id == Field::HistoryPartner || f.id == Field::WallKey) ? 0xFF : 0x00;
    std::fill(newHost.begin(), newHost.end(), fill);
    const std::size_t keep = std::min(oldStride, newStride);
    for (Index i = 0; i < m_n; ++i)
      std::copy_n(oldHost.data() + i * oldStride, keep, newHost.data() + i * newStride);
    m_fields[int(f.id)].resize(newHost.size());
    m_space->copyFromHost(m_fields[int(f.id)].data(), newHost.data(), newHost.size());
  }
  (kind == Multiplicity::kContactSlots ? m_contactSlots : m_wallSlots) = newSlots;
}

template class ParticleData<float>;
template class ParticleData<double>;

}  // namespace pflow::compute
