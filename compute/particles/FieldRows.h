// What every solver does with the rows of its field table, on any executor: reorder them (the cell sort),
// pack some of them for another rank (migration, halo) and copy packed rows back in, and copy them to the
// host as a snapshot. Driven by the table's flags (kSnapshot, kMigrate, kGhost, kRefresh), so a field
// added to a table travels wherever its flags say. The DEM engine (compute/dem/EngineImpl.h) and the SPH
// engine (compute/sph/SphEngineImpl.h) both hold one.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/core/Memory.h"
#include "compute/neighbor/CellGrid.h"
#include "compute/neighbor/NeighborKernels.h"
#include "compute/particles/DistributedRows.h"
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
  // (perm on the device), through scratch: slot-major slot fields one column at a time. Fields flagged
  // kRecomputed are left out (their values are written before they are read again) unless `recomputedToo` (a
  // resumed run's sort keeps the checkpoint's forces), and their memory is the scratch of a large table: a block
  // too large for one of them is gathered in row ranges, one into each, and copied back once all are gathered
  // (DEM in float: the 24-byte positions into the force's and the torque's 12 bytes a row), so the sort needs no
  // buffer of its own on the GPU. Otherwise one scratch buffer, where blocks are batched into launches of up to kBatchBytes
  // (GatherBlocks): with few rows, a launch per block would cost more than its bytes (DEM on the GPU: 7 fields plus
  // 2 per contact slot and 2 per wall slot, 37 blocks with the settled bed's 11 and 4, two launches each); with
  // many, each block is a batch of its own.
  static constexpr std::size_t kBatchBytes = std::size_t(8) << 20;
  void reorder(const Index* perm, Index count, bool recomputedToo = false) {
    using Block = kernels::GatherBlocks::Block;
    std::vector<Block>& all = m_blocks;  // kept: no allocation at each rebuild
    all.clear();
    m_lent.clear();
    std::size_t largest = 0;
    const bool byColumn = m_store.slotMajor();
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& f = Store::kTable[k];
      Buffer& field = m_store.buffer(f.id);
      if ((f.flags & kRecomputed) && !recomputedToo) {
        if (field.bytes()) m_lent.push_back({field.template as<unsigned char>(), field.bytes()});
        continue;
      }
      const bool columns = byColumn && f.multiplicity != Multiplicity::kOne;
      const std::size_t blocks = columns ? m_store.valuesPerParticle(f) : 1;
      const std::size_t stride = columns ? f.elementBytes : m_store.strideBytes(f);
      for (std::size_t b = 0; b < blocks; ++b)
        all.push_back({field.template as<unsigned char>() + b * m_store.columnBytes(f), stride, 0});
      largest = std::max(largest, stride * std::size_t(count));
    }
    if (largest > kBatchBytes && !m_lent.empty()) {
      reorderIntoLent(perm, count);
      return;
    }
    const auto rounded = [](std::size_t b) { return (b + 63) / 64 * 64; };
    std::size_t total = 0;
    for (const Block& b : all) total += rounded(b.stride * std::size_t(count));
    const std::size_t cap = std::max(largest, std::min(total, kBatchBytes));
    if (m_scratch.bytes() < cap) m_scratch.resize(cap);
    unsigned char* scratch = m_scratch.as<unsigned char>();
    for (std::size_t first = 0; first < all.size();) {
      kernels::GatherBlocks g{};
      g.scratch = scratch, g.perm = perm;
      std::size_t at = 0, next = first;
      while (next < all.size() && g.blocks < kernels::GatherBlocks::kMax &&
             (g.blocks == 0 || at + rounded(all[next].stride * std::size_t(count)) <= cap)) {
        g.block[g.blocks++] = {all[next].data, all[next].stride, at};
        at += rounded(all[next].stride * std::size_t(count));
        ++next;
      }
      if (g.blocks == 1) {  // one block: the plain gather and a copy back
        m_exec.forEach(count, kernels::GatherBytes{all[first].data, scratch, perm, all[first].stride});
        m_mem.copyWithin(all[first].data, scratch, all[first].stride * std::size_t(count));
      } else {
        m_exec.forEach(count, g);
        g.back = true;
        m_exec.forEach(count, g);
      }
      first = next;
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
      // The segment's blocks in launches of up to GatherBlocks::kMax (one launch per block cost more than its bytes
      // where the rows are few: a halo's few hundred).
      kernels::GatherBlocks g{};
      g.scratch = m_stage.as<unsigned char>(), g.perm = rows + first;
      forEachBlock(flags, [&](const unsigned char* field, std::size_t stride) {
        if (g.blocks == kernels::GatherBlocks::kMax) m_exec.forEach(n, g), g.blocks = 0;
        g.block[g.blocks++] = {const_cast<unsigned char*>(field), stride, at};
        at += stride * n;
      });
      if (g.blocks) m_exec.forEach(n, g);
      first += n;
    }
    m_mem.copyToHost(out.data(), m_stage.data(), out.size());
  }

  // The fields flagged with any of `flags` of rows [0, n), copied off the device in the table's own types and
  // row-major whatever the executor's layout (a slot field: n x slots x components, as `components`): a
  // checkpoint's arrays, which either executor loads back (loadState).
  ParticleSnapshot stateArrays(std::int64_t step, double time, Index n, std::uint32_t flags) const {
    ParticleSnapshot s{step, time, n, {}};
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& f = Store::kTable[k];
      if (!(f.flags & flags)) continue;
      const std::size_t per = m_store.valuesPerParticle(f);
      SnapshotArray a{f.name, f.scalar, int(std::size_t(f.components) * per), f.unit, {}};
      a.data.resize(std::size_t(n) * per * f.elementBytes);
      const unsigned char* from = m_store.buffer(f.id).template as<unsigned char>();
      if (m_store.slotMajor() && f.multiplicity != Multiplicity::kOne && per > 1) {
        std::vector<std::byte> column(std::size_t(n) * f.elementBytes);
        for (std::size_t slot = 0; slot < per; ++slot) {
          m_mem.copyToHost(column.data(), from + slot * m_store.columnBytes(f), column.size());
          for (Index i = 0; i < n; ++i)
            std::memcpy(a.data.data() + (std::size_t(i) * per + slot) * f.elementBytes, column.data() + std::size_t(i) * f.elementBytes,
                        f.elementBytes);
        }
      } else if (n) {
        m_mem.copyToHost(a.data.data(), from, a.data.size());
      }
      s.arrays.push_back(std::move(a));
    }
    return s;
  }

  // stateArrays' inverse into rows [0, s.n) (the store already holds that many rows at the arrays' slot counts):
  // every field flagged with any of `flags` must be there, at its size. Returns the first that is not.
  Status loadState(const ParticleSnapshot& s, std::uint32_t flags) {
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& f = Store::kTable[k];
      if (!(f.flags & flags)) continue;
      const SnapshotArray* a = s.find(f.name);
      const std::size_t per = m_store.valuesPerParticle(f);
      if (!a || a->type != f.scalar || a->data.size() != s.n * per * f.elementBytes)
        return Status(StatusCode::kInvalidArgument, std::string("checkpoint: the field '") + f.name + "' is " +
                                                        (a ? "not of this run's type and slot count" : "missing"));
      unsigned char* to = m_store.buffer(f.id).template as<unsigned char>();
      if (m_store.slotMajor() && f.multiplicity != Multiplicity::kOne && per > 1) {
        std::vector<std::byte> column(s.n * f.elementBytes);
        for (std::size_t slot = 0; slot < per; ++slot) {
          for (std::size_t i = 0; i < s.n; ++i)
            std::memcpy(column.data() + i * f.elementBytes, a->data.data() + (i * per + slot) * f.elementBytes, f.elementBytes);
          m_mem.copyFromHost(to + slot * m_store.columnBytes(f), column.data(), column.size());
        }
      } else if (s.n) {
        m_mem.copyFromHost(to, a->data.data(), a->data.size());
      }
    }
    return Status::ok();
  }

  // The kSnapshot fields named in `fields` (when empty: all of them but the kOnRequest ones) of rows [0, n), copied
  // off the device.
  // Output is double at both precisions (one file layout): float fields are widened on the host.
  ParticleSnapshot snapshot(std::int64_t step, double time, Index n, const std::vector<std::string>& fields) const {
    ParticleSnapshot s{step, time, n, {}};
    for (int k = 0; k < Store::kCount; ++k) {
      const Info& f = Store::kTable[k];
      if (!(f.flags & kSnapshot)) continue;
      if (fields.empty() ? (f.flags & kOnRequest) != 0 : std::find(fields.begin(), fields.end(), f.name) == fields.end()) continue;
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

 protected:  // LocalRows works on the same executor, memory and store
  const Exec& m_exec;
  MemorySpace& m_mem;
  Store& m_store;

 private:
  struct Lent {
    unsigned char* data;
    std::size_t bytes;
  };
  // reorder of a large table through the kRecomputed fields' memory: each block in row ranges, one range a lent
  // buffer, all gathered before any is copied back. The rows the lent buffers do not hold go through the scratch
  // buffer: a row at most with DEM's fields slot-major (the GPU's layout); particle-major (the CPU's), a slot field's
  // rows are wider than the lent memory and the rest of them go there.
  void reorderIntoLent(const Index* perm, Index count) {
    // The scratch is sized once for the widest left-over rows; a column left by a reorder that carried the
    // kRecomputed fields (a resumed run's first sort) is released here.
    Index first[Store::kCount + 1];
    std::size_t need = 0;
    for (const auto& b : m_blocks) {
      const std::size_t ranges = splitRows(b.stride, count, first);
      need = std::max(need, b.stride * std::size_t(count - first[ranges]));
    }
    if (m_scratch.bytes() < need || m_scratch.bytes() > need + kBatchBytes) m_scratch.resize(need);
    for (const auto& b : m_blocks) {
      const std::size_t ranges = splitRows(b.stride, count, first);
      const Index rest = count - first[ranges];
      auto into = [&](std::size_t r) { return r < ranges ? m_lent[r].data : m_scratch.as<unsigned char>(); };
      auto rowsOf = [&](std::size_t r) { return r < ranges ? first[r + 1] - first[r] : rest; };
      for (std::size_t r = 0; r <= ranges; ++r)
        if (rowsOf(r) > 0) m_exec.forEach(rowsOf(r), kernels::GatherBytes{b.data, into(r), perm + first[r], b.stride});
      for (std::size_t r = 0; r <= ranges; ++r)
        if (rowsOf(r) > 0) m_mem.copyWithin(b.data + b.stride * std::size_t(first[r]), into(r), b.stride * std::size_t(rowsOf(r)));
    }
  }
  // Rows [first[r], first[r + 1]) of a block of `stride`-byte rows go through lent buffer r; returns the number of
  // ranges, and the rows from first[ranges] on go through m_scratch.
  std::size_t splitRows(std::size_t stride, Index count, Index* first) const {
    std::size_t ranges = 0;
    first[0] = 0;
    for (const Lent& l : m_lent) {
      if (first[ranges] == count) break;
      first[ranges + 1] = first[ranges] + std::min<Index>(count - first[ranges], Index(l.bytes / stride));
      ++ranges;
    }
    return ranges;
  }

  Buffer m_scratch{m_mem, 0};
  std::vector<kernels::GatherBlocks::Block> m_blocks;  // reorder's list of blocks
  std::vector<Lent> m_lent;                            // the kRecomputed fields' memory, reorder's scratch
  mutable Buffer m_stage{m_mem, 0};  // pack/copyIn staging
};

// The local rows of a distributed run's engine: the owned particles [0, owned), then the ghosts [owned, n),
// with the ghosts' own cell list, and the DistributedRows operations on them (migration's keep and append, the
// halo's rows, ghosts set and refreshed). Both solvers' engines hold one and forward DistributedRows to it.
template <class Exec, class Store>
class LocalRows : public FieldRows<Exec, Store> {
 public:
  using Base = FieldRows<Exec, Store>;
  LocalRows(const Exec& exec, MemorySpace& mem, Store& store) : Base(exec, mem, store) {}

  Index n = 0;      // local rows: owned, then ghosts
  Index owned = 0;

  // Appends `count` rows of the fields carrying `flags` (packed by pack) after the first n rows.
  void unpack(const std::byte* data, Index count, std::uint32_t flags) {
    const Index first = n;
    n += count;
    m_store.resize(n);
    Base::copyIn(data, first, count, flags);
  }
  void pack(const std::vector<Index>& rows, const std::vector<int>& segments, std::uint32_t flags, std::vector<std::byte>& out) const {
    Base::uploadRows(m_rowsBuf, rows);
    Base::pack(m_rowsBuf.template as<Index>(), segments, flags, out);
  }
  void setHaloRows(const std::vector<Index>& rows, const std::vector<int>& segments) {
    Base::uploadRows(m_haloRowsBuf, rows);
    m_haloSegments = segments;
  }
  void packHalo(std::uint32_t flags, std::vector<std::byte>& out) const {
    Base::pack(m_haloRowsBuf.template as<Index>(), m_haloSegments, flags, out);
  }
  void keepOwned(const std::vector<Index>& keep) {
    n = owned;
    const Index count = Index(keep.size());
    if (m_rowsBuf.bytes() < std::max<std::size_t>(1, count) * sizeof(Index)) m_rowsBuf.resize(std::max<std::size_t>(1, count) * sizeof(Index));
    m_mem.copyFromHost(m_rowsBuf.data(), keep.data(), count * sizeof(Index));
    // Migration falls inside a rebuild, where the kRecomputed fields are dead (the forces follow), and they do not
    // travel with a particle either: a resumed run has every particle on its own rank, and then no row leaves.
    Base::reorder(m_rowsBuf.template as<Index>(), count);
    owned = n = count;
    m_store.resize(n);
  }
  void appendOwned(const std::vector<PackedRows>& blocks) {
    n = owned;
    for (const PackedRows& b : blocks) unpack(b.data, b.count, kMigrate);
    owned = n;
  }
  // The ghosts replaced by `blocks` (kGhost), binned into `grid`'s cells: their data stays in arrival order
  // (refreshes arrive in that order); ghostCellStart/ghostItems list them by cell. `positions()` gives the
  // position field, asked once the rows are in (unpacking may move every field).
  template <class Positions>
  void setGhosts(const std::vector<PackedRows>& blocks, const CellGrid& grid, const Positions& positions) {
    n = owned;
    for (const PackedRows& b : blocks) unpack(b.data, b.count, kGhost);
    const Index count = n - owned;
    auto atLeast = [](Buffer& b, std::size_t bytes) {
      if (b.bytes() < bytes) b.resize(bytes);
    };
    atLeast(m_ghostCellStart, (std::size_t(grid.numCells()) + 1) * sizeof(Index));
    atLeast(m_ghostItems, std::max<std::size_t>(1, count) * sizeof(Index));
    atLeast(m_ghostKey, std::max<std::size_t>(1, count) * sizeof(std::uint32_t));
    m_exec.forEach(count, kernels::CellKey{grid, positions() + owned, m_ghostKey.template as<std::uint32_t>()});
    m_exec.sortByKey(m_ghostKey.template as<std::uint32_t>(), count, grid.numCells(), m_ghostItems.template as<Index>(),
                     m_ghostCellStart.template as<Index>());
  }
  // Each cell's ghosts in the order `order(cellStart, items)` gives them (a kernel launch over the cells).
  template <class F>
  void orderGhostCells(std::uint32_t numCells, const F& order) {
    m_exec.forEach(numCells, order(m_ghostCellStart.template as<Index>(), m_ghostItems.template as<Index>()));
  }
  void refreshGhosts(const std::vector<PackedRows>& blocks) {
    Index first = owned;
    for (const PackedRows& b : blocks) {
      Base::copyIn(b.data, first, b.count, kRefresh);
      first += b.count;
    }
  }
  void dropGhosts() {
    n = owned;
    m_store.resize(n);
  }
  const Index* ghostCellStart() const { return m_ghostCellStart.template as<Index>(); }
  const Index* ghostItems() const { return m_ghostItems.template as<Index>(); }
  // The cell each ghost is listed in, by ghost row (row owned + k), as setGhosts binned it.
  const std::uint32_t* ghostKeys() const { return m_ghostKey.template as<std::uint32_t>(); }

 private:
  using Base::m_exec;
  using Base::m_mem;
  using Base::m_store;
  mutable Buffer m_rowsBuf{m_mem, 0};      // pack's rows
  mutable Buffer m_haloRowsBuf{m_mem, 0};  // the halo's rows, on the device from one rebuild to the next
  std::vector<int> m_haloSegments;
  Buffer m_ghostCellStart{m_mem, 0}, m_ghostItems{m_mem, 0}, m_ghostKey{m_mem, 0};
};

// An engine interface (Interface derives DistributedRows) whose row operations are its LocalRows's: the engine
// gives access to them (rows()) and says what follows a change of its local rows (localRowsChanged(): its own
// per-particle buffers resized). setGhosts and dropGhosts stay the engine's (each solver adds to them).
template <class Interface, class Rows>
class ForwardDistributedRows : public Interface {
 public:
  std::size_t rowBytes(std::uint32_t flags) const override { return rows().rowBytes(flags); }
  void pack(const std::vector<Index>& r, const std::vector<int>& segments, std::uint32_t flags, std::vector<std::byte>& out) const override {
    rows().pack(r, segments, flags, out);
  }
  void setHaloRows(const std::vector<Index>& r, const std::vector<int>& segments) override { rows().setHaloRows(r, segments); }
  void packHalo(std::uint32_t flags, std::vector<std::byte>& out) const override { rows().packHalo(flags, out); }
  void keepOwned(const std::vector<Index>& keep) override {
    rows().keepOwned(keep);
    localRowsChanged();
  }
  void appendOwned(const std::vector<PackedRows>& blocks) override {
    rows().appendOwned(blocks);
    localRowsChanged();
  }
  void refreshGhosts(const std::vector<PackedRows>& blocks) override { rows().refreshGhosts(blocks); }

 protected:
  virtual Rows& rows() = 0;
  virtual const Rows& rows() const = 0;
  virtual void localRowsChanged() = 0;
};

}  // namespace pflow::compute
