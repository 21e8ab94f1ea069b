#include "compute/core/Memory.h"

#include <cstdlib>
#include <new>

namespace pflow::compute {

namespace {
struct Header {
  std::size_t bytes;
  std::size_t pad[7];  // keeps the user block 64-byte aligned
};
}  // namespace

void* HostMemory::allocate(std::size_t bytes) {
  void* p = std::aligned_alloc(64, ((bytes + sizeof(Header) + 63) / 64) * 64);
  if (!p) throw std::bad_alloc();
  static_cast<Header*>(p)->bytes = bytes;
  account(static_cast<std::ptrdiff_t>(bytes));
  return static_cast<Header*>(p) + 1;
}

void HostMemory::deallocate(void* p) {
  if (!p) return;
  Header* h = static_cast<Header*>(p) - 1;
  account(-static_cast<std::ptrdiff_t>(h->bytes));
  std::free(h);
}

}  // namespace pflow::compute
