// Atomic helpers usable from kernels under every executor (CUDA atomics on the device,
// GCC/Clang builtins on the host, which nvcc's host pass also accepts).
#pragma once
#include <cstdint>

#include "compute/core/Types.h"

namespace pflow {

PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicOrU32(std::uint32_t* addr, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  atomicOr(reinterpret_cast<unsigned int*>(addr), v);
#else
  __atomic_fetch_or(addr, v, __ATOMIC_RELAXED);
#endif
}

#if !defined(__CUDA_ARCH__)
namespace detail {
// Host: stores v while `better(v, current)` holds, by compare-and-swap.
template <class Better>
inline void atomicUpdateU32(std::uint32_t* addr, std::uint32_t v, Better better) {
  std::uint32_t cur = __atomic_load_n(addr, __ATOMIC_RELAXED);
  while (better(v, cur) && !__atomic_compare_exchange_n(addr, &cur, v, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) {
  }
}
}  // namespace detail
#endif

PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicMaxU32(std::uint32_t* addr, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  atomicMax(reinterpret_cast<unsigned int*>(addr), v);
#else
  detail::atomicUpdateU32(addr, v, [](std::uint32_t a, std::uint32_t b) { return a > b; });
#endif
}

PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicMinU32(std::uint32_t* addr, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  atomicMin(reinterpret_cast<unsigned int*>(addr), v);
#else
  detail::atomicUpdateU32(addr, v, [](std::uint32_t a, std::uint32_t b) { return a < b; });
#endif
}

PFLOW_HOSTDEVICE PFLOW_FORCEINLINE std::uint32_t atomicAddU32(std::uint32_t* addr, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(reinterpret_cast<unsigned int*>(addr), v);
#else
  return __atomic_fetch_add(addr, v, __ATOMIC_RELAXED);
#endif
}

// Stores v at *addr if it holds `expected`; returns whether it did (history pool claims, one owner a key).
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE bool atomicCasU64(std::uint64_t* addr, std::uint64_t expected, std::uint64_t v) {
#if defined(__CUDA_ARCH__)
  return atomicCAS(reinterpret_cast<unsigned long long*>(addr), (unsigned long long)expected, (unsigned long long)v) ==
         (unsigned long long)expected;
#else
  return __atomic_compare_exchange_n(addr, &expected, v, false, __ATOMIC_RELAXED, __ATOMIC_RELAXED);
#endif
}

// Adds v to a float (the GPU's pairs-once forces: a pair's reaction to its partner, ComputeForces' kHalf).
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicAddF32(float* addr, float v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(addr, v);
#else
  std::uint32_t cur = __atomic_load_n(reinterpret_cast<std::uint32_t*>(addr), __ATOMIC_RELAXED);
  for (;;) {
    float f;
    __builtin_memcpy(&f, &cur, sizeof f);
    f += v;
    std::uint32_t next;
    __builtin_memcpy(&next, &f, sizeof f);
    if (__atomic_compare_exchange_n(reinterpret_cast<std::uint32_t*>(addr), &cur, next, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) return;
  }
#endif
}

// Adds v to a double (wall loads: a few addresses, on the steps that record them only).
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicAddF64(double* addr, double v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(addr, v);
#else
  std::uint64_t cur = __atomic_load_n(reinterpret_cast<std::uint64_t*>(addr), __ATOMIC_RELAXED);
  for (;;) {
    double d;
    __builtin_memcpy(&d, &cur, sizeof d);
    d += v;
    std::uint64_t next;
    __builtin_memcpy(&next, &d, sizeof d);
    if (__atomic_compare_exchange_n(reinterpret_cast<std::uint64_t*>(addr), &cur, next, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) return;
  }
#endif
}

}  // namespace pflow
