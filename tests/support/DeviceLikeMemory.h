// Host memory standing in for a device's in tests of the memory layer: byte accounting of its own, at most `limit`
// bytes at once (OutOfDeviceMemory beyond, as CudaMemory throws), and growing through the host
// (MemorySpace::growsThroughHost) as a GPU's memory does.
#pragma once
#include <cstddef>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "compute/core/Memory.h"

namespace pflow::test {

class DeviceLikeMemory final : public compute::MemorySpace {
 public:
  explicit DeviceLikeMemory(std::size_t limit = std::numeric_limits<std::size_t>::max()) : m_limit(limit) {}
  void* allocate(std::size_t bytes) override {
    if (bytes > m_limit - bytesInUse()) throw compute::OutOfDeviceMemory("device-like: " + std::to_string(bytes) + " B");
    account(std::ptrdiff_t(bytes));
    void* p = ::operator new(bytes);
    m_sizes.emplace_back(p, bytes);
    return p;
  }
  void deallocate(void* p) override {
    for (auto it = m_sizes.begin(); it != m_sizes.end(); ++it)
      if (it->first == p) {
        account(-std::ptrdiff_t(it->second));
        m_sizes.erase(it);
        break;
      }
    ::operator delete(p);
  }
  void copyToHost(void* d, const void* s, std::size_t b) override { std::memcpy(d, s, b); }
  void copyFromHost(void* d, const void* s, std::size_t b) override { std::memcpy(d, s, b); }
  void copyWithin(void* d, const void* s, std::size_t b) override { std::memcpy(d, s, b); }
  void fillBytes(void* d, unsigned char v, std::size_t b) override { std::memset(d, v, b); }
  bool growsThroughHost() const override { return true; }

 private:
  std::size_t m_limit;
  std::vector<std::pair<void*, std::size_t>> m_sizes;
};

}  // namespace pflow::test
