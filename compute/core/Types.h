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
using Gid = std::uint64_t;    // global particle identity, stable across reorder and (later) migration
using Index = std::uint32_t;  // local index, valid until the next reorder
inline constexpr Gid kNoGid = ~Gid(0);
inline constexpr Index kNoIndex = ~Index(0);
}  // namespace pflow
