#include "compute/core/CpuExecutor.h"

#include <omp.h>

#include <algorithm>
#include <cstdlib>

#include <string>
#include <vector>

namespace pflow::compute {

CpuExecutor::CpuExecutor(int threads)
    : m_threads(threads > 0 ? threads : omp_get_max_threads()), m_memory(m_threads) {
  if (const char* chunk = std::getenv("PFLOW_DYNAMIC_CHUNK")) m_dynamicChunk = std::max(0, std::atoi(chunk));
}

std::string CpuExecutor::description() const {
  return "OpenMP on " + std::to_string(m_threads) + " thread(s)";
}

void CpuExecutor::sortByKey(const std::uint32_t* keys, Index n, std::uint32_t numKeys, Index* perm,
                            Index* keyStart) const {
  // Histogram, scan, scatter. Sequential scatter keeps the order stable and the run deterministic;
  // sorting happens only on rebuild steps.
  std::fill(keyStart, keyStart + numKeys + 1, Index(0));
  for (Index i = 0; i < n; ++i) ++keyStart[keys[i] + 1];
  for (std::uint32_t c = 0; c < numKeys; ++c) keyStart[c + 1] += keyStart[c];
  std::vector<Index> cursor(keyStart, keyStart + numKeys);
  for (Index i = 0; i < n; ++i) perm[cursor[keys[i]]++] = i;
}

std::uint64_t CpuExecutor::exclusiveScan(const std::uint32_t* in, std::uint32_t* out, Index n) const {
  std::uint64_t total = 0;
  for (Index i = 0; i < n; ++i) {  // in place when in == out
    const std::uint32_t v = in[i];
    out[i] = static_cast<std::uint32_t>(total);
    total += v;
  }
  return total;
}

}  // namespace pflow::compute
