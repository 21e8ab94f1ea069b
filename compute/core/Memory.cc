#include "compute/core/Memory.h"

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>

namespace pflow::compute {

namespace {
struct Header {
  std::size_t bytes;
  std::size_t pad[7];  // keeps the user block 64-byte aligned
};
}  // namespace

// Below this a block is handled by the calling thread: waking the team costs more than the copy.
constexpr std::size_t kParallelBytes = std::size_t(1) << 20;

// f(begin, end) on `threads` equal contiguous shares of [0, bytes), share t on thread t (the split of a
// static OpenMP loop over the elements of any fixed-size type, up to one element at the seams).
template <class F>
void inShares(int threads, std::size_t bytes, const F& f) {
  if (bytes < kParallelBytes || threads <= 1) {
    f(std::size_t(0), bytes);
    return;
  }
#pragma omp parallel num_threads(threads)
  {
    const std::size_t t = std::size_t(omp_get_thread_num()), nt = std::size_t(omp_get_num_threads());
    const std::size_t begin = bytes / nt * t + std::min(t, bytes % nt);
    const std::size_t end = begin + bytes / nt + (t < bytes % nt ? 1 : 0);
    f(begin, end);
  }
}

HostMemory::HostMemory(int threads) : m_threads(threads) {
  const char* env = std::getenv("PFLOW_FIRST_TOUCH");
  m_firstTouch = !(env && std::string(env) == "0");
}

void* HostMemory::allocate(std::size_t bytes) {
  void* p = std::aligned_alloc(64, ((bytes + sizeof(Header) + 63) / 64) * 64);
  if (!p) throw std::bad_alloc();
  static_cast<Header*>(p)->bytes = bytes;
  account(static_cast<std::ptrdiff_t>(bytes));
  auto* user = reinterpret_cast<unsigned char*>(static_cast<Header*>(p) + 1);
  // First touch by the threads that will work on each share (only the pages' placement matters).
  if (m_firstTouch) inShares(m_threads, bytes, [&](std::size_t b, std::size_t e) { std::memset(user + b, 0, e - b); });
  return user;
}

void HostMemory::copy(void* d, const void* s, std::size_t b) const {
  if (!b) return;
  inShares(m_threads, b, [&](std::size_t lo, std::size_t hi) {
    std::memcpy(static_cast<unsigned char*>(d) + lo, static_cast<const unsigned char*>(s) + lo, hi - lo);
  });
}

void HostMemory::fillBytes(void* d, unsigned char v, std::size_t b) {
  if (!b) return;
  inShares(m_threads, b, [&](std::size_t lo, std::size_t hi) { std::memset(static_cast<unsigned char*>(d) + lo, v, hi - lo); });
}

void HostMemory::deallocate(void* p) {
  if (!p) return;
  Header* h = static_cast<Header*>(p) - 1;
  account(-static_cast<std::ptrdiff_t>(h->bytes));
  std::free(h);
}

}  // namespace pflow::compute
