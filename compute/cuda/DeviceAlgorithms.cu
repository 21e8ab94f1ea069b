#include "compute/cuda/DeviceAlgorithms.h"

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>

#include "compute/cuda/CudaCheck.h"

namespace pflow::compute::cuda {
namespace {

__global__ void iotaKernel(Index n, Index* out) {
  const Index i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) out[i] = i;
}

// keyStart[c] = number of sorted keys < c, by binary search (c in [0, numKeys]).
__global__ void keyStartKernel(const std::uint32_t* sorted, Index n, std::uint32_t numKeys, Index* keyStart) {
  const std::uint32_t c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c > numKeys) return;
  Index lo = 0, hi = n;
  while (lo < hi) {
    const Index mid = lo + (hi - lo) / 2;
    if (sorted[mid] < c) lo = mid + 1;
    else hi = mid;
  }
  keyStart[c] = lo;
}

int bitsFor(std::uint32_t numKeys) {
  int bits = 1;
  while (bits < 32 && (std::uint64_t(1) << bits) < numKeys) ++bits;
  return bits;
}

unsigned blocksFor(std::uint64_t n, unsigned block) { return unsigned((n + block - 1) / block); }

}  // namespace

void DeviceAlgorithms::sortByKey(const std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm,
                                 Index* keyStart) {
  if (m_keysOut.bytes() < std::size_t(n) * sizeof(std::uint32_t)) {
    m_keysOut.resize(std::size_t(n) * sizeof(std::uint32_t));
    m_iota.resize(std::size_t(n) * sizeof(Index));
  }
  if (n > 0) {
    iotaKernel<<<blocksFor(n, 256), 256>>>(n, m_iota.as<Index>());
    PFLOW_CUDA_CHECK(cudaGetLastError());
    const int endBit = bitsFor(numKeys);
    std::size_t bytes = 0;
    PFLOW_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys, m_keysOut.as<std::uint32_t>(),
                                                     m_iota.as<Index>(), perm, n, 0, endBit));
    void* t = temp(bytes);
    PFLOW_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(t, bytes, keys, m_keysOut.as<std::uint32_t>(), m_iota.as<Index>(),
                                                     perm, n, 0, endBit));
  }
  keyStartKernel<<<blocksFor(std::uint64_t(numKeys) + 1, 256), 256>>>(m_keysOut.as<std::uint32_t>(), n, numKeys,
                                                                       keyStart);
  PFLOW_CUDA_CHECK(cudaGetLastError());
}

void DeviceAlgorithms::sortByKeyLent(std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm, Index* keyStart,
                                     void* lent, std::size_t lentBytes) {
  if (n == 0 || lentBytes < lentBytesFor(n)) {
    sortByKey(keys, n, numKeys, perm, keyStart);
    return;
  }
  // The buffers of sortByKey (16 bytes an item), from a sort that could not borrow (a resumed run's first), go.
  m_keysOut.resize(0);
  m_iota.resize(0);
  auto* keysAlt = static_cast<std::uint32_t*>(lent);
  auto* permAlt = reinterpret_cast<Index*>(keysAlt + alignedItems(n));
  iotaKernel<<<blocksFor(n, 256), 256>>>(n, perm);
  PFLOW_CUDA_CHECK(cudaGetLastError());
  const int endBit = bitsFor(numKeys);
  cub::DoubleBuffer<std::uint32_t> k(keys, keysAlt);
  cub::DoubleBuffer<Index> v(perm, permAlt);
  std::size_t bytes = 0;
  PFLOW_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, bytes, k, v, n, 0, endBit));
  void* t = temp(bytes);
  PFLOW_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(t, bytes, k, v, n, 0, endBit));
  if (v.Current() != perm)
    PFLOW_CUDA_CHECK(cudaMemcpyAsync(perm, v.Current(), std::size_t(n) * sizeof(Index), cudaMemcpyDeviceToDevice));
  keyStartKernel<<<blocksFor(std::uint64_t(numKeys) + 1, 256), 256>>>(k.Current(), n, numKeys, keyStart);
  PFLOW_CUDA_CHECK(cudaGetLastError());
}

std::uint64_t DeviceAlgorithms::exclusiveScan(const std::uint32_t* in, std::uint32_t* out, Index n) {
  if (n == 0) return 0;
  std::uint32_t last[2];
  // The last input first: in place (in == out, which CUB's scan allows) the scan overwrites it.
  PFLOW_CUDA_CHECK(cudaMemcpy(&last[1], in + n - 1, sizeof(std::uint32_t), cudaMemcpyDeviceToHost));
  std::size_t bytes = 0;
  PFLOW_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in, out, n));
  void* t = temp(bytes);
  PFLOW_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(t, bytes, in, out, n));
  PFLOW_CUDA_CHECK(cudaMemcpy(&last[0], out + n - 1, sizeof(std::uint32_t), cudaMemcpyDeviceToHost));
  return std::uint64_t(last[0]) + last[1];
}

}  // namespace pflow::compute::cuda
