// The CUDA executor: the same kernel functors as the OpenMP executor, one thread per item, on one
// GPU. Every array lives in device memory (explicit cudaMalloc, no managed memory); the host reads
// back only reduction results and the Conditions flags. Included only by .cu files.
//
// Block sizes are chosen per kernel by measurement: the first launches of each kernel (with enough
// items to fill the GPU) cycle through the candidate block sizes, each timed with events, and the
// fastest median is kept for the rest of the run (LaunchTuner). Every launch does its real work
// exactly once, so tuning needs no idempotent kernels and no copies of the state.
#pragma once
#include <cuda_runtime.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <typeinfo>
#include <vector>

#include "compute/core/Memory.h"
#include "compute/core/Types.h"
#include "compute/cuda/CudaCheck.h"
#include "compute/cuda/DeviceAlgorithms.h"

namespace pflow::compute::cuda {

// Device memory of the current GPU. Copies are synchronous with respect to the default stream, on
// which every kernel of the executor runs, so a copy always sees the kernels queued before it.
class CudaMemory final : public MemorySpace {
 public:
  void* allocate(std::size_t bytes) override;
  void deallocate(void* p) override;
  void copyToHost(void* d, const void* s, std::size_t b) override;
  void copyFromHost(void* d, const void* s, std::size_t b) override;
  void copyWithin(void* d, const void* s, std::size_t b) override;
  void fillBytes(void* d, unsigned char v, std::size_t b) override;
  bool growsThroughHost() const override { return true; }

 private:
  std::map<void*, std::size_t> m_sizes;
};

template <class F>
__global__ void forEachKernel(Index n, F f) {
  const Index i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

// The same with at most N registers a thread (F::kMaxRegisters = N): more warps resident to hide the loads of
// the latency-bound passes, for some spills (the SPH rates pass in float: 64; the DEM pair forces: 80 in float,
// 128 in double; docs/performance.md and docs/sph.md say what each bought).
template <int N, class F>
__global__ void __maxnreg__(N) forEachKernelCapped(Index n, F f) {
  const Index i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

// F's register cap (F::kMaxRegisters), 0 where it has none.
template <class F>
constexpr int maxRegistersOf() {
  if constexpr (requires { F::kMaxRegisters; }) return F::kMaxRegisters;
  else return 0;
}

// The block's reduction of v by `op` (warp shuffles, then one warp over the warps' results in shared
// memory); valid in thread 0 only.
template <class Op>
__device__ double blockReduce(double v, Op op) {
  for (int o = 16; o > 0; o >>= 1) v = op(v, __shfl_down_sync(0xffffffffu, v, o));
  __shared__ double perWarp[32];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  if (lane == 0) perWarp[warp] = v;
  __syncthreads();
  if (warp != 0) return v;
  v = lane < int((blockDim.x + 31) >> 5) ? perWarp[lane] : 0.0;
  for (int o = 16; o > 0; o >>= 1) v = op(v, __shfl_down_sync(0xffffffffu, v, o));
  return v;
}

// max over the items of f(i) >= 0: a warp-shuffle and shared-memory block reduction, then one atomic
// per block on the double's bit pattern (non-negative doubles order like their bits).
template <class F>
__global__ void maxOfKernel(Index n, F f, unsigned long long* result) {
  const Index i = blockIdx.x * blockDim.x + threadIdx.x;
  double v = i < n ? f(i) : 0.0;
  v = v > 0.0 ? v : 0.0;  // also drops NaN, as the OpenMP executor's `if (v > result)` does
  v = blockReduce(v, [](double a, double b) { return fmax(a, b); });
  if (threadIdx.x == 0 && v > 0.0) atomicMax(result, static_cast<unsigned long long>(__double_as_longlong(v)));
}

// sum over the items of f(i): a warp-shuffle and shared-memory block reduction, then one atomicAdd per
// block (the order of the blocks' additions varies from run to run: for diagnostics, not physics).
template <class F>
__global__ void sumOfKernel(Index n, F f, double* result) {
  const Index i = blockIdx.x * blockDim.x + threadIdx.x;
  const double v = blockReduce(i < n ? f(i) : 0.0, [](double a, double b) { return a + b; });
  if (threadIdx.x == 0) atomicAdd(result, v);
}

// Per-kernel block size by measurement (see the file comment).
class LaunchTuner {
 public:
  static constexpr int kCandidates[] = {64, 128, 256, 512};
  static constexpr int kRepeats = 3;
  static constexpr Index kMinItems = 1u << 16;  // smaller launches do not fill an H100: not timed
  static constexpr int kDefault = 128;

  struct Entry {
    std::string name;
    int maxThreads = 1024;
    int chosen = 0;  // 0 while tuning
    int calls = 0;
    std::vector<float> ms[4];
  };

  // The block size for the next launch of `kernel`, and whether it is a timed tuning launch.
  int blockFor(const void* kernel, const char* name, Index n, bool& timed);
  void record(const void* kernel, int block, float ms);
  // "ComputeForces 128 (64: 1.2 ms, 128: 1.0 ms, ...)" per tuned kernel.
  std::vector<std::string> report() const;
  void forceBlock(int block) { m_forced = block; }

 private:
  Entry& entry(const void* kernel, const char* name);
  std::map<const void*, Entry> m_entries;
  int m_forced = 0;
};

class CudaExecutor {
 public:
  static constexpr const char* kName = "cuda";
  static constexpr bool kColumnMajorLists = true;  // a warp reads 32 consecutive candidate words
  static constexpr bool kLockstepLanes = true;     // a warp's lanes wait through each other's branches (the SPH walk in two phases)
  static constexpr bool kSlotMajor = true;         // and 32 consecutive values of a history slot (SlotLayout)
  static constexpr bool kPairsOnce = false;        // each thread writes only its own particle: no atomics, one order
  // `threads` is the OpenMP setting of the CPU executor; the CUDA executor runs on the current device.
  explicit CudaExecutor(int threads = 0);
  ~CudaExecutor();
  CudaExecutor(const CudaExecutor&) = delete;
  CudaExecutor& operator=(const CudaExecutor&) = delete;

  MemorySpace& memory() { return m_memory; }
  std::string description() const;
  int device() const { return m_device; }

  template <class F>
  void forEach(Index n, const F& f) const {
    if (n == 0) return;
    if constexpr (constexpr int cap = maxRegistersOf<F>(); cap > 0) {
      launch(reinterpret_cast<const void*>(&forEachKernelCapped<cap, F>), typeid(F).name(), n,
             [&](unsigned grid, int block) { forEachKernelCapped<cap, F><<<grid, block>>>(n, f); });
      return;
    }
    launch(reinterpret_cast<const void*>(&forEachKernel<F>), typeid(F).name(), n,
           [&](unsigned grid, int block) { forEachKernel<F><<<grid, block>>>(n, f); });
  }

  template <class F>
  double maxOf(Index n, const F& f) const {
    if (n == 0) return 0.0;
    PFLOW_CUDA_CHECK(cudaMemsetAsync(m_reduce, 0, sizeof(unsigned long long)));
    unsigned long long* out = m_reduce;
    launch(reinterpret_cast<const void*>(&maxOfKernel<F>), typeid(F).name(), n,
           [&](unsigned grid, int block) { maxOfKernel<F><<<grid, block>>>(n, f, out); });
    unsigned long long bits = 0;
    PFLOW_CUDA_CHECK(cudaMemcpy(&bits, m_reduce, sizeof bits, cudaMemcpyDeviceToHost));
    double v;
    static_assert(sizeof v == sizeof bits);
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }

  // sum over i of f(i) (f returns double); 0 for n == 0.
  template <class F>
  double sumOf(Index n, const F& f) const {
    if (n == 0) return 0.0;
    PFLOW_CUDA_CHECK(cudaMemsetAsync(m_reduce, 0, sizeof(double)));
    double* out = reinterpret_cast<double*>(m_reduce);
    launch(reinterpret_cast<const void*>(&sumOfKernel<F>), typeid(F).name(), n,
           [&](unsigned grid, int block) { sumOfKernel<F><<<grid, block>>>(n, f, out); });
    double v = 0;
    PFLOW_CUDA_CHECK(cudaMemcpy(&v, m_reduce, sizeof v, cudaMemcpyDeviceToHost));
    return v;
  }

  void sortByKey(const std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm, Index* keyStart) const {
    m_algorithms->sortByKey(keys, n, numKeys, perm, keyStart);
  }
  // The same sort, `keys` overwritten, in lent memory (DeviceAlgorithms::sortByKeyLent).
  void sortByKeyLent(std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm, Index* keyStart, void* lent,
                     std::size_t lentBytes) const {
    m_algorithms->sortByKeyLent(keys, n, numKeys, perm, keyStart, lent, lentBytes);
  }
  std::uint64_t exclusiveScan(const std::uint32_t* in, std::uint32_t* out, Index n) const {
    return m_algorithms->exclusiveScan(in, out, n);
  }
  void synchronize() const { PFLOW_CUDA_CHECK(cudaDeviceSynchronize()); }

  std::vector<std::string> tuningReport() const { return m_tuner.report(); }

 private:
  template <class Launch>
  void launch(const void* kernel, const char* name, Index n, const Launch& go) const {
    bool timed = false;
    const int block = m_tuner.blockFor(kernel, name, n, timed);
    const unsigned grid = unsigned((std::uint64_t(n) + block - 1) / block);
    if (timed) PFLOW_CUDA_CHECK(cudaEventRecord(m_start));
    go(grid, block);
    PFLOW_CUDA_CHECK(cudaGetLastError());
    if (timed) {
      PFLOW_CUDA_CHECK(cudaEventRecord(m_stop));
      PFLOW_CUDA_CHECK(cudaEventSynchronize(m_stop));
      float ms = 0;
      PFLOW_CUDA_CHECK(cudaEventElapsedTime(&ms, m_start, m_stop));
      m_tuner.record(kernel, block, ms);
    }
  }

  int m_device = 0;
  CudaMemory m_memory;
  std::unique_ptr<DeviceAlgorithms> m_algorithms;
  unsigned long long* m_reduce = nullptr;
  cudaEvent_t m_start = nullptr, m_stop = nullptr;
  mutable LaunchTuner m_tuner;
};

}  // namespace pflow::compute::cuda
