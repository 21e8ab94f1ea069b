// pflow-gpu-bandwidth: the device's measured copy bandwidth, the ceiling that docs/performance.md and
// pflow-bench compare each phase with. A device-to-device copy of a buffer far larger than L2,
// timed with events over many repetitions (median), counting bytes read plus bytes written.
// Prints one JSON line.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#define CHECK(x)                                                                    \
  do {                                                                              \
    cudaError_t e_ = (x);                                                           \
    if (e_ != cudaSuccess) {                                                        \
      std::fprintf(stderr, "%s: %s\n", #x, cudaGetErrorString(e_));                 \
      return 1;                                                                     \
    }                                                                               \
  } while (0)

__global__ void copyKernel(const double4_32a* __restrict__ src, double4_32a* __restrict__ dst, size_t n) {
  for (size_t i = blockIdx.x * size_t(blockDim.x) + threadIdx.x; i < n; i += size_t(gridDim.x) * blockDim.x)
    dst[i] = src[i];
}

int main() {
  int dev = 0;
  CHECK(cudaGetDevice(&dev));
  cudaDeviceProp p{};
  CHECK(cudaGetDeviceProperties(&p, dev));
  const size_t bytes = size_t(2) << 30;  // 2 GiB each way
  const size_t n = bytes / sizeof(double4_32a);
  double4_32a *a, *b;
  CHECK(cudaMalloc(&a, bytes));
  CHECK(cudaMalloc(&b, bytes));
  CHECK(cudaMemset(a, 1, bytes));  // not zeros
  cudaEvent_t t0, t1;
  CHECK(cudaEventCreate(&t0));
  CHECK(cudaEventCreate(&t1));
  auto median = [](std::vector<float> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  std::vector<float> memcpyMs, kernelMs;
  for (int r = 0; r < 22; ++r) {
    CHECK(cudaEventRecord(t0));
    CHECK(cudaMemcpyAsync(r % 2 ? a : b, r % 2 ? b : a, bytes, cudaMemcpyDeviceToDevice));
    CHECK(cudaEventRecord(t1));
    CHECK(cudaEventSynchronize(t1));
    float ms;
    CHECK(cudaEventElapsedTime(&ms, t0, t1));
    if (r >= 2) memcpyMs.push_back(ms);
    CHECK(cudaEventRecord(t0));
    copyKernel<<<p.multiProcessorCount * 8, 256>>>(r % 2 ? a : b, r % 2 ? b : a, n);
    CHECK(cudaGetLastError());
    CHECK(cudaEventRecord(t1));
    CHECK(cudaEventSynchronize(t1));
    CHECK(cudaEventElapsedTime(&ms, t0, t1));
    if (r >= 2) kernelMs.push_back(ms);
  }
  const double moved = 2.0 * double(bytes);
  std::printf("{\"device\": \"%s\", \"sms\": %d, \"l2_bytes\": %d, \"copy_bytes\": %zu, "
              "\"memcpy_gb_per_s\": %.1f, \"kernel_copy_gb_per_s\": %.1f}\n",
              p.name, p.multiProcessorCount, p.l2CacheSize, bytes, moved / (median(memcpyMs) * 1e-3) / 1e9,
              moved / (median(kernelMs) * 1e-3) / 1e9);
  return 0;
}
