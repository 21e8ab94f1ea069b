// This pflow was built without nvcc: the CUDA executor is absent and says so.
#include "compute/dem/Engine.h"
#include "compute/sph/SphEngine.h"

namespace pflow::compute {

int cudaDeviceCount() { return 0; }
bool cudaBuiltIn() { return false; }

Result<std::unique_ptr<Engine>> makeCudaEngine(EngineSetup, int, bool) {
  return Status(StatusCode::kFailedPrecondition,
                "--executor cuda: this pflow was built without CUDA (nvcc was not found at configure time)");
}

namespace sph {
Result<std::unique_ptr<SphEngine>> makeCudaSphEngine(SphSetup, int, bool) {
  return Status(StatusCode::kFailedPrecondition,
                "--executor cuda: this pflow was built without CUDA (nvcc was not found at configure time)");
}
}  // namespace sph

}  // namespace pflow::compute
