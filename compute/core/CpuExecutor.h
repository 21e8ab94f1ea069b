// The OpenMP executor: runs the same kernel functors as the CUDA executor, one iteration per
// particle, on every core. Kernels are `PFLOW_HOSTDEVICE void operator()(Index i) const`.
#pragma once
#include <cstdint>
#include <string>

#include "compute/core/Memory.h"
#include "compute/core/Types.h"

namespace pflow::compute {

class CpuExecutor {
 public:
  static constexpr const char* kName = "cpu";
  static constexpr bool kColumnMajorLists = false;  // each core walks its own candidate rows
  static constexpr bool kSlotMajor = false;         // and its particles' history slots (SlotLayout)
  static constexpr bool kPairsOnce = true;          // forEachTwoColours: each contact evaluated once (ComputePairsOnce)
  static constexpr bool kLockstepLanes = false;     // a core runs its own branches (the SPH walk in one phase)
  explicit CpuExecutor(int threads = 0);
  // Below this many iterations a loop runs on the calling thread: waking a team costs more.
  static constexpr Index kMinParallel = 512;

  MemorySpace& memory() { return m_memory; }
  int threads() const { return m_threads; }
  std::string description() const;

  // f(i) for i in [0, n). Streaming kernels (the same work per item) run a static schedule: thread t
  // always works on the same share of the particles, the share it first touched (HostMemory), so it
  // stays in that core's caches and NUMA node. Kernels whose cost per item varies (contacts, forces;
  // they declare kVariableCost) hand out chunks of 256 items to whichever thread is free: on the 16
  // cores of the GPU host that made the forces phase 1.5x faster than static shares (bench/RESULTS.md),
  // whose slowest thread sets the pace. PFLOW_DYNAMIC_CHUNK=N sets the chunk (0: static everywhere).
  template <class F>
  void forEach(Index n, const F& f) const {
    if (variableCost<F>() && m_dynamicChunk > 0) {
#pragma omp parallel for schedule(dynamic, m_dynamicChunk) num_threads(m_threads) if (n >= kMinParallel)
      for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) f(static_cast<Index>(i));
      return;
    }
#pragma omp parallel for schedule(static) num_threads(m_threads) if (n >= kMinParallel)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) f(static_cast<Index>(i));
  }

  // f(k) for k in [0, n) in two colours: every even k, then, once all of those have returned, every odd k.
  // Items of one colour run in parallel, one item per task handed to whichever thread is free.
  template <class F>
  void forEachTwoColours(Index n, const F& f) const {
#pragma omp parallel num_threads(m_threads) if (n > 2)
    for (int c = 0; c < 2; ++c) {
#pragma omp for schedule(dynamic, 1)
      for (std::int64_t k = c; k < static_cast<std::int64_t>(n); k += 2) f(static_cast<Index>(k));
    }
  }

  // max over i of f(i) (f returns double); 0 for n == 0.
  template <class F>
  double maxOf(Index n, const F& f) const {
    double result = 0;
#pragma omp parallel for schedule(static) num_threads(m_threads) if (n >= kMinParallel) reduction(max : result)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) {
      const double v = f(static_cast<Index>(i));
      if (v > result) result = v;
    }
    return result;
  }

  // sum over i of f(i) (f returns double).
  template <class F>
  double sumOf(Index n, const F& f) const {
    double result = 0;
#pragma omp parallel for schedule(static) num_threads(m_threads) if (n >= kMinParallel) reduction(+ : result)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) result += f(static_cast<Index>(i));
    return result;
  }

  // Stable counting sort of [0, n) by key < numKeys: perm[k] = old index of the k-th sorted item,
  // keyStart[c] = first sorted position with key c (numKeys + 1 entries).
  void sortByKey(const std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm, Index* keyStart) const;
  // The CUDA executor's variant that sorts in lent memory: the counting sort needs none.
  void sortByKeyLent(std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm, Index* keyStart, void*,
                     std::size_t) const {
    sortByKey(keys, n, numKeys, perm, keyStart);
  }

  // out[i] = sum of in[0..i), returns the total; in place when in == out.
  std::uint64_t exclusiveScan(const std::uint32_t* in, std::uint32_t* out, Index n) const;

  void synchronize() const {}

 private:
  template <class F>
  static constexpr bool variableCost() {
    if constexpr (requires { F::kVariableCost; }) return F::kVariableCost;
    else return false;
  }
  int m_threads;
  int m_dynamicChunk = 256;
  HostMemory m_memory;
};

}  // namespace pflow::compute
