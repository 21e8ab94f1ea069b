// What every solver does with the rows of its field table, on any executor: reorder them (the cell sort),
// pack some of them for another rank (migration, halo) and copy packed rows back in, and copy them to the
// host as a snapshot. Driven by the table's flags (kSnapshot, kMigrate, kGhost, kRefresh), so a field
// added to a table travels wherever its flags say. The DEM engine (compute/sim/EngineImpl.h) and the SPH
// engine (compute/sph/SphEngineImpl.h) both hold one.
#pragma once
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "compute/core/Memory.h"
#include "compute/neighbor/NeighborKernels.h"
#include "compute/particles/FieldStore.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::compute {

template <class Exec, class Store>
class FieldRows {
 public:
  using Info = typename Store::Info;
  FieldRows(const Exec& exec, MemorySpace& mem, Store& store) : m_exec(exec), m_mem(mem), m_store(store) {}

  // Bytes of one packed row of the fields carrying `flags`.
  std::size_t rowBytes(std::uint32_t flags) const {
    std::size_t b = 0;
    for (int k = 0; k < Store::kCount; ++k)
      if (Store::kTable[k].flags & flags) b += m_store.strideBytes(Store::kTable[k]);
    return b;
  }

  // Every field of the table (all of its slots) reordered so that new row k = old row perm[k], k < count
  // (perm on the device), through one scratch buffer: slot-major slot fields one column at a time.
  void reorder(const Index* perm, Index count) {
    const bool byColumn = m_store.slotMajor();
    std::size_t largest = 0;
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& f = Store::kTable[k];
      largest = std::max(largest, f.elementBytes * (byColumn ? 1 : m_store.valuesPerParticle(f)) * std::size_t(count));
    }
    if (m_scratch.bytes() < largest) m_scratch.resize(largest);
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& f = Store::kTable[k];
      Buffer& field = m_store.buffer(f.id);
      const bool columns = byColumn && f.multiplicity != Multiplicity::kOne;
      const std::size_t blocks = columns ? m_store.valuesPerParticle(f) : 1;
      const std::size_t stride = columns ? f.elementBytes : m_store.strideBytes(f);
      for (std::size_t b = 0; b < blocks; ++b) {
        unsigned char* data = field.template as<unsigned char>() + b * m_store.columnBytes(f);
        m_exec.forEach(count, kernels::GatherBytes{data, m_scratch.as<unsigned char>(), perm, stride});
        m_mem.copyWithin(data, m_scratch.data(), stride * std::size_t(count));
      }
    }
  }

  // Calls f(first byte of row 0, stride) for each block of the fields carrying `flags`: one per field,
  // or one per slot of a slot-major slot field. The packed layout of pack/copyIn.
  template <class F>
  void forEachBlock(std::uint32_t flags, const F& f) const {
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& fi = Store::kTable[k];
      if (!(fi.flags & flags)) continue;
      const Buffer& field = m_store.buffer(fi.id);
      const bool columns = m_store.slotMajor() && fi.multiplicity != Multiplicity::kOne;
      const std::size_t blocks = columns ? m_store.valuesPerParticle(fi) : 1;
      const std::size_t stride = columns ? fi.elementBytes : m_store.strideBytes(fi);
      for (std::size_t b = 0; b < blocks; ++b)
        f(const_cast<unsigned char*>(field.template as<unsigned char>()) + b * m_store.columnBytes(fi), stride);
    }
  }

  // Overwrites rows [first, first + count) of the fields carrying `flags` with packed host data.
  void copyIn(const std::byte* data, Index first, Index count, std::uint32_t flags) {
    if (!count) return;
    const std::size_t bytes = rowBytes(flags) * count;
    if (m_stage.bytes() < bytes) m_stage.resize(bytes);
    m_mem.copyFromHost(m_stage.data(), data, bytes);
    std::size_t at = 0;
    forEachBlock(flags, [&](unsigned char* field, std::size_t stride) {
      m_mem.copyWithin(field + stride * first, m_stage.as<unsigned char>() + at, stride * count);
      at += stride * count;
    });
  }

  // Rows to the device (pack's row lists), into `b` (grown when needed).
  void uploadRows(Buffer& b, const std::vector<Index>& rows) const {
    if (b.bytes() < rows.size() * sizeof(Index)) b.resize(rows.size() * sizeof(Index));
    m_mem.copyFromHost(b.data(), rows.data(), rows.size() * sizeof(Index));
  }

  // Each segment field by field, each field a block of the segment's values (slot fields slot by slot when
  // slot-major), gathered on the device from rows `rows` (on the device) into one staging buffer: one copy
  // back to the host, whatever the number of segments.
  void pack(const Index* rows, const std::vector<int>& segments, std::uint32_t flags, std::vector<std::byte>& out) const {
    Index count = 0;
    for (int segment : segments) count += Index(segment);
    out.resize(rowBytes(flags) * count);
    if (!count) return;
    if (m_stage.bytes() < out.size()) m_stage.resize(out.size());
    std::size_t at = 0;
    Index first = 0;
    for (int segment : segments) {
      const Index n = Index(segment);
      if (!n) continue;
      forEachBlock(flags, [&](const unsigned char* field, std::size_t stride) {
        m_exec.forEach(n, kernels::GatherBytes{field, m_stage.as<unsigned char>() + at, rows + first, stride});
        at += stride * n;
      });
      first += n;
    }
    m_mem.copyToHost(out.data(), m_stage.data(), out.size());
  }

  // The kSnapshot fields named in `fields` (all of them when empty) of rows [0, n), copied off the device.
  // Output is double at both precisions (one file layout): float fields are widened on the host.
  ParticleSnapshot snapshot(std::int64_t step, double time, Index n, const std::vector<std::string>& fields) const {
    ParticleSnapshot s;
    s.step = step;
    s.time = time;
    s.n = n;
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& f = Store::kTable[k];
      if (!(f.flags & kSnapshot)) continue;
      if (!fields.empty() && std::find(fields.begin(), fields.end(), f.name) == fields.end()) continue;
      SnapshotArray a{f.name, f.scalar, f.components, f.unit, {}};
      a.data.resize(m_store.fieldBytes(f, n));
      m_mem.copyToHost(a.data.data(), m_store.buffer(f.id).data(), a.data.size());
      if (f.scalar == ScalarType::kF32) {
        const std::size_t values = a.data.size() / sizeof(float);
        std::vector<std::byte> wide(values * sizeof(double));
        const float* from = reinterpret_cast<const float*>(a.data.data());
        double* to = reinterpret_cast<double*>(wide.data());
        for (std::size_t v = 0; v < values; ++v) to[v] = from[v];
        a.data = std::move(wide);
        a.type = ScalarType::kF64;
      }
      s.arrays.push_back(std::move(a));
    }
    return s;
  }

 private:
  const Exec& m_exec;
  MemorySpace& m_mem;
  Store& m_store;
  Buffer m_scratch{m_mem, 0};
  mutable Buffer m_stage{m_mem, 0};  // pack/copyIn staging
};

}  // namespace pflow::compute
