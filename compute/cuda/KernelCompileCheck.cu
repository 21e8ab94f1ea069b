// Compiles every kernel functor of the step loop as CUDA device code, so the physics written for the
// OpenMP executor is proven to build for the GPU (sm_90) until the CUDA executor instantiates them
// for real. A `gpu` test launches one of them where a device is present.
#include "compute/contact/ForceKernel.h"
#include "compute/cuda/KernelCompileCheck.cuh"

#include <vector>
#include "compute/geometry/MeshKernels.h"
#include "compute/integrate/VelocityVerlet.h"
#include "compute/neighbor/NeighborKernels.h"

namespace pflow::compute::gpu {

template <class F>
__global__ void forEachKernel(Index n, F f) {
  const Index i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

// Kernels that return a value per item (for a max-reduction): store it.
template <class F>
__global__ void mapKernel(Index n, F f, double* out) {
  const Index i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) out[i] = f(i);
}

template __global__ void forEachKernel<kernels::ComputeForces>(Index, kernels::ComputeForces);
template __global__ void forEachKernel<kernels::IntegrateSecondHalf>(Index, kernels::IntegrateSecondHalf);
template __global__ void mapKernel<kernels::IntegrateFirstHalf>(Index, kernels::IntegrateFirstHalf, double*);
template __global__ void mapKernel<kernels::MoveTriangles>(Index, kernels::MoveTriangles, double*);
template __global__ void forEachKernel<kernels::CellKey>(Index, kernels::CellKey);
template __global__ void forEachKernel<kernels::GatherBytes>(Index, kernels::GatherBytes);
template __global__ void forEachKernel<kernels::BuildNeighbors>(Index, kernels::BuildNeighbors);
template __global__ void forEachKernel<kernels::BinTriangles>(Index, kernels::BinTriangles);
template __global__ void forEachKernel<kernels::SortBins>(Index, kernels::SortBins);
template __global__ void forEachKernel<kernels::WallCandidates>(Index, kernels::WallCandidates);

// Free fall of n particles for `steps` steps on the device, through the same integrator functors as
// the CPU path; returns cudaSuccess or the first error.
int freeFallOnDevice(Vec3d* hostPos, Vec3d* hostVel, Index n, double dt, int steps, Vec3d gravity) {
  Vec3d *pos, *vel, *omega, *force, *torque, *ref;
  double *radius, *mass, *scratch;
  Conditions* cond;
  const std::size_t v3 = n * sizeof(Vec3d), d1 = n * sizeof(double);
  cudaError_t err = cudaSuccess;
  auto check = [&](cudaError_t e) { if (err == cudaSuccess) err = e; };
  check(cudaMalloc(&pos, v3)); check(cudaMalloc(&vel, v3)); check(cudaMalloc(&omega, v3));
  check(cudaMalloc(&force, v3)); check(cudaMalloc(&torque, v3)); check(cudaMalloc(&ref, v3));
  check(cudaMalloc(&radius, d1)); check(cudaMalloc(&mass, d1)); check(cudaMalloc(&scratch, d1));
  check(cudaMalloc(&cond, sizeof(Conditions)));
  if (err != cudaSuccess) return int(err);
  check(cudaMemcpy(pos, hostPos, v3, cudaMemcpyHostToDevice));
  check(cudaMemcpy(ref, hostPos, v3, cudaMemcpyHostToDevice));
  check(cudaMemcpy(vel, hostVel, v3, cudaMemcpyHostToDevice));
  check(cudaMemset(omega, 0, v3)); check(cudaMemset(force, 0, v3)); check(cudaMemset(torque, 0, v3));
  std::vector<double> ones(n, 1.0);
  check(cudaMemcpy(radius, ones.data(), d1, cudaMemcpyHostToDevice));
  check(cudaMemcpy(mass, ones.data(), d1, cudaMemcpyHostToDevice));
  Conditions c0;
  check(cudaMemcpy(cond, &c0, sizeof c0, cudaMemcpyHostToDevice));
  const kernels::IntegrateArgs a{pos, vel, omega, force, torque, radius, mass, ref, gravity, dt, cond};
  const unsigned blocks = (n + 127) / 128;
  for (int s = 0; s < steps && err == cudaSuccess; ++s) {
    mapKernel<<<blocks, 128>>>(n, kernels::IntegrateFirstHalf{a}, scratch);
    forEachKernel<<<blocks, 128>>>(n, kernels::IntegrateSecondHalf{a});
    check(cudaGetLastError());
  }
  check(cudaMemcpy(hostPos, pos, v3, cudaMemcpyDeviceToHost));
  check(cudaMemcpy(hostVel, vel, v3, cudaMemcpyDeviceToHost));
  for (void* p : {(void*)pos, (void*)vel, (void*)omega, (void*)force, (void*)torque, (void*)ref, (void*)radius,
                  (void*)mass, (void*)scratch, (void*)cond})
    cudaFree(p);
  return int(err);
}

int deviceCount() {
  int n = 0;
  // Without a GPU (or a driver) this fails: treat every error as no device.
  if (cudaGetDeviceCount(&n) != cudaSuccess) return 0;
  return n;
}

}  // namespace pflow::compute::gpu
