// Host pieces of the executor: the skin accumulator's rounding and the host memory space's parallel
// first touch, copies and fills.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "compute/core/Memory.h"
#include "compute/dem/integrate/VelocityVerlet.h"

// The skin accumulator rounds each sum away from zero by at most one unit in the last place, the way
// nextafterf would, and never below the exact sum: a slow creep still reaches the skin.
TEST(SkinAccumulator, AddUpNeverUnderReads) {
  using pflow::compute::kernels::addUp;
  const float accs[] = {0.0f, -0.0f, 1e-30f, 6e-5f, -6e-5f, 1.0f, -3.5e-7f, 1e-45f};
  const double steps[] = {1e-12, -1e-12, 3e-9, -3e-9, 1e-45, -1e-45, 2.5e-5, 0.0};
  for (float acc : accs)
    for (double dx : steps) {
      const double exact = double(acc) + dx;
      const float got = addUp(acc, dx);
      EXPECT_GE(std::fabs(double(got)), std::fabs(exact)) << acc << " + " << dx;
      const float nearest = float(exact);
      const float expected = std::fabs(double(nearest)) >= std::fabs(exact)
                                 ? nearest
                                 : std::nextafter(nearest, exact > 0 ? 3.0e38f : -3.0e38f);
      EXPECT_EQ(got, expected) << acc << " + " << dx;
    }
}

// Large host blocks are touched, copied and filled in shares by the executor's threads: same bytes as a
// plain memcpy/memset, whatever the share boundaries.
TEST(HostMemory, ParallelCopyAndFillMatchSerial) {
  pflow::compute::HostMemory mem(3);
  const std::size_t bytes = (std::size_t(3) << 20) + 7;  // above the parallel threshold, uneven shares
  unsigned char* a = static_cast<unsigned char*>(mem.allocate(bytes));
  unsigned char* b = static_cast<unsigned char*>(mem.allocate(bytes));
  for (std::size_t k = 0; k < bytes; ++k) EXPECT_EQ(a[k], 0) << k;  // first touch zeroes
  std::vector<unsigned char> host(bytes);
  for (std::size_t k = 0; k < bytes; ++k) host[k] = static_cast<unsigned char>(k * 2654435761u >> 13);
  mem.copyFromHost(a, host.data(), bytes);
  mem.copyWithin(b, a, bytes);
  std::vector<unsigned char> back(bytes);
  mem.copyToHost(back.data(), b, bytes);
  EXPECT_EQ(back, host);
  mem.fillBytes(b + 1, 0xAB, bytes - 2);
  mem.copyToHost(back.data(), b, bytes);
  EXPECT_EQ(back.front(), host.front());
  EXPECT_EQ(back.back(), host.back());
  for (std::size_t k = 1; k + 1 < bytes; ++k) ASSERT_EQ(back[k], 0xAB) << k;
  mem.deallocate(a);
  mem.deallocate(b);
  EXPECT_EQ(mem.bytesInUse(), 0u);
}
