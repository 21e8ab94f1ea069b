#include "compute/particles/ParticleData.h"


namespace pflow::compute {

template <class R>
void ParticleData<R>::resizeSlots(Multiplicity kind, int newSlots) {
  const int oldSlots = kind == Multiplicity::kContactSlots ? m_contactSlots : m_wallSlots;
  if (newSlots == oldSlots) return;
  // Slot fields are slot-major (one column of n values per slot), so growing appends empty columns and
  // every existing slot stays where it is; all on the device.
  if (newSlots < oldSlots) return;  // slots only grow
  for (int k = 0; k < kNumFields; ++k) {
    const FieldInfo& f = kTable[k];
    if (f.multiplicity != kind) continue;
    const std::size_t column = f.elementBytes * std::size_t(m_n);
    Buffer& b = m_fields[int(f.id)];
    b.growKeep(column * std::size_t(newSlots));
    // Empty slots: partner/key bytes 0xFF (kNoPartner, kNoGid), displacements 0.
    const unsigned char fill = (f.id == Field::HistoryPartner || f.id == Field::WallKey) ? 0xFF : 0x00;
    const std::size_t keep = column * std::size_t(oldSlots);
    m_space->fillBytes(static_cast<unsigned char*>(b.data()) + keep, fill, b.bytes() - keep);
  }
  (kind == Multiplicity::kContactSlots ? m_contactSlots : m_wallSlots) = newSlots;
}

template class ParticleData<float>;
template class ParticleData<double>;

}  // namespace pflow::compute
