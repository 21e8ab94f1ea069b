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
// After a lambda's parameters: inlined where it is called (device code inlines lambdas anyway).
#if defined(__CUDA_ARCH__)
#define PFLOW_FORCEINLINE_LAMBDA
#else
#define PFLOW_FORCEINLINE_LAMBDA __attribute__((always_inline))
#endif

namespace pflow {

// Most points of a wall's piecewise-linear velocity profile (motion.velocity_profile): held inline in the motion's
// device parameters.
inline constexpr int kMaxProfilePoints = 16;

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
// A history slot's partner: the partner's gid in 32 bits (runs hold fewer than 2^32 - 1 particles; the
// setup refuses more), kNoPartner when the slot is empty.
using PartnerId = std::uint32_t;
inline constexpr PartnerId kNoPartner = ~PartnerId(0);
inline constexpr Gid kMaxParticles = Gid(kNoPartner);

// One particle's slots of a slot field (contact history): slot k of particle i at p[i * row + k * col].
template <class T>
struct SlotRow {
  T* p;                // slot 0 of particle i
  std::size_t stride;  // between consecutive slots
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE T& operator[](int k) const { return p[std::size_t(k) * stride]; }
};

// How a slot field is laid out, chosen by the executor: slot-major on the GPU (row 1, col n: a warp's 32
// consecutive particles touch 32 consecutive values of a slot, slots grow by appending columns, reorder
// needs one column of scratch), particle-major on the CPU (row = slots, col 1: a core walks one
// particle's slots in one or two cache lines).
struct SlotLayout {
  std::size_t row = 1, col = 1;
  template <class T>
  PFLOW_HOSTDEVICE PFLOW_FORCEINLINE SlotRow<T> at(T* base, Index i) const { return {base + std::size_t(i) * row, col}; }
};
}  // namespace pflow
