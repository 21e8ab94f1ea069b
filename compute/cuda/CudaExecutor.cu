#include "compute/cuda/CudaExecutor.cuh"

#include <cxxabi.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace pflow::compute::cuda {

// ---- CudaMemory ----

void* CudaMemory::allocate(std::size_t bytes) {
  void* p = nullptr;
  const cudaError_t e = cudaMalloc(&p, bytes);
  if (e != cudaSuccess) {
    cudaGetLastError();  // clear the sticky-free error state of a failed allocation
    std::size_t freeBytes = 0, total = 0;
    cudaMemGetInfo(&freeBytes, &total);
    throw OutOfDeviceMemory("CUDA out of memory: allocating " + std::to_string(bytes) + " B with " +
                             std::to_string(bytesInUse()) + " B in use by this run and " + std::to_string(freeBytes) +
                             " B free of " + std::to_string(total) + " B (" + cudaGetErrorString(e) + ")");
  }
  m_sizes[p] = bytes;
  account(std::ptrdiff_t(bytes));
  return p;
}

void CudaMemory::deallocate(void* p) {
  auto it = m_sizes.find(p);
  if (it != m_sizes.end()) {
    account(-std::ptrdiff_t(it->second));
    m_sizes.erase(it);
  }
  cudaFree(p);  // never throws from a destructor path; an error here would resurface at the next check
}

void CudaMemory::copyToHost(void* d, const void* s, std::size_t b) {
  if (b) PFLOW_CUDA_CHECK(cudaMemcpy(d, s, b, cudaMemcpyDeviceToHost));
}
void CudaMemory::copyFromHost(void* d, const void* s, std::size_t b) {
  if (b) PFLOW_CUDA_CHECK(cudaMemcpy(d, s, b, cudaMemcpyHostToDevice));
}
void CudaMemory::copyWithin(void* d, const void* s, std::size_t b) {
  if (b) PFLOW_CUDA_CHECK(cudaMemcpyAsync(d, s, b, cudaMemcpyDeviceToDevice));
}
void CudaMemory::fillBytes(void* d, unsigned char v, std::size_t b) {
  if (b) PFLOW_CUDA_CHECK(cudaMemsetAsync(d, v, b));
}

// ---- LaunchTuner ----

namespace {
std::string kernelName(const char* mangled) {
  int status = 0;
  char* d = abi::__cxa_demangle(mangled, nullptr, nullptr, &status);
  std::string s = status == 0 && d ? d : mangled;
  std::free(d);
  for (const char* prefix : {"pflow::compute::kernels::", "pflow::compute::"})
    if (s.rfind(prefix, 0) == 0) s = s.substr(std::strlen(prefix));
  return s;
}
}  // namespace

LaunchTuner::Entry& LaunchTuner::entry(const void* kernel, const char* name) {
  auto it = m_entries.find(kernel);
  if (it != m_entries.end()) return it->second;
  Entry e;
  e.name = kernelName(name);
  cudaFuncAttributes attr{};
  PFLOW_CUDA_CHECK(cudaFuncGetAttributes(&attr, kernel));
  e.maxThreads = attr.maxThreadsPerBlock;
  return m_entries.emplace(kernel, std::move(e)).first->second;
}

int LaunchTuner::blockFor(const void* kernel, const char* name, Index n, bool& timed) {
  Entry& e = entry(kernel, name);
  timed = false;
  const int fallback = std::min(kDefault, e.maxThreads);
  if (m_forced) return std::min(m_forced, e.maxThreads);
  if (e.chosen) return e.chosen;
  if (n < kMinItems) return fallback;
  if (e.calls++ == 0) return fallback;  // the first launch loads the module: not timed
  int valid = 0;
  for (int c : kCandidates) valid += c <= e.maxThreads;
  timed = true;
  return kCandidates[(e.calls - 2) % valid];
}

void LaunchTuner::record(const void* kernel, int block, float ms) {
  Entry& e = m_entries.at(kernel);
  int valid = 0, k = 0;
  for (int c : kCandidates) {
    if (c == block) e.ms[k].push_back(ms);
    valid += c <= e.maxThreads;
    ++k;
  }
  for (int c = 0; c < valid; ++c)
    if (int(e.ms[c].size()) < kRepeats) return;
  float best = 0;
  for (int c = 0; c < valid; ++c) {
    std::vector<float> v = e.ms[c];
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    const float median = v[v.size() / 2];
    if (!e.chosen || median < best) {
      best = median;
      e.chosen = kCandidates[c];
    }
  }
}

std::vector<std::string> LaunchTuner::report() const {
  std::vector<std::string> lines;
  for (const auto& [kernel, e] : m_entries) {
    std::string s = e.name + " " + (e.chosen ? std::to_string(e.chosen) : std::string("untuned")) + " (";
    for (int c = 0; c < 4; ++c) {
      if (e.ms[c].empty()) continue;
      std::vector<float> v = e.ms[c];
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      char buf[64];
      std::snprintf(buf, sizeof buf, "%s%d: %.3f ms", s.back() == '(' ? "" : ", ", kCandidates[c], v[v.size() / 2]);
      s += buf;
    }
    lines.push_back(s + ")");
  }
  return lines;
}

// ---- CudaExecutor ----

CudaExecutor::CudaExecutor(int) {
  PFLOW_CUDA_CHECK(cudaGetDevice(&m_device));
  m_algorithms = std::make_unique<DeviceAlgorithms>(m_memory);
  PFLOW_CUDA_CHECK(cudaMalloc(&m_reduce, sizeof(unsigned long long)));
  PFLOW_CUDA_CHECK(cudaEventCreate(&m_start));
  PFLOW_CUDA_CHECK(cudaEventCreate(&m_stop));
  if (const char* forced = std::getenv("PFLOW_CUDA_BLOCK")) m_tuner.forceBlock(std::atoi(forced));
}

CudaExecutor::~CudaExecutor() {
  cudaEventDestroy(m_start);
  cudaEventDestroy(m_stop);
  cudaFree(m_reduce);
}

std::string CudaExecutor::description() const {
  cudaDeviceProp p{};
  cudaGetDeviceProperties(&p, m_device);
  char buf[256];
  std::snprintf(buf, sizeof buf, "CUDA on device %d (%s, %d SMs, %.1f GiB)", m_device, p.name, p.multiProcessorCount,
                double(p.totalGlobalMem) / double(1ull << 30));
  return buf;
}

}  // namespace pflow::compute::cuda
