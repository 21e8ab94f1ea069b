// Host pieces of the executor: the skin accumulator's rounding, the host memory space's parallel
// first touch, copies and fills, how a buffer grows in a device's memory, and the order of the two colours.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "compute/core/CpuExecutor.h"
#include "compute/core/Memory.h"
#include "compute/dem/integrate/VelocityVerlet.h"
#include "tests/support/DeviceLikeMemory.h"

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

namespace {

using pflow::test::DeviceLikeMemory;

std::vector<unsigned char> contents(pflow::compute::Buffer& b, std::size_t bytes) {
  std::vector<unsigned char> out(bytes);
  b.space()->copyToHost(out.data(), b.data(), bytes);
  return out;
}

// Fills the whole block with byte k = a k + c and returns what it wrote.
std::vector<unsigned char> fill(pflow::compute::Buffer& b, unsigned a, unsigned c) {
  std::vector<unsigned char> pattern(b.bytes());
  for (std::size_t k = 0; k < pattern.size(); ++k) pattern[k] = static_cast<unsigned char>(a * k + c);
  b.space()->copyFromHost(b.data(), pattern.data(), pattern.size());
  return pattern;
}

}  // namespace

// A slot field growing on a device never holds the old and the grown block at once: a 60-byte block grows to 100
// in a space of 100 bytes, its contents kept, the peak the grown size (beside the old one it would need 160).
TEST(BufferGrowth, ThroughTheHostNeverHoldsBothBlocks) {
  DeviceLikeMemory mem(100);
  pflow::compute::Buffer b(mem, 60);
  const std::vector<unsigned char> pattern = fill(b, 7, 1);
  b.growKeep(100);
  EXPECT_EQ(b.bytes(), 100u);
  EXPECT_EQ(contents(b, 60), pattern);
  EXPECT_EQ(mem.peakBytes(), 100u);
  EXPECT_EQ(mem.bytesInUse(), 100u);
}

// Growing with pieces moved (Buffer::growPlaced, the capacity growth of slot-major columns): each piece lands at its
// new offset, through the host without holding both blocks; a growth that does not fit puts each piece back where it
// was.
TEST(BufferGrowth, PlacedPiecesMoveThroughTheHostAndComeBackOnFailure) {
  DeviceLikeMemory mem(100);
  pflow::compute::Buffer b(mem, 40);
  const std::vector<unsigned char> pattern = fill(b, 5, 3);
  // Two columns of 20 bytes, 15 of them kept, to columns of 40.
  const std::vector<pflow::compute::Buffer::Move> moves{{0, 0, 15}, {20, 40, 15}};
  EXPECT_THROW(b.growPlaced(120, moves), pflow::compute::OutOfDeviceMemory);
  EXPECT_EQ(b.bytes(), 40u);
  const std::vector<unsigned char> back = contents(b, 40);
  EXPECT_TRUE(std::equal(pattern.begin(), pattern.begin() + 15, back.begin()));
  EXPECT_TRUE(std::equal(pattern.begin() + 20, pattern.begin() + 35, back.begin() + 20));
  b.growPlaced(80, moves);
  EXPECT_EQ(b.bytes(), 80u);
  const std::vector<unsigned char> grown = contents(b, 80);
  EXPECT_TRUE(std::equal(pattern.begin(), pattern.begin() + 15, grown.begin()));
  EXPECT_TRUE(std::equal(pattern.begin() + 20, pattern.begin() + 35, grown.begin() + 40));
  EXPECT_EQ(mem.peakBytes(), 80u);
}

// A growth that does not fit fails with the device's error and leaves the block as it was: its size, its contents.
TEST(BufferGrowth, AGrowthThatDoesNotFitKeepsTheBlock) {
  DeviceLikeMemory mem(100);
  pflow::compute::Buffer b(mem, 60);
  const std::vector<unsigned char> pattern = fill(b, 253, 255);  // 255 - 3 k modulo 256
  EXPECT_THROW(b.growKeep(120), pflow::compute::OutOfDeviceMemory);
  EXPECT_EQ(b.bytes(), 60u);
  EXPECT_EQ(contents(b, 60), pattern);
  EXPECT_EQ(mem.bytesInUse(), 60u);
}

// CpuExecutor::forEachTwoColours runs every item once, and an odd item only after both its even neighbours have
// returned (ComputePairsOnce's slabs write their own layer and the next: an odd slab started early would race with
// them). The even items sleep, so that an odd item started without waiting for them would be seen; and the odd items
// do not all wait for the whole even colour (no barrier), checked where the last even item is slow.
TEST(CpuExecutorColours, OddItemsWaitForTheirEvenNeighboursOnly) {
  for (const pflow::Index n : {1u, 2u, 3u, 9u, 40u, 41u}) {
    pflow::compute::CpuExecutor exec(4);
    std::atomic<int> clock{0};
    std::vector<int> begin(n, -1), end(n, -1), runs(n, 0);
    exec.forEachTwoColours(n, [&](pflow::Index k) {
      begin[k] = clock.fetch_add(1);
      ++runs[k];
      if (k % 2 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(k + 2 >= n ? 60 : 2));
      end[k] = clock.fetch_add(1);
    });
    for (pflow::Index k = 0; k < n; ++k) {
      EXPECT_EQ(runs[k], 1) << "item " << k << " of " << n;
      if (k % 2 == 0) continue;
      EXPECT_GT(begin[k], end[k - 1]) << "item " << k << " of " << n;
      if (k + 1 < n) EXPECT_GT(begin[k], end[k + 1]) << "item " << k << " of " << n;
    }
    if (n >= 40) {  // the first odd item ran long before the slow last even one ended
      const pflow::Index lastEven = (n - 1) % 2 == 0 ? n - 1 : n - 2;
      EXPECT_LT(end[1], end[lastEven]) << n;
    }
  }
}
