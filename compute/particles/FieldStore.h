// Particle state as structure-of-arrays in the executor's memory: one Buffer per entry of a solver's field
// table (Set: DemFieldSet in ParticleFields.h, sph::SphFieldSet in compute/sph/SphFields.h) at the run's
// precision R. Slot fields (DEM contact history) hold `slots` values per particle.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "compute/core/Memory.h"
#include "compute/particles/FieldInfo.h"

namespace pflow::compute {

template <class Set, class R>
class FieldStore {
 public:
  using Id = typename Set::Id;
  using Info = FieldInfoOf<Id>;
  static constexpr int kCount = Set::kCount;
  static constexpr const Info* kTable = Set::template table<R>();

  explicit FieldStore(MemorySpace& space) : m_space(&space) {
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
    for (int k = 0; k < kCount; ++k) m_fields[k].resize(fieldBytes(kTable[k], n));
  }
  // Changes the row count (distributed runs: particles migrate in and out, ghosts come and go), keeping
  // rows [0, min(old, n)); new rows are undefined. Capacity grows by half again when it must grow.
  void resize(Index n);

  std::size_t valuesPerParticle(const Info& f) const {
    switch (f.multiplicity) {
      case Multiplicity::kOne: return 1;
      case Multiplicity::kContactSlots: return std::size_t(m_contactSlots);
      case Multiplicity::kWallSlots: return std::size_t(m_wallSlots);
    }
    return 1;
  }
  std::size_t strideBytes(const Info& f) const { return f.elementBytes * valuesPerParticle(f); }
  std::size_t fieldBytes(const Info& f, Index n) const { return strideBytes(f) * n; }
  // Bytes between slot k and slot k + 1 of a slot-major field (one column of `capacity` values).
  std::size_t columnBytes(const Info& f) const { return f.elementBytes * std::size_t(m_capacity); }

  template <Id F> using Type = typename Set::template Type<F, R>;
  template <Id F> Type<F>* ptr() { return m_fields[int(F)].template as<Type<F>>(); }
  template <Id F> const Type<F>* ptr() const { return m_fields[int(F)].template as<Type<F>>(); }
  bool slotMajor() const { return m_slotMajor; }
  SlotLayout layout(Multiplicity kind) const {
    if (m_slotMajor) return {1, m_capacity};
    return {kind == Multiplicity::kWallSlots ? std::size_t(m_wallSlots) : std::size_t(m_contactSlots), 1};
  }
  Buffer& buffer(Id f) { return m_fields[int(f)]; }
  const Buffer& buffer(Id f) const { return m_fields[int(f)]; }

  // Grows the slots of one slot kind (never shrinks), keeping every particle's existing slots and
  // marking the new ones empty (Set::emptySlotByte).
  void resizeSlots(Multiplicity kind, int newSlots);

 private:
  MemorySpace* m_space;
  Index m_n = 0;
  Index m_capacity = 0;
  int m_contactSlots = 0;
  int m_wallSlots = 0;
  bool m_slotMajor = false;
  std::array<Buffer, kCount> m_fields;
};

template <class Set, class R>
void FieldStore<Set, R>::resizeSlots(Multiplicity kind, int newSlots) {
  const int oldSlots = kind == Multiplicity::kContactSlots ? m_contactSlots : m_wallSlots;
  if (newSlots <= oldSlots) return;  // slots only grow
  for (int k = 0; k < kCount; ++k) {
    const Info& f = kTable[k];
    if (f.multiplicity != kind) continue;
    const unsigned char fill = Set::emptySlotByte(f.id);
    Buffer& b = m_fields[k];
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

template <class Set, class R>
void FieldStore<Set, R>::resize(Index n) {
  if (n <= m_capacity) {
    m_n = n;
    return;
  }
  const Index capacity = std::max<Index>(n, m_capacity + m_capacity / 2);
  for (int k = 0; k < kCount; ++k) {
    const Info& f = kTable[k];
    const std::size_t bytes = f.elementBytes * valuesPerParticle(f) * std::size_t(capacity);
    if (!bytes) continue;  // a slot field with no slots
    std::vector<Buffer::Move> moves;
    if (m_slotMajor && f.multiplicity != Multiplicity::kOne) {
      // Columns are `capacity` long: each moves to its new offset.
      for (std::size_t c = 0; c < valuesPerParticle(f); ++c)
        moves.push_back({c * columnBytes(f), c * f.elementBytes * capacity, f.elementBytes * m_n});
    } else {
      moves.push_back({0, 0, fieldBytes(f, m_n)});
    }
    // Through the host on a GPU (Buffer::growPlaced): a rank whose rows outgrow their capacity never holds a field
    // twice.
    m_fields[k].growPlaced(bytes, moves);
  }
  m_capacity = capacity;
  m_n = n;
}

}  // namespace pflow::compute
