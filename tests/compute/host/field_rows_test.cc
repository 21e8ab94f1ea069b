// The cell sort's reorder of the DEM field table (compute/particles/FieldRows.h): every field moves with its row,
// slot columns included, whichever scratch it goes through; the force and torque (kRecomputed) are left out and
// lend their memory, so a large table is sorted with no buffer of its own. Slot fields, and the rows' capacity, grow
// on a device without holding any field twice.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "compute/core/CpuExecutor.h"
#include "compute/dem/ParticleFields.h"
#include "compute/particles/FieldRows.h"
#include "tests/support/DeviceLikeMemory.h"

namespace pflow::compute {
namespace {

using Store = FieldStore<DemFieldSet, float>;
using Rows = FieldRows<CpuExecutor, Store>;

// A value for each byte of each field's row r (slot s): the same function before and after, so a moved row is
// recognised wherever it lands.
unsigned char tag(int field, std::size_t r, std::size_t byte) {
  return static_cast<unsigned char>((r * 2654435761u + byte * 97u + std::size_t(field) * 31u) >> 7);
}

struct Table {
  CpuExecutor exec{2};
  Store store{exec.memory()};
  Rows rows{exec, exec.memory(), store};

  // n rows with `slots` contact and wall slots, slot-major (the GPU's layout) or particle-major (the CPU's).
  Table(Index n, int slots, bool slotMajor) {
    store.allocate(n, slots, slots, slotMajor);
    forEachField([&](int k, unsigned char* data, std::size_t stride, std::size_t column, std::size_t blocks) {
      std::vector<unsigned char> host(column * blocks);
      for (std::size_t b = 0; b < blocks; ++b)
        for (std::size_t r = 0; r < std::size_t(n); ++r)
          for (std::size_t c = 0; c < stride; ++c) host[b * column + r * stride + c] = tag(k * 64 + int(b), r, c);
      exec.memory().copyFromHost(data, host.data(), host.size());
    });
  }
  // f(field, first byte, row stride, bytes between blocks, blocks): a block per slot column when slot-major.
  template <class F>
  void forEachField(const F& f) {
    for (int k = 0; k < kNumFields; ++k) {
      const FieldInfo& fi = Store::kTable[k];
      const bool columns = store.slotMajor() && fi.multiplicity != Multiplicity::kOne;
      const std::size_t stride = columns ? fi.elementBytes : store.strideBytes(fi);
      const std::size_t column = columns ? store.columnBytes(fi) : stride * std::size_t(store.capacity());
      f(k, store.buffer(fi.id).as<unsigned char>(), stride, column, columns ? store.valuesPerParticle(fi) : 1);
    }
  }
  // How many bytes of the fields (kRecomputed ones only if `recomputed`) are not old row perm[r] at row r.
  std::size_t misplaced(const std::vector<Index>& perm, bool recomputed) {
    std::size_t bad = 0;
    forEachField([&](int k, unsigned char* data, std::size_t stride, std::size_t column, std::size_t blocks) {
      if ((Store::kTable[k].flags & kRecomputed) && !recomputed) return;
      std::vector<unsigned char> host(column * blocks);
      exec.memory().copyToHost(host.data(), data, host.size());
      for (std::size_t b = 0; b < blocks; ++b)
        for (std::size_t r = 0; r < perm.size(); ++r)
          for (std::size_t c = 0; c < stride; ++c)
            bad += host[b * column + r * stride + c] != tag(k * 64 + int(b), perm[r], c);
    });
    return bad;
  }
};

std::vector<Index> shuffled(Index n, unsigned seed) {
  std::vector<Index> perm(n);
  std::iota(perm.begin(), perm.end(), Index(0));
  std::shuffle(perm.begin(), perm.end(), std::mt19937(seed));
  return perm;
}

// 400 001 rows: the positions' column (24 bytes a row, 9.6 MB) is above the batch size, so the sort goes through
// the force's and torque's 12 bytes a row, and an odd count leaves a row over for the scratch buffer.
TEST(FieldRowsReorder, LargeTableMovesEveryFieldThroughTheForcesMemory) {
  for (bool slotMajor : {true, false}) {
    const Index n = 400001;
    Table t(n, 3, slotMajor);
    const std::vector<Index> perm = shuffled(n, 7);
    const std::size_t before = t.exec.memory().bytesInUse();
    t.rows.reorder(perm.data(), n);
    EXPECT_EQ(t.misplaced(perm, false), 0u) << (slotMajor ? "slot-major" : "particle-major");
    // Slot-major, the left-over row's 24 bytes at most (rounded to the allocator's 64), not a column of the table;
    // particle-major, what of the widest rows (3 slots of 12 bytes) the 24 lent bytes a row do not hold.
    EXPECT_LE(t.exec.memory().bytesInUse() - before, slotMajor ? 64u : 12u * n + 64u);
  }
}

// A resumed run's sort carries the forces too (they are the checkpoint's, read by the next step's half kick).
TEST(FieldRowsReorder, RecomputedFieldsMoveWhenAsked) {
  const Index n = 400001;
  Table t(n, 2, true);
  const std::vector<Index> perm = shuffled(n, 11);
  t.rows.reorder(perm.data(), n, /*recomputedToo=*/true);
  EXPECT_EQ(t.misplaced(perm, true), 0u);
}

// After a resumed run's first sort (the forces carried, through a scratch column of the widest field), the next
// sort lends the forces' memory again and the column is released (docs/performance.md: a resumed run held ~40 B a
// particle more for the rest of the run).
TEST(FieldRowsReorder, ScratchColumnReleasedWhenTheForcesLendAgain) {
  const Index n = 400001;
  Table t(n, 2, true);
  const std::size_t table = t.exec.memory().bytesInUse();
  const std::vector<Index> first = shuffled(n, 5);
  t.rows.reorder(first.data(), n, /*recomputedToo=*/true);
  EXPECT_GE(t.exec.memory().bytesInUse() - table, 24u * n);  // the positions' column
  const std::vector<Index> second = shuffled(n, 6);
  t.rows.reorder(second.data(), n);
  EXPECT_LE(t.exec.memory().bytesInUse() - table, 64u);
  // Both moves composed: row r holds what was row first[second[r]].
  std::vector<Index> composed(n);
  for (Index r = 0; r < n; ++r) composed[r] = first[second[r]];
  EXPECT_EQ(t.misplaced(composed, false), 0u);
}

// A small table: batched gathers through one scratch buffer of at most the batch size.
TEST(FieldRowsReorder, SmallTableMovesEveryField) {
  for (bool slotMajor : {true, false}) {
    const Index n = 5003;
    Table t(n, 4, slotMajor);
    const std::vector<Index> perm = shuffled(n, 3);
    t.rows.reorder(perm.data(), n);
    EXPECT_EQ(t.misplaced(perm, false), 0u);
  }
}

// Slot fields growing in the GPU's layout (slot-major) in a memory that grows through the host, as CudaMemory does:
// the space never holds more than it holds after the growths (before 2026-11-29 the bed's peak was 12 B a particle
// above its end, the old wall field beside the grown one); every kept slot keeps its values, every new slot is
// empty. The same growths in host memory, which keeps both blocks for the copy, do peak above the end: the check
// tells the two apart.
TEST(FieldStoreSlots, GrowingThroughTheHostHoldsNoFieldTwice) {
  const Index n = 1000;
  test::DeviceLikeMemory device;
  CpuExecutor exec{1};
  for (MemorySpace* mem : {static_cast<MemorySpace*>(&device), &exec.memory()}) {
    Store store(*mem);
    store.allocate(n, 2, 1, /*slotMajor=*/true);
    const auto slotFields = [&](const auto& f) {
      for (int k = 0; k < kNumFields; ++k)
        if (Store::kTable[k].multiplicity != Multiplicity::kOne) f(k, Store::kTable[k]);
    };
    slotFields([&](int k, const FieldInfo& fi) {
      std::vector<unsigned char> host(store.columnBytes(fi) * store.valuesPerParticle(fi));
      for (std::size_t b = 0; b < host.size(); ++b) host[b] = tag(k, b, 0);
      mem->copyFromHost(store.buffer(fi.id).data(), host.data(), host.size());
    });
    store.resizeSlots(Multiplicity::kWallSlots, 2);
    store.resizeSlots(Multiplicity::kContactSlots, 3);
    if (mem == &device) EXPECT_EQ(mem->peakBytes(), mem->bytesInUse());
    else EXPECT_GT(mem->peakBytes(), mem->bytesInUse());
    slotFields([&](int k, const FieldInfo& fi) {
      const std::size_t column = store.columnBytes(fi), kept = fi.multiplicity == Multiplicity::kWallSlots ? 1 : 2;
      std::vector<unsigned char> host(column * store.valuesPerParticle(fi));
      mem->copyToHost(host.data(), store.buffer(fi.id).data(), host.size());
      std::size_t bad = 0;
      for (std::size_t b = 0; b < host.size(); ++b)
        bad += host[b] != (b < kept * column ? tag(k, b, 0) : DemFieldSet::emptySlotByte(fi.id));
      EXPECT_EQ(bad, 0u) << fi.name;
    });
  }
}

// A rank's rows outgrowing their capacity (FieldStore::resize, distributed runs) in the GPU's layout, in a memory that
// grows through the host: every field, slot columns included, moves to its new place with no field held twice (the
// peak is the end's; before 2026-11-29 each field's old and grown blocks were held together while it moved), and
// every kept row keeps its bytes, each slot column at its new offset. Host memory does hold both: the check tells
// the two apart.
TEST(FieldStoreCapacity, GrowingThroughTheHostHoldsNoFieldTwice) {
  const Index n = 1000, grown = 1700;
  test::DeviceLikeMemory device;
  CpuExecutor exec{1};
  for (MemorySpace* mem : {static_cast<MemorySpace*>(&device), &exec.memory()}) {
    Store store(*mem);
    store.allocate(n, 2, 1, /*slotMajor=*/true);
    const std::size_t before = mem->bytesInUse();
    for (int k = 0; k < kNumFields; ++k) {
      const FieldInfo& fi = Store::kTable[k];
      std::vector<unsigned char> host(store.fieldBytes(fi, n));
      for (std::size_t b = 0; b < host.size(); ++b) host[b] = tag(k, b, 1);
      if (!host.empty()) mem->copyFromHost(store.buffer(fi.id).data(), host.data(), host.size());
    }
    const std::size_t peakBefore = mem->peakBytes();
    store.resize(grown);
    EXPECT_EQ(store.size(), grown);
    EXPECT_GE(store.capacity(), grown);
    EXPECT_GT(mem->bytesInUse(), before);
    if (mem == &device) EXPECT_EQ(mem->peakBytes(), std::max(peakBefore, mem->bytesInUse()));
    else EXPECT_GT(mem->peakBytes(), mem->bytesInUse());
    for (int k = 0; k < kNumFields; ++k) {
      const FieldInfo& fi = Store::kTable[k];
      const std::size_t values = store.valuesPerParticle(fi), oldColumn = fi.elementBytes * std::size_t(n);
      if (!values) continue;
      std::vector<unsigned char> host(store.fieldBytes(fi, store.capacity()));
      mem->copyToHost(host.data(), store.buffer(fi.id).data(), host.size());
      std::size_t bad = 0;
      if (fi.multiplicity == Multiplicity::kOne) {
        for (std::size_t b = 0; b < oldColumn; ++b) bad += host[b] != tag(k, b, 1);
      } else {
        for (std::size_t c = 0; c < values; ++c)
          for (std::size_t b = 0; b < oldColumn; ++b) bad += host[c * store.columnBytes(fi) + b] != tag(k, c * oldColumn + b, 1);
      }
      EXPECT_EQ(bad, 0u) << fi.name;
    }
  }
}

}  // namespace
}  // namespace pflow::compute
