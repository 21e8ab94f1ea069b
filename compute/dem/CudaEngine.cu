// The engine on the CUDA executor: the same EngineImpl as the OpenMP path, instantiated with
// CudaExecutor, so every phase runs the same kernel functors on the GPU.
#include "compute/cuda/CudaExecutor.cuh"
#include "compute/dem/EngineImpl.h"

namespace pflow::compute {

template class EngineImpl<cuda::CudaExecutor, double>;
template class EngineImpl<cuda::CudaExecutor, float>;

int cudaDeviceCount() {
  int n = 0;
  // Without a GPU or a driver this fails ("CUDA driver version is insufficient"): no device.
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return n;
}

bool cudaBuiltIn() { return true; }

Result<std::unique_ptr<Engine>> makeCudaEngine(EngineSetup setup, int device, bool singlePrecision) {
  const int count = cudaDeviceCount();
  if (count == 0) return Status(StatusCode::kFailedPrecondition, "--executor cuda: no CUDA device is visible to this process");
  if (device < 0 || device >= count)
    return invalidArgument("CUDA device " + std::to_string(device) + " does not exist (" + std::to_string(count) +
                           " visible)");
  try {
    PFLOW_CUDA_CHECK(cudaSetDevice(device));
    if (singlePrecision)
      return std::unique_ptr<Engine>(std::make_unique<EngineImpl<cuda::CudaExecutor, float>>(std::move(setup)));
    return std::unique_ptr<Engine>(std::make_unique<EngineImpl<cuda::CudaExecutor, double>>(std::move(setup)));
  } catch (const std::exception& e) {
    return Status(StatusCode::kResourceExhausted, e.what());
  }
}

}  // namespace pflow::compute
