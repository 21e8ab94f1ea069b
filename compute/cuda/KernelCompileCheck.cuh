// Launch functions of the CUDA compile check (plain C++ interface: no CUDA types).
#pragma once
#include <vector>

#include "compute/core/VectorMath.h"

namespace pflow::compute::gpu {
int deviceCount();
// Integrates free fall of n unit-mass particles on the GPU with the step loop's integrator kernels.
int freeFallOnDevice(Vec3d* pos, Vec3d* vel, Index n, double dt, int steps, Vec3d gravity);
}  // namespace pflow::compute::gpu
