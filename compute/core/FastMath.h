// Arithmetic helpers of the pair loops (the lowest set bit of a mask: lowestBit, core/Types.h). Square roots and quotients where float on the GPU may use the special-function unit's approximations instead of
// the correctly rounded sequences (a few instructions instead of about ten, and no slow path): the SPH pair terms,
// whose float runs are accurate to far less than these roundings (docs/sph.md, "Performance"), and the DEM contact
// law's roots and quotients of well-scaled operands (the effective radius, mass and inertia, sqrt(R* delta), the
// dashpot's sqrt(S_n m*), the history's rotation, the Coulomb cap's norm, the rolling spin's norm and limit): the float
// forces phase 8 % shorter on an H200 (docs/performance.md). On the CPU, and in double everywhere, they are the plain
// operations, so double runs agree across executors as before; float runs agree to a few roundings (2^-22, not 2^-24).
#pragma once
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "compute/core/Types.h"

namespace pflow::compute {

// sqrt(x) for x >= 0: PTX sqrt.approx.f32 in float on the GPU (relative error below 2^-22; 0 for 0).
template <class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R sqrtFast(R x) {
#if defined(__CUDA_ARCH__)
  if constexpr (std::is_same_v<R, float>) {
    float y;
    asm("sqrt.approx.f32 %0, %1;" : "=f"(y) : "f"(x));
    return y;
  }
#endif
  return std::sqrt(x);
}

// a / b for |b| in [2^-126, 2^126]: __fdividef in float on the GPU (2 ulp).
template <class R>
PFLOW_HOSTDEVICE PFLOW_FORCEINLINE R divFast(R a, R b) {
#if defined(__CUDA_ARCH__)
  if constexpr (std::is_same_v<R, float>) return __fdividef(a, b);
#endif
  return a / b;
}

}  // namespace pflow::compute
