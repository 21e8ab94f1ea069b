// Basic types shared by host and device code. No STL containers, no protobuf, no MPI: nvcc sees this.
#pragma once
#include <cstdint>

#if defined(__CUDACC__)
#define PFLOW_HOSTDEVICE __host__ __device__
#define PFLOW_FORCEINLINE __forceinline__
#else
#define PFLOW_HOSTDEVICE
#define PFLOW_FORCEINLINE inline __attribute__((always_inline))
#endif

namespace pflow {

// Index of the lowest set bit of a non-zero mask.
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE int lowestBit(std::uint32_t mask) {
#if defined(__CUDA_ARCH__)
  return __ffs(int(mask)) - 1;
#else
  return __builtin_ctz(mask);
#endif
}

using Gid = std::uint64_t;    // global particle identity, stable across reorder and (later) migration
using Index = std::uint32_t;  // local index, valid until the next reorder
inline constexpr Gid kNoGid = ~Gid(0);
inline constexpr Index kNoIndex = ~Index(0);
}  // namespace pflow
