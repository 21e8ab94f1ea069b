// Device-wide primitives of the CUDA executor that come from CUB (radix sort, scan), behind a plain
// C++ interface: nothing that includes this header sees CUB or CUDA types. Implemented in
// DeviceAlgorithms.cu. All work is queued on the default stream.
#pragma once
#include <cstdint>

#include "compute/core/Memory.h"
#include "compute/core/Types.h"

namespace pflow::compute::cuda {

class DeviceAlgorithms {
 public:
  explicit DeviceAlgorithms(MemorySpace& deviceMemory)
      : m_temp(deviceMemory, 0), m_keysOut(deviceMemory, 0), m_iota(deviceMemory, 0) {}

  // Stable sort of [0, n) by key < numKeys (LSD radix sort over the key bits in use):
  // perm[k] = old index of the k-th sorted item; keyStart[c] = first sorted position with key c
  // (numKeys + 1 entries). The same permutation as the OpenMP executor's stable counting sort.
  void sortByKey(const std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm, Index* keyStart);
  // The same sort in the caller's memory: `keys` is overwritten, and `lent` (lentBytes of memory that is free
  // until the sort returns, at least lentBytesFor(n)) holds the radix sort's second buffers, so that the sort keeps
  // only CUB's histograms of its own between calls, not 16 bytes an item. Less lent memory: sortByKey.
  void sortByKeyLent(std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm, Index* keyStart, void* lent,
                     std::size_t lentBytes);
  static std::size_t lentBytesFor(Index n) { return alignedItems(n) * sizeof(std::uint32_t) + std::size_t(n) * sizeof(Index); }

  // out[i] = sum of in[0..i); returns the total (read back to the host). In place when in == out.
  std::uint64_t exclusiveScan(const std::uint32_t* in, std::uint32_t* out, Index n);

 private:
  static std::size_t alignedItems(Index n) { return (std::size_t(n) + 63) / 64 * 64; }  // 256-byte aligned halves
  void* temp(std::size_t bytes) {
    if (m_temp.bytes() < bytes) m_temp.resize(bytes + bytes / 4);
    return m_temp.data();
  }
  Buffer m_temp, m_keysOut, m_iota;
};

}  // namespace pflow::compute::cuda
