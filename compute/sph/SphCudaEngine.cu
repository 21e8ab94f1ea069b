// The SPH engine on the CUDA executor: the same SphEngineImpl as the OpenMP path, so every phase runs the
// same kernels on the GPU.
#include "compute/cuda/CudaCheck.h"
#include "compute/cuda/CudaExecutor.cuh"
#include "compute/dem/Engine.h"
#include "compute/sph/SphEngineImpl.h"

namespace pflow::compute::sph {

template class SphEngineImpl<cuda::CudaExecutor, double>;
template class SphEngineImpl<cuda::CudaExecutor, float>;

Result<std::unique_ptr<SphEngine>> makeCudaSphEngine(SphSetup setup, int device, bool singlePrecision) {
  const int count = cudaDeviceCount();
  if (count == 0) return Status(StatusCode::kFailedPrecondition, "--executor cuda: no CUDA device is visible to this process");
  if (device < 0 || device >= count)
    return invalidArgument("CUDA device " + std::to_string(device) + " does not exist (" + std::to_string(count) + " visible)");
  try {
    PFLOW_CUDA_CHECK(cudaSetDevice(device));
    if (singlePrecision)
      return std::unique_ptr<SphEngine>(std::make_unique<SphEngineImpl<cuda::CudaExecutor, float>>(std::move(setup)));
    return std::unique_ptr<SphEngine>(std::make_unique<SphEngineImpl<cuda::CudaExecutor, double>>(std::move(setup)));
  } catch (const std::exception& e) {
    return Status(StatusCode::kResourceExhausted, e.what());
  }
}

}  // namespace pflow::compute::sph
