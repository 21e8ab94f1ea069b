// The OpenMP executor: runs the same kernel functors as the CUDA executor, one iteration per
// particle, on every core. Kernels are `PFLOW_HOSTDEVICE void operator()(Index i) const`.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

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

  // f(k) for k in [0, n) in two colours: each odd k once its neighbours k - 1 and k + 1 (even) have returned, the
  // even k in any order. Each item is a task handed to whichever thread is free; an odd item starts as soon as its two
  // neighbours are done, not when the whole even colour is (a barrier between the colours left threads idle while the
  // last even items ran: 50 items a colour on 16 threads take 4 rounds where 3.1 would do). For ComputePairsOnce and
  // PullHistory, whose item k (a slab of one cell layer) writes particles of layers k and k + 1 only: every particle's
  // writes come in the order of the barrier's schedule, so the sums are the same bits.
  template <class F>
  void forEachTwoColours(Index n, const F& f) const {
    if (n <= 2 || m_threads <= 1) {
      for (Index c = 0; c < 2; ++c)
        for (Index k = c; k < n; k += 2) f(k);
      return;
    }
    // A dependency's address per item (never read or written): kept between calls, so that a step allocates nothing.
    thread_local std::vector<char> ready;
    if (ready.size() < static_cast<std::size_t>(n)) ready.resize(static_cast<std::size_t>(n));
    char* d = ready.data();
#pragma omp parallel num_threads(m_threads)
#pragma omp single
    {
      for (std::int64_t k = 0; k < static_cast<std::int64_t>(n); k += 2) {
#pragma omp task firstprivate(k) shared(f) depend(out : d[k])
        f(static_cast<Index>(k));
      }
      for (std::int64_t k = 1; k < static_cast<std::int64_t>(n); k += 2) {
        const std::int64_t next = k + 1 < static_cast<std::int64_t>(n) ? k + 1 : k - 1;
#pragma omp task firstprivate(k) shared(f) depend(in : d[k - 1], d[next])
        f(static_cast<Index>(k));
      }
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
