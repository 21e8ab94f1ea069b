// Atomic helpers usable from kernels under every executor (CUDA atomics on the device,
// GCC/Clang builtins on the host, which nvcc's host pass also accepts).
#pragma once
#include <cstdint>
#include <type_traits>

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

#if !defined(__CUDA_ARCH__)
namespace detail {
// Host: adds v to the T at addr (its bits a Bits) by compare-and-swap.
template <class T, class Bits>
inline void atomicAddByCas(T* addr, T v) {
  Bits cur = __atomic_load_n(reinterpret_cast<Bits*>(addr), __ATOMIC_RELAXED);
  for (;;) {
    T x;
    __builtin_memcpy(&x, &cur, sizeof x);
    x += v;
    Bits next;
    __builtin_memcpy(&next, &x, sizeof x);
    if (__atomic_compare_exchange_n(reinterpret_cast<Bits*>(addr), &cur, next, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED)) return;
  }
}
}  // namespace detail
#endif

// Adds v to a float or a double: wall loads (a few addresses, on the steps that record them only) and the GPU's pairs
// once (a pair's reaction to its partner, ComputeForces' kHalf).
template <class T>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicAddReal(T* addr, T v) {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>);
#if defined(__CUDA_ARCH__)
  atomicAdd(addr, v);
#else
  detail::atomicAddByCas<T, std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>(addr, v);
#endif
}
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicAddF64(double* addr, double v) { atomicAddReal(addr, v); }

// A float sum of three components in a 16-byte row: the GPU adds to it with one vector atomic add (red.v4.f32,
// sm_90) where three float adds took twice as long (bench/RESULTS.md, "The GPU's pairs once").
struct alignas(16) Sum4 {
  float x, y, z, w;
};
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicAddSum4(Sum4* p, float x, float y, float z) {
#if defined(__CUDA_ARCH__)
  atomicAdd(reinterpret_cast<float4*>(p), make_float4(x, y, z, 0.f));
#else
  atomicAddReal(&p->x, x), atomicAddReal(&p->y, y), atomicAddReal(&p->z, z);
#endif
}
// All four components (the SPH pairs once: a pair's acceleration and density rate for its partner).
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE void atomicAddSum4(Sum4* p, float x, float y, float z, float w) {
#if defined(__CUDA_ARCH__)
  atomicAdd(reinterpret_cast<float4*>(p), make_float4(x, y, z, w));
#else
  atomicAddReal(&p->x, x), atomicAddReal(&p->y, y), atomicAddReal(&p->z, z), atomicAddReal(&p->w, w);
#endif
}

}  // namespace pflow
