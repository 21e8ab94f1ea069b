// Particle state as structure-of-arrays in the executor's memory, one Buffer per entry of the field
// table at the run's precision R. Slot fields (contact history) hold `slots` values per particle.
#pragma once
#include <array>
#include <cstdint>

#include "compute/core/Memory.h"
#include "compute/particles/ParticleFields.h"

namespace pflow::compute {

template <class R>
class ParticleData {
 public:
  static constexpr const FieldInfo* kTable = kFieldTableOf<R>;

  explicit ParticleData(MemorySpace& space) : m_space(&space) {
    for (auto& b : m_fields) b.bind(space);
  }

  Index size() const { return m_n; }
  // Rows allocated: size() may grow to this without moving anything (slot-major columns are this long).
  Index capacity() const { return m_capacity; }
  int contactSlots() const { return m_contactSlots; }
  int wallSlots() const { return m_wallSlots; }

  // Allocates every field for n particles (contents undefined); slot fields slot-major or particle-major
  // (SlotLayout, chosen by the executor).
  void allocate(Index n, int contactSlots, int wallSlots, bool slotMajor) {
    m_n = n;
    m_capacity = n;
    m_slotMajor = slotMajor;
    m_contactSlots = contactSlots;
    m_wallSlots = wallSlots;
    for (int k = 0; k < kNumFields; ++k) m_fields[k].resize(fieldBytes(kTable[k], n));
  }
  // Changes the row count (distributed runs: particles migrate in and out, ghosts come and go), keeping
  // rows [0, min(old, n)); new rows are undefined. Capacity grows by half again when it must grow.
  void resize(Index n);

  std::size_t valuesPerParticle(const FieldInfo& f) const {
    switch (f.multiplicity) {
      case Multiplicity::kOne: return 1;
      case Multiplicity::kContactSlots: return std::size_t(m_contactSlots);
      case Multiplicity::kWallSlots: return std::size_t(m_wallSlots);
    }
    return 1;
  }
  std::size_t strideBytes(const FieldInfo& f) const { return f.elementBytes * valuesPerParticle(f); }
  std::size_t fieldBytes(const FieldInfo& f, Index n) const { return strideBytes(f) * n; }
  // Bytes between slot k and slot k + 1 of a slot-major field (one column of `capacity` values).
  std::size_t columnBytes(const FieldInfo& f) const { return f.elementBytes * std::size_t(m_capacity); }

  template <Field F> using Type = typename FieldType<F, R>::type;
  template <Field F> Type<F>* ptr() { return m_fields[int(F)].template as<Type<F>>(); }
  template <Field F> const Type<F>* ptr() const { return m_fields[int(F)].template as<Type<F>>(); }
  bool slotMajor() const { return m_slotMajor; }
  SlotLayout layout(Multiplicity kind) const {
    if (m_slotMajor) return {1, m_capacity};
    return {kind == Multiplicity::kWallSlots ? std::size_t(m_wallSlots) : std::size_t(m_contactSlots), 1};
  }
  Buffer& buffer(Field f) { return m_fields[int(f)]; }
  const Buffer& buffer(Field f) const { return m_fields[int(f)]; }

  // Grows the slots of one slot kind (never shrinks), keeping every particle's existing slots and
  // marking the new ones empty (partner kNoPartner, wall key kNoGid, displacement 0).
  void resizeSlots(Multiplicity kind, int newSlots);

 private:
  MemorySpace* m_space;
  Index m_n = 0;
  Index m_capacity = 0;
  int m_contactSlots = 0;
  int m_wallSlots = 0;
  bool m_slotMajor = false;
  std::array<Buffer, kNumFields> m_fields;
};

}  // namespace pflow::compute
